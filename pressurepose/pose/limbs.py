"""The four sampled limbs: their joint chains, angle boxes and forward kinematics of many candidates.

Only the limb joints move while sampling (spine, neck, ankles, wrists are held at 0), so a limb's
joints follow from the shaped rest joints and the limb's own local rotations. Everything here works
in SMPL's y-up model frame, relative to the rest pelvis; :func:`to_world` maps to the bed frame.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from pressurepose.body.capsules import CAPSULE_JOINTS, CAPSULE_NAMES
from pressurepose.body.joints import joint_index
from pressurepose.pose.limits import JointLimits


@dataclass(frozen=True)
class Limb:
    """A limb: chain joints (proximal first), the joints judged for bins, height and the mattress,
    the capsules it carries, and whether it is a leg (else an arm)."""

    name: str
    side: int  # 0 left, 1 right
    is_leg: bool
    chain: tuple[int, ...]
    proximal: int  # hip or shoulder joint (binned against)
    distal: int  # ankle or wrist
    on_bed: tuple[int, ...]  # joints that must lie over the mattress for limbs_on_bed
    capsules: tuple[int, ...]  # capsule indices moved by this limb

    @property
    def moving(self) -> int:
        """Number of leading chain joints the sampler rotates (hip, knee / collar, shoulder, elbow)."""
        return 2 if self.is_leg else 3

    def box(self, limits: JointLimits, straight: bool) -> tuple[np.ndarray, np.ndarray]:
        """Lower and upper bounds (D,) of the sampled angles: the hip's (x, y, z) or the total
        shoulder rotation's, then the knee or elbow angle unless ``straight``."""
        if self.is_leg:
            lo, hi = limits.lower[self.chain[0]], limits.upper[self.chain[0]]
        else:
            lo, hi = limits.shoulder_lower[self.side], limits.shoulder_upper[self.side]
        if straight:
            return lo.copy(), hi.copy()
        hinge_joint = self.chain[1] if self.is_leg else self.chain[2]
        axis = limits.hinge_axis[hinge_joint]
        return (np.append(lo, limits.lower[hinge_joint, axis]), np.append(hi, limits.upper[hinge_joint, axis]))

    def local_axis_angles(self, angles: np.ndarray, limits: JointLimits) -> np.ndarray:
        """SMPL local axis-angles (..., len(chain), 3) of the chain joints for sampled angles (..., D)."""
        out = np.zeros(angles.shape[:-1] + (len(self.chain), 3))
        if self.is_leg:
            out[..., 0, :] = angles[..., :3]
            hinge_at = 1
        else:
            out[..., 0, :] = limits.shoulder_split * angles[..., :3]
            out[..., 1, :] = (1.0 - limits.shoulder_split) * angles[..., :3]
            hinge_at = 2
        if angles.shape[-1] > 3:
            out[..., hinge_at, limits.hinge_axis[self.chain[hinge_at]]] = angles[..., 3]
        return out


def _limb(name: str, side: int, is_leg: bool, chain: tuple[str, ...], on_bed: tuple[str, ...],
          capsules: tuple[str, ...]) -> Limb:
    j = tuple(joint_index(n) for n in chain)
    return Limb(name, side, is_leg, j, j[0] if is_leg else j[1], j[2] if is_leg else j[3],
                tuple(joint_index(n) for n in on_bed), tuple(CAPSULE_NAMES.index(c) for c in capsules))


_SIDES = ("left", "right")
# sampling order: left leg, right leg, left arm, right arm
LIMBS: tuple[Limb, ...] = tuple(
    _limb(f"{side}_leg", s, True, tuple(f"{side}_{n}" for n in ("hip", "knee", "ankle", "foot")),
          tuple(f"{side}_{n}" for n in ("knee", "ankle", "foot")),
          tuple(f"{side}_{n}" for n in ("thigh", "calf", "foot")))
    for s, side in enumerate(_SIDES)
) + tuple(
    _limb(f"{side}_arm", s, False, tuple(f"{side}_{n}" for n in ("collar", "shoulder", "elbow", "wrist", "hand")),
          tuple(f"{side}_{n}" for n in ("elbow", "wrist", "hand")),
          tuple(f"{side}_{n}" for n in ("shoulder", "upper_arm", "forearm", "hand")))
    for s, side in enumerate(_SIDES)
)


def rotate(axis_angle: np.ndarray, v: np.ndarray) -> np.ndarray:
    """Rotate vectors v (..., M, 3) by axis-angles (..., 3) (Rodrigues' formula, no matrices)."""
    theta = np.sqrt(np.sum(axis_angle * axis_angle, axis=-1, keepdims=True))
    k = (axis_angle / np.where(theta < 1e-12, 1.0, theta))[..., None, :]
    c, s = np.cos(theta)[..., None, :], np.sin(theta)[..., None, :]
    kx, ky, kz = k[..., 0], k[..., 1], k[..., 2]
    vx, vy, vz = v[..., 0], v[..., 1], v[..., 2]
    cross = np.stack([ky * vz - kz * vy, kz * vx - kx * vz, kx * vy - ky * vx], axis=-1)
    return v * c + cross * s + k * (np.sum(k * v, axis=-1, keepdims=True) * (1.0 - c))


def limb_geometry(limb: Limb, axis_angles: np.ndarray, rest_joints: np.ndarray,
                  capsule_ends: np.ndarray | None = None) -> tuple[np.ndarray, np.ndarray | None]:
    """Chain joint positions (P, K, C, 3) and the limb's capsule ends (P, K, len(limb.capsules), 2, 3).

    axis_angles: (P, K, C, 3) local axis-angles of the C chain joints for K candidates of P bodies
    (only the first ``limb.moving`` may be non-zero); rest_joints: (P, 24, 3) shaped rest joints;
    capsule_ends: (P, 20, 2, 3) capsule ends relative to their joint at rest, or None (then only the
    joints are computed and None is returned for the ends). All in SMPL's frame, without the root
    rotation; the chain's first joint stays at rest (its parents are held at 0).
    """
    n_c = len(limb.chain)
    rest = rest_joints[:, list(limb.chain)]  # (P, C, 3)
    frame_of = list(range(n_c - 1))  # bone c rides on chain joint c
    vecs = [rest[:, 1:] - rest[:, :-1]]
    if capsule_ends is not None:
        for k in limb.capsules:
            c = limb.chain.index(CAPSULE_JOINTS[k])
            frame_of += [c, c]
            vecs.append(capsule_ends[:, k])
    frame_of = np.array(frame_of)
    shape = axis_angles.shape[:2] + (len(frame_of), 3)
    v = np.array(np.broadcast_to(np.concatenate(vecs, axis=1)[:, None], shape))
    # R_c v = L_0 (L_1 (... L_c v)): apply the deepest moving rotations first
    for c in reversed(range(limb.moving)):
        sel = np.flatnonzero(frame_of >= c)
        v[:, :, sel] = rotate(axis_angles[:, :, c], v[:, :, sel])
    joints = np.concatenate([np.broadcast_to(rest[:, None, :1], shape[:2] + (1, 3)),
                             rest[:, None, :1] + np.cumsum(v[:, :, : n_c - 1], axis=2)], axis=2)
    if capsule_ends is None:
        return joints, None
    ends = joints[:, :, frame_of[n_c - 1:]] + v[:, :, n_c - 1:]
    return joints, ends.reshape(shape[:2] + (len(limb.capsules), 2, 3))


def limb_lengths(rest_joints: np.ndarray) -> np.ndarray:
    """(P, 4) length of each limb in :data:`LIMBS` order (proximal -> middle -> distal joint), m."""
    out = np.empty(rest_joints.shape[:1] + (len(LIMBS),))
    for i, limb in enumerate(LIMBS):
        a, b, c = limb.proximal, limb.chain[limb.chain.index(limb.proximal) + 1], limb.distal
        out[:, i] = (np.linalg.norm(rest_joints[:, b] - rest_joints[:, a], axis=-1)
                     + np.linalg.norm(rest_joints[:, c] - rest_joints[:, b], axis=-1))
    return out


def to_world(points: np.ndarray, M: np.ndarray, pelvis_rest: np.ndarray, pelvis_world: np.ndarray) -> np.ndarray:
    """Bed-frame points (P, ..., 3) from SMPL-frame points (P, ..., 3): ``M (p - pelvis_rest) + pelvis_world``
    with M = W Q (P, 3, 3), pelvis_rest (P, 3) and pelvis_world (P, 3)."""
    shape = points.shape
    flat = points.reshape(shape[0], -1, 3) - pelvis_rest[:, None]
    out = np.einsum("pij,pnj->pni", M, flat) + pelvis_world[:, None]
    return out.reshape(shape)
