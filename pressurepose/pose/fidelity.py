"""How closely sampled joint angles follow a reference sampler's: per-DOF 1-D Wasserstein distances.

The 22 sampled degrees of freedom of the SMPL pose vector: the hips' three components, the knees'
x, the collars' and shoulders' three components (the sampled shoulder rotation split 1 : 2), the
elbows' y. The reference is the public code's own output (``benchmarks/bench_sampler_fidelity.py``
reads it); this module only works on plain arrays and never reads files.
"""

from __future__ import annotations

import numpy as np

from pressurepose.body.joints import joint_index
from pressurepose.errors import BadInput

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
