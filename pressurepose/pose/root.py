"""The global transform of a body lying on the bed: roll, yaw (pitch 0) to SMPL's root axis-angle.

Bed frame (whole project): metres, origin at the head-end left corner of the mat's sensing area on
the unloaded mattress surface, x across the bed, y along it toward the foot, z up.

Roll 0, yaw 0 is the body lying supine along the bed: head toward y = 0 (row 0), face up (+z), the
body's left toward -x. ``roll`` is a right-handed rotation about the body's head direction (the bed's
-y axis before yaw): +pi/2 lays the body on its left side, -pi/2 on its right side, +-pi prone. ``yaw``
then turns the body about the bed's z axis (right-handed, seen from above: counter-clockwise).

The body model's output for a root axis-angle r is ``W @ rest`` with ``W = Q R(r) Q^T`` (Q =
``Y_UP_TO_Z_UP``), so the root pose for a world rotation W is ``r = Q^T rotvec(W)``.
"""

from __future__ import annotations

import numpy as np

from pressurepose.body.lbs_numpy import Y_UP_TO_Z_UP, rotation_to_axis_angle

# z-up rest body (head +z, face -y, left +x) -> supine on the bed (head -y, face +z, left -x)
SUPINE = np.array([[-1.0, 0.0, 0.0], [0.0, 0.0, -1.0], [0.0, -1.0, 0.0]])


def world_rotation(roll, yaw) -> np.ndarray:
    """World rotations (B, 3, 3) of the z-up rest body for roll, yaw (B,) rad (see module doc)."""
    roll = np.atleast_1d(np.asarray(roll, dtype=np.float64))
    yaw = np.atleast_1d(np.asarray(yaw, dtype=np.float64))
    cr, sr, cy, sy = np.cos(roll), np.sin(roll), np.cos(yaw), np.sin(yaw)
    one, zero = np.ones_like(cr), np.zeros_like(cr)
    # right-handed rotation by `roll` about -y is a rotation by -roll about +y
    about_head = np.stack([cr, zero, -sr, zero, one, zero, sr, zero, cr], -1).reshape(-1, 3, 3)
    about_z = np.stack([cy, -sy, zero, sy, cy, zero, zero, zero, one], -1).reshape(-1, 3, 3)
    return about_z @ about_head @ SUPINE


def root_axis_angle(W: np.ndarray) -> np.ndarray:
    """SMPL root axis-angle (B, 3) giving world rotations W (B, 3, 3) of the z-up rest body."""
    return rotation_to_axis_angle(W) @ Y_UP_TO_Z_UP  # row-vector form of Q^T w


def root_rotation(root_pose: np.ndarray) -> np.ndarray:
    """World rotations W (B, 3, 3) of the z-up rest body for SMPL root axis-angles (B, 3)."""
    from pressurepose.body.lbs_numpy import rodrigues

    Q = Y_UP_TO_Z_UP
    return Q @ rodrigues(np.atleast_2d(root_pose)) @ Q.T


def body_axes(W: np.ndarray) -> dict[str, np.ndarray]:
    """World directions (B, 3) of the body's head, face (front) and left for rotations W (B, 3, 3)."""
    return {"head": W[..., :, 2], "face": -W[..., :, 1], "left": W[..., :, 0]}
