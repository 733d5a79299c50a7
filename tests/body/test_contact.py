"""The settle's start test (pressurepose.body.contact) on capsules placed by hand, with known depths."""

import numpy as np
import pytest

from pressurepose.body.capsules import CAPSULE_NAMES
from pressurepose.body.contact import (
    START_OVERLAP_TOL_M,
    START_PAIRS,
    penetrating,
    start_overlap,
)

N = CAPSULE_NAMES.index


def apart() -> tuple[np.ndarray, np.ndarray]:
    """20 capsules of radius 2 cm and length 10 cm, 1 m apart along x, vertical: none touch."""
    ends = np.zeros((20, 2, 3))
    ends[:, 0, 0] = ends[:, 1, 0] = np.arange(20.0)
    ends[:, 1, 2] = 0.1
    return ends, np.full(20, 0.02)


def test_separate_capsules_pass():
    ends, radius = apart()
    assert not start_overlap(ends, radius)


@pytest.mark.parametrize(("depth_mm", "rejected"), [(1.0, False), (1.9, False), (2.1, True), (30.0, True)])
def test_a_hand_inside_the_head_fails_past_the_tolerance(depth_mm, rejected):
    """The hand's axis parallel to the head's, their surfaces overlapping by depth_mm."""
    ends, radius = apart()
    hand, head = N("left_hand"), N("head")
    ends[hand] = ends[head] + [0.04 - depth_mm / 1000, 0.0, 0.0]
    assert bool(start_overlap(ends, radius)) == rejected
    assert START_OVERLAP_TOL_M == 0.002


def test_only_pairs_with_a_self_colliding_capsule_count():
    """Trunk capsules overlap by design; adjacent ones (forearm and hand) too: neither is tested."""
    ends, radius = apart()
    ends[N("spine1")] = ends[N("spine2")]
    ends[N("left_hand")] = ends[N("left_forearm")]
    assert (N("spine1"), N("spine2")) not in START_PAIRS
    assert not start_overlap(ends, radius)
    ends[N("right_hand")] = ends[N("left_hand")]
    assert start_overlap(ends, radius)


def test_batched_and_by_pair():
    ends, radius = apart()
    both = np.stack([ends, ends])
    both[1, N("left_foot")] = both[1, N("right_calf")]
    np.testing.assert_array_equal(start_overlap(both, np.stack([radius, radius])), [False, True])
    assert not start_overlap(both[1], radius, pairs=((N("left_hand"), N("head")),))
    assert penetrating(ends[0], ends[0] + [0.039, 0, 0], 0.02, 0.02)
    assert not penetrating(ends[0], ends[0] + [0.039, 0, 0], 0.02, 0.02, tol=0.002)
