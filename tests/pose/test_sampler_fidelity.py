"""The supine sampler's joint-angle marginals against the public sampler's own output.

The reference file is read only if it is found beside the checkout (see
benchmarks/bench_sampler_fidelity.py, which also documents why unpickling it is acceptable)."""

import numpy as np
import pytest

from benchmarks.bench_sampler_fidelity import load_official, official_path
from pressurepose.errors import BadInput
from pressurepose.pose.fidelity import (
    SAMPLED_DOFS,
    marginal_distances,
    pose_from_indexed,
)


def test_sampled_dofs_are_the_22_of_the_public_sampler():
    names = [n for n, _ in SAMPLED_DOFS]
    assert len(SAMPLED_DOFS) == 22 and len(set(names)) == 22
    # the public sampler's stored indices, minus the root, spine, neck and head values it holds at 0
    stored = {3, 4, 5, 6, 7, 8, 12, 15, 39, 40, 41, 42, 43, 44, 48, 49, 50, 51, 52, 53, 55, 58}
    assert {i for _, i in SAMPLED_DOFS} == stored


def test_pose_from_indexed_and_distances():
    pose = pose_from_indexed([[3, 12], [3, 15]], [[0.1, 0.2], [0.3, 0.4]])
    assert pose.shape == (2, 72)
    assert pose[0, 3] == 0.1 and pose[0, 12] == 0.2 and pose[1, 15] == 0.4 and pose.sum() == pytest.approx(1.0)
    rng = np.random.default_rng(0)
    a = rng.uniform(-1, 1, (500, 72))
    np.testing.assert_allclose(marginal_distances(a, a), 0.0, atol=1e-12)
    b = a.copy()
    b[:, 12] += np.deg2rad(5.0)  # left knee shifted by 5 degrees: W1 of exactly 5 there, 0 elsewhere
    d = marginal_distances(a, b)
    k = [i for _, i in SAMPLED_DOFS].index(12)
    assert d[k] == pytest.approx(5.0)
    assert np.all(np.delete(d, k) < 1e-9)
    with pytest.raises(BadInput, match="indices"):
        pose_from_indexed([[72]], [[0.1]])
    with pytest.raises(BadInput, match="expected"):
        marginal_distances(a[:, :69], a)


def test_supine_marginals_follow_the_public_sampler(batch_of):
    """300 supine female bodies against the public sampler's 2700. With a test keeping limbs above the
    body's support (which the public code does not have, docs/not-adopted.md) and bins counted along
    the body instead of the bed, this seed measured mean W1 4.3 deg and hip flexion W1 11-12 deg (14
    and 13 on 2700 bodies); the sampler as it is, 2.9 and 1.3-1.4.
    300 bodies leave ~1-2 deg of sampling noise per DOF (largest at the shoulders), hence the
    tolerances."""
    path = official_path()
    if path is None:
        pytest.skip("the public sampler's supine file is not beside this checkout")
    _, reference, _ = load_official(path)
    assert reference.shape == (2700, 72)
    batch = batch_of("general_supine", False, 300, 100)
    w1 = marginal_distances(batch.pose, reference)
    hip_flexion = [w1[[n for n, _ in SAMPLED_DOFS].index(f"{s}_hip x")] for s in ("left", "right")]
    assert w1.mean() <= 3.8, dict(zip((n for n, _ in SAMPLED_DOFS), w1.round(1)))
    assert max(hip_flexion) <= 6.0, hip_flexion
