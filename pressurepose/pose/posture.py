"""Posture class of a lying body from its root orientation: supine, prone, left or right lateral.

The body's roll about its own long axis decides: with ``front`` the world direction the body faces
and ``left`` the world direction of its left side (both from the SMPL root rotation, z-up world),
``roll = atan2(-left_z, front_z)`` is 0 lying on the back, +90 deg on the left side, +-180 deg on the
front, -90 deg on the right side. Each class spans 90 degrees of roll, centred on those values.
"""

from __future__ import annotations

import numpy as np

from pressurepose.body.lbs_numpy import Y_UP_TO_Z_UP, rodrigues
from pressurepose.errors import BadInput

POSTURES: tuple[str, ...] = ("supine", "left_lateral", "prone", "right_lateral")


def roll_angle(pose) -> np.ndarray:
    """Roll (B,) radians in (-pi, pi] of bodies with SMPL pose (B, 72) or (B, 3) root axis-angle;
    a single pose (72,) or (3,) gives a 0-d array."""
    p = np.asarray(pose, dtype=np.float64)
    if p.shape[-1] not in (3, 72) or not np.all(np.isfinite(p)):
        raise BadInput(f"pose has shape {p.shape}; expected finite (..., 72) SMPL pose or (..., 3) root "
                       f"axis-angle")
    Q = Y_UP_TO_Z_UP
    return roll_of_rotation(Q @ rodrigues(p[..., :3]) @ Q.T)


def roll_of_rotation(W) -> np.ndarray:
    """Roll (...,) radians of bodies whose z-up rest body is turned by world rotations W (..., 3, 3)
    (e.g. the ragdoll root body's ``xmat``): the rest body faces -y and its left is +x, so
    front_z = -W[2, 1] and left_z = W[2, 0]."""
    W = np.asarray(W, dtype=np.float64)
    return np.arctan2(-W[..., 2, 0], -W[..., 2, 1])


def posture_class(pose) -> str:
    """'supine', 'left_lateral', 'prone' or 'right_lateral' for one SMPL pose (72,) (or root (3,))."""
    p = np.asarray(pose, dtype=np.float64)
    if p.ndim != 1:
        raise BadInput(f"pose has shape {p.shape}; expected one pose (72,) (use posture_classes for a batch)")
    return str(posture_classes(p[None])[0])


def posture_classes(poses) -> np.ndarray:
    """(B,) posture names of SMPL poses (B, 72) (or root axis-angles (B, 3))."""
    return np.array(POSTURES)[posture_index(roll_angle(poses))]


def posture_index(roll) -> np.ndarray:
    """Index into ``POSTURES`` of rolls (...,) radians."""
    return np.floor((np.asarray(roll) + np.pi / 4) / (np.pi / 2)).astype(np.int64) % 4
