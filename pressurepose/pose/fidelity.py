"""How closely sampled poses follow reference poses: 1-D Wasserstein distances of joint angles and
of end-joint places.

Joint angles (:func:`marginal_distances`): the 22 sampled degrees of freedom of the SMPL pose
vector: the hips' three components, the knees' x, the collars' and shoulders' three components (the
sampled shoulder rotation split 1 : 2), the elbows' y. The reference is the public code's own
output (``benchmarks/bench_sampler_fidelity.py`` reads it).

End joints (:func:`end_joint_distances`): where the head, elbows, wrists, knees and ankles lie
relative to the pelvis, whatever the body's orientation: each pose is put on one body (zero shape),
its root orientation removed, and the 1-D Wasserstein distance of each coordinate of each end joint
is taken between the two sets of poses, averaged over the three coordinates. Measured against the
SMPL fits to the SLP dataset (``benchmarks/bench_real_poses.py``): two groups of real people lie
1.4-1.6 cm apart by this measure; the paper's uniform sampler 10-14 cm from them.

This module only works on arrays and never reads pose files.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from pressurepose.body.joints import JOINT_NAMES, joint_index
from pressurepose.errors import BadInput

END_JOINTS: tuple[str, ...] = ("head", "left_elbow", "right_elbow", "left_wrist", "right_wrist", "left_knee",
                               "right_knee", "left_ankle", "right_ankle")

_JOINT_AXES = (
    ("left_hip", "xyz"), ("right_hip", "xyz"), ("left_knee", "x"), ("right_knee", "x"),
    ("left_collar", "xyz"), ("right_collar", "xyz"), ("left_shoulder", "xyz"), ("right_shoulder", "xyz"),
    ("left_elbow", "y"), ("right_elbow", "y"),
)
# (name, index into the 72 pose values) of the 22 sampled degrees of freedom
SAMPLED_DOFS: tuple[tuple[str, int], ...] = tuple(
    (f"{joint} {axis}", 3 * joint_index(joint) + "xyz".index(axis)) for joint, axes in _JOINT_AXES for axis in axes)


def pose_from_indexed(indices, angles) -> np.ndarray:
    """(N, 72) SMPL pose vectors from per-row pose indices and angles (each N rows of K values, the
    public sampler's ``[betas, indices, angles, ...]`` layout); values not listed are 0."""
    idx = np.asarray(indices, dtype=np.int64)
    ang = np.asarray(angles, dtype=np.float64)
    if idx.ndim != 2 or idx.shape != ang.shape:
        raise BadInput(f"pose indices {idx.shape} and angles {ang.shape}; expected two (N, K) arrays")
    if idx.size and (idx.min() < 0 or idx.max() >= 72):
        raise BadInput("pose indices must lie in [0, 72)")
    pose = np.zeros((len(idx), 72))
    np.put_along_axis(pose, idx, ang, axis=1)
    return pose


def marginal_distances(pose: np.ndarray, reference: np.ndarray) -> np.ndarray:
    """(22,) 1-D Wasserstein distances, degrees, between the marginals of :data:`SAMPLED_DOFS` in
    pose (N, 72) and reference (M, 72) (radians)."""
    from scipy.stats import wasserstein_distance

    a, b = np.atleast_2d(pose), np.atleast_2d(reference)
    if a.shape[1:] != (72,) or b.shape[1:] != (72,) or not len(a) or not len(b):
        raise BadInput(f"poses {a.shape} and {b.shape}; expected (N, 72) and (M, 72) with N, M >= 1")
    return np.array([wasserstein_distance(np.rad2deg(a[:, i]), np.rad2deg(b[:, i])) for _, i in SAMPLED_DOFS])


def _poses(pose, what: str) -> np.ndarray:
    p = np.atleast_2d(np.asarray(pose, dtype=np.float64))
    if p.ndim != 2 or p.shape[1] != 72 or not len(p) or not np.all(np.isfinite(p)):
        raise BadInput(f"{what} has shape {p.shape}; expected finite (N, 72) SMPL poses with N >= 1")
    return p


def pelvis_frame_joints(pose, body=None) -> np.ndarray:
    """Joints (N, 24, 3), m, of poses (N, 72) on ``body`` (a :class:`~pressurepose.body.BodyModel`;
    default the shipped neutral model) with zero shape and no root rotation, relative to the pelvis,
    in the model's z-up frame (head +z, front -y, left +x)."""
    from pressurepose.body import BodyModel
    from pressurepose.body.lbs_numpy import Y_UP_TO_Z_UP, forward_kinematics, rodrigues, shaped_rest

    p = _poses(pose, "pose").reshape(-1, 24, 3).copy()
    p[:, 0] = 0.0
    body = body or BodyModel("neutral")
    _, rest = shaped_rest(body.arrays, np.zeros((1, 1)))
    G = forward_kinematics(rodrigues(p), np.broadcast_to(rest, (len(p),) + rest.shape[1:]), body.parents)
    j = G[..., :3, 3] @ Y_UP_TO_Z_UP.T
    return j - j[:, :1]


@dataclass(frozen=True)
class EndJointDistance:
    """1-D Wasserstein distances, m, between two pose sets' end-joint places (see module doc):
    by_joint maps each of :data:`END_JOINTS` to its distance (the mean over x, y, z); mean is their
    mean; by_axis (9, 3) the distances of each coordinate (model frame: x left, y back, z head)."""

    by_joint: dict
    mean: float
    by_axis: np.ndarray

    def line(self, unit: float = 100.0) -> str:
        """'9.8 | head 15.0 | ...' in cm (unit 100) for reports."""
        return f"{unit * self.mean:.1f} | " + " | ".join(f"{k} {unit * v:.1f}" for k, v in self.by_joint.items())


def end_joint_distances(pose, reference, body=None) -> EndJointDistance:
    """How far poses (N, 72) lie from reference poses (M, 72) by where their end joints fall
    (:func:`pelvis_frame_joints` on ``body``); see :class:`EndJointDistance`."""
    from scipy.stats import wasserstein_distance

    ja = pelvis_frame_joints(pose, body)
    jb = pelvis_frame_joints(_poses(reference, "reference poses"), body)
    idx = [JOINT_NAMES.index(n) for n in END_JOINTS]
    d = np.array([[wasserstein_distance(ja[:, j, a], jb[:, j, a]) for a in range(3)] for j in idx])
    per = d.mean(axis=1)
    return EndJointDistance(dict(zip(END_JOINTS, map(float, per))), float(per.mean()), d)
