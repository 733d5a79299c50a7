"""The capsules as the settle's ragdoll collides them, and the test of a body's start against it.

Contact geoms. The ragdoll (:mod:`pressurepose.sim.ragdoll`) carries each capsule as a MuJoCo geom
of the capsule's radius and length, except the four trunk capsules, which are shortened to the body's
sides (:func:`trunk_contact_lengths`). The self-colliding capsules (:data:`CHECKED_DEFAULT`: calves,
feet, forearms, hands) collide with every capsule not adjacent to them in the kinematic tree (MuJoCo
filters parent-child pairs: :func:`adjacent`); the others do not collide with each other.

Start test. The settle (:mod:`pressurepose.sim.settle`) rejects, as ``self_collision``, a body that
starts with a pair of its contact geoms more than ``SettleConfig.self_collision_tol_m`` (default
:data:`START_OVERLAP_TOL_M`) inside each other (:func:`start_overlap`). The pose sampler applies
the same test where its own (paper appendix A.1, :mod:`pressurepose.pose.collision`) exempts a
capsule: the hands of the hands-behind-head partition, which rest against the head.

Lengths and radii in metres, z-up or SMPL axes alike (the tests are rotation-invariant).
"""

from __future__ import annotations

import numpy as np

from pressurepose.body.capsules import (
    CAPSULE_JOINTS,
    CAPSULE_NAMES,
    NUM_CAPSULES,
    Capsules,
)
from pressurepose.body.joints import JOINT_NAMES, PARENTS
from pressurepose.body.lbs_numpy import rest_joints

# capsules that collide with the rest of the body (the paper's: forearms, hands, calves and feet)
CHECKED_DEFAULT: tuple[str, ...] = ("left_calf", "right_calf", "left_foot", "right_foot", "left_forearm",
                                    "right_forearm", "left_hand", "right_hand")
# a pair of contact geoms this deep (m) inside each other where the settle starts: rejected
START_OVERLAP_TOL_M = 0.002
# Trunk capsule -> the SMPL joints whose skinned vertices make up the body's side around it (the
# pelvis takes the hips' vertices, which form the side of the hips; the chest takes the collars').
TRUNK_SIDE_JOINTS = {
    CAPSULE_NAMES.index("pelvis"): ("pelvis", "left_hip", "right_hip", "spine1"),
    CAPSULE_NAMES.index("spine"): ("pelvis", "left_hip", "right_hip", "spine1", "spine2"),
    CAPSULE_NAMES.index("spine1"): ("spine1", "spine2", "spine3", "left_collar", "right_collar"),
    CAPSULE_NAMES.index("spine2"): ("spine2", "spine3", "neck", "left_collar", "right_collar"),
}
MIN_CONTACT_LENGTH_M = 1e-3


def trunk_contact_lengths(body, betas, caps: Capsules) -> np.ndarray:
    """(20,) m: cylinder lengths of the capsules' contact geoms for shape ``betas`` (S,).

    A trunk capsule (:data:`TRUNK_SIDE_JOINTS`) is shortened so that its caps end at the side of the
    body's rest mesh: the farthest vertex, along the capsule's axis, among those skinned mostly to
    the capsule's trunk joints and lying within one radius of its axis (at least
    ``MIN_CONTACT_LENGTH_M``: MuJoCo needs a cylinder part). Never lengthened; the limb
    capsules keep their length. A body without such vertices (e.g. a coarse toy) keeps every length.
    Every length is at least ``MIN_CONTACT_LENGTH_M``: for extreme shapes the capsule regressor gives
    a neck of zero length, which MuJoCo refuses.
    """
    v, J = rest_joints(body.arrays, np.asarray(betas, dtype=np.float64)[None])
    v, J = v[0], J[0]
    owner = np.asarray(body.arrays.weights).argmax(axis=1)
    out = np.asarray(caps.length, dtype=np.float64).copy()
    for k, names in TRUNK_SIDE_JOINTS.items():
        R = caps.rest_transform[k, :3, :3]
        local = (v - J[CAPSULE_JOINTS[k]] - caps.rest_transform[k, :3, 3]) @ R  # capsule frame
        near = np.isin(owner, [JOINT_NAMES.index(n) for n in names]) & (np.hypot(local[:, 0], local[:, 1])
                                                                          < caps.radius[k])
        if near.any():
            half_width = np.abs(local[near, 2]).max()
            out[k] = min(out[k], max(2.0 * (half_width - caps.radius[k]), MIN_CONTACT_LENGTH_M))
    return np.maximum(out, MIN_CONTACT_LENGTH_M)


def adjacent(a: int, b: int) -> bool:
    """True if capsules a and b ride on joints that are parent and child."""
    ja, jb = CAPSULE_JOINTS[a], CAPSULE_JOINTS[b]
    return PARENTS[ja] == jb or PARENTS[jb] == ja


def collision_pairs(checked: tuple[str, ...] = CHECKED_DEFAULT) -> tuple[tuple[int, int], ...]:
    """Sorted capsule index pairs (a < b) to test: each checked capsule against every capsule other
    than itself and those adjacent to it."""
    idx = [CAPSULE_NAMES.index(n) for n in checked]
    pairs = {tuple(sorted((c, d))) for c in idx for d in range(NUM_CAPSULES) if d != c and not adjacent(c, d)}
    return tuple(sorted(pairs))


def segment_distance(p1: np.ndarray, q1: np.ndarray, p2: np.ndarray, q2: np.ndarray) -> np.ndarray:
    """Distance (...) between segments p1-q1 and p2-q2 (each (..., 3)): closest points by clamping
    the unconstrained solution onto the segments (Ericson, Real-Time Collision Detection 5.1.9)."""
    d1, d2, r = q1 - p1, q2 - p2, p1 - p2
    a = np.maximum(np.sum(d1 * d1, -1), 1e-18)
    e = np.maximum(np.sum(d2 * d2, -1), 1e-18)
    b, c, f = np.sum(d1 * d2, -1), np.sum(d1 * r, -1), np.sum(d2 * r, -1)
    denom = a * e - b * b
    s = np.where(denom > 1e-12 * a * e, np.clip((b * f - c * e) / np.where(denom > 0, denom, 1.0), 0, 1), 0.0)
    t = (b * s + f) / e
    s = np.where(t < 0, np.clip(-c / a, 0, 1), np.where(t > 1, np.clip((b - c) / a, 0, 1), s))
    t = np.clip(t, 0, 1)
    gap = p1 + d1 * s[..., None] - p2 - d2 * t[..., None]
    return np.sqrt(np.sum(gap * gap, -1))


def penetrating(ea: np.ndarray, eb: np.ndarray, ra, rb, tol: float = 0.0) -> np.ndarray:
    """(...) True where capsules with axis segments ``ea``, ``eb`` (..., 2, 3) and radii ``ra``, ``rb``
    (...) m penetrate each other deeper than ``tol`` m (0: touching is not penetrating)."""
    d = segment_distance(ea[..., 0, :], ea[..., 1, :], eb[..., 0, :], eb[..., 1, :])
    return d < np.asarray(ra) + np.asarray(rb) - tol


# the pairs the ragdoll collides
START_PAIRS: tuple[tuple[int, int], ...] = collision_pairs(CHECKED_DEFAULT)


def start_overlap(ends: np.ndarray, radius: np.ndarray, tol: float = START_OVERLAP_TOL_M,
                  pairs: tuple[tuple[int, int], ...] = START_PAIRS) -> np.ndarray:
    """(...) True where a posed body fails the settle's start test (see ``START_PAIRS``).

    ends: (..., 20, 2, 3) axis-segment ends of the contact geoms, m; radius: (..., 20) m; tol: m;
    pairs: the capsule pairs tested (default all of the settle's).
    """
    p = np.asarray(pairs, dtype=np.int64).reshape(-1, 2)
    ends, radius = np.asarray(ends), np.asarray(radius)
    if not len(p):
        return np.zeros(ends.shape[:-3], dtype=bool)
    hit = penetrating(ends[..., p[:, 0], :, :], ends[..., p[:, 1], :, :], radius[..., p[:, 0]],
                      radius[..., p[:, 1]], tol)
    return np.any(hit, axis=-1)
