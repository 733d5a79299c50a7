"""Self-collision: the sampler's segment distance and MuJoCo checker against an independent
distance computation, the choice of pairs, and collision-free rest poses of the shipped bodies."""

import numpy as np
import pytest

from pressurepose.body.capsules import CAPSULE_NAMES, capsules_for, posed_capsules
from pressurepose.body.contact import CHECKED_DEFAULT, collision_pairs, segment_distance
from pressurepose.pose.collision import SelfCollision, limb_pairs
from pressurepose.pose.limbs import LIMBS

N = CAPSULE_NAMES.index


def random_segments(rng, n):
    p1, q1, p2 = rng.normal(0, 0.3, (3, n, 3))
    q2 = p2 + rng.normal(0, 0.3, (n, 3))
    # some parallel, some degenerate (points), some collinear
    q2[:50] = p2[:50] + 0.7 * (q1[:50] - p1[:50])
    q1[50:60] = p1[50:60]
    p2[60:70] = p1[60:70] + 0.3 * (q1[60:70] - p1[60:70])
    q2[60:70] = p1[60:70] + 1.5 * (q1[60:70] - p1[60:70])
    return p1, q1, p2, q2


def test_segment_distance_matches_independent_cases(segment_distance_by_cases):
    rng = np.random.default_rng(0)
    p1, q1, p2, q2 = random_segments(rng, 4000)
    got = segment_distance(p1, q1, p2, q2)
    want = segment_distance_by_cases(p1, q1, p2, q2)
    np.testing.assert_allclose(got, want, atol=1e-9)
    # and a dense-sampling spot check of a few
    t = np.linspace(0, 1, 2001)
    for i in range(5):
        a = p1[i] + t[:, None] * (q1[i] - p1[i])
        b = p2[i] + t[:, None] * (q2[i] - p2[i])
        brute = np.min(np.linalg.norm(a[:, None] - b[None], axis=-1))
        assert got[i] <= brute + 1e-12 and brute - got[i] < 1e-3


def test_segment_distance_known_answers():
    z = np.zeros(3)
    x = np.array([1.0, 0, 0])
    # crossing perpendicular segments 0.5 apart
    assert segment_distance(z, x, np.array([0.5, -1, 0.5]), np.array([0.5, 1, 0.5])) == pytest.approx(0.5)
    # parallel, overlapping, 0.2 apart
    assert segment_distance(z, x, np.array([0.5, 0.2, 0]), np.array([2.0, 0.2, 0])) == pytest.approx(0.2)
    # collinear with a gap of 0.3
    assert segment_distance(z, x, np.array([1.3, 0, 0]), np.array([2.0, 0, 0])) == pytest.approx(0.3)


def test_mujoco_checker_agrees_with_independent_distances(segment_distance_by_cases):
    rng = np.random.default_rng(1)
    sc = SelfCollision()
    pairs = np.array(sc.pairs)
    hits = 0
    for _ in range(150):
        ends = rng.uniform(-0.35, 0.35, (20, 2, 3))
        radius = rng.uniform(0.02, 0.08, 20)
        d = segment_distance_by_cases(ends[pairs[:, 0], 0], ends[pairs[:, 0], 1], ends[pairs[:, 1], 0],
                                      ends[pairs[:, 1], 1])
        gap = d - radius[pairs[:, 0]] - radius[pairs[:, 1]]
        tangent = {tuple(p) for p, g in zip(pairs.tolist(), gap) if abs(g) < 1e-6}  # either answer is fine
        want = {tuple(p) for p, g in zip(pairs.tolist(), gap) if g < 0} - tangent
        got = set(sc.contacts(ends, radius)) - tangent
        assert got == want
        hits += len(want)
    assert hits > 100  # the random capsules do collide often enough to test something


def test_pairs_skip_adjacent_capsules_and_unchecked_pairs():
    pairs = set(collision_pairs())
    sort = lambda a, b: tuple(sorted((N(a), N(b))))  # noqa: E731
    assert sort("left_forearm", "left_upper_arm") not in pairs  # parent / child
    assert sort("left_forearm", "left_hand") not in pairs
    assert sort("left_calf", "left_thigh") not in pairs and sort("left_calf", "left_foot") not in pairs
    assert sort("left_forearm", "right_forearm") in pairs
    assert sort("left_hand", "head") in pairs and sort("left_foot", "left_thigh") in pairs
    assert sort("pelvis", "spine") not in pairs  # neither is checked
    no_hands = set(collision_pairs(tuple(c for c in CHECKED_DEFAULT if not c.endswith("hand"))))
    assert sort("left_hand", "head") not in no_hands
    assert sort("left_hand", "left_calf") in no_hands  # the calf is still checked


def test_limb_pairs_are_the_pairs_a_limb_decides_alone():
    all_pairs = set(collision_pairs())
    fixed = {N(n) for n in ("pelvis", "spine", "spine1", "spine2", "neck", "head")}
    for limb in LIMBS:
        own = set(limb.capsules)
        lp = limb_pairs(limb.capsules)
        assert lp
        for a, b in lp:
            assert a in own and (b in own or b in fixed)
            assert tuple(sorted((a, b))) in all_pairs
        expected = {p for p in all_pairs if set(p) <= own | fixed and set(p) & own}
        assert {tuple(sorted(p)) for p in lp} == expected


@pytest.mark.parametrize("betas_kind", ["mean", "low", "high"])
def test_rest_pose_of_shipped_bodies_is_collision_free(female, betas_kind):
    betas = {"mean": np.zeros(10), "low": np.full(10, -3.0), "high": np.full(10, 3.0)}[betas_kind]
    caps = capsules_for(female, betas)
    ends, radius = posed_capsules(female, caps, betas, np.zeros((1, 72)))
    assert SelfCollision().contacts(ends[0], radius) == []
