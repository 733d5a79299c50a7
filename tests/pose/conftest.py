"""Shared fixtures of the pose tests: the shipped female body, cached sample batches, and an
independent segment-distance routine (not the sampler's) for the self-collision checks."""

import numpy as np
import pytest

from pressurepose.body import BodyModel
from pressurepose.body.model import asset_path


@pytest.fixture(scope="session")
def female():
    if not asset_path("female.npz").is_file():
        pytest.skip("the shipped female body model is not baked (pressurepose/body/assets/female.npz)")
    return BodyModel("female")


@pytest.fixture(scope="session")
def batch_of(female):
    """batch_of(partition, limbs_on_bed, count, seed) -> SampleBatch with the paper's sampler
    settings (uniform shapes and placement, limbs may hang), cached for the session."""
    from pressurepose.pose import sample_bodies
    from pressurepose.pose.config import paper_sampler

    cache = {}

    def get(partition, limbs_on_bed, count, seed):
        key = (partition, limbs_on_bed, count, seed)
        if key not in cache:
            cache[key] = sample_bodies(partition, "f", count, seed, limbs_on_bed=limbs_on_bed, body=female,
                                       config=paper_sampler())
        return cache[key]

    return get


def _segment_distance_by_cases(p1, q1, p2, q2):
    """Distance between segments (..., 3): the minimum of |p1 + s d1 - p2 - t d2| over the unit
    square is at the interior stationary point or on one of the four edges (a convex quadratic), so
    take the least of those five candidates."""
    d1, d2, w = q1 - p1, q2 - p2, p1 - p2
    a, b, e = (d1 * d1).sum(-1), (d1 * d2).sum(-1), (d2 * d2).sum(-1)
    c, f = (d1 * w).sum(-1), (d2 * w).sum(-1)

    def dist(s, t):
        g = w + d1 * s[..., None] - d2 * t[..., None]
        return np.sqrt((g * g).sum(-1))

    cands = []
    det = a * e - b * b
    ok = det > 1e-14
    safe = np.where(ok, det, 1.0)
    s_in, t_in = (b * f - c * e) / safe, (a * f - b * c) / safe
    inside = ok & (s_in >= 0) & (s_in <= 1) & (t_in >= 0) & (t_in <= 1)
    cands.append(np.where(inside, dist(s_in, t_in), np.inf))
    for s_fix in (0.0, 1.0):  # t minimising for a fixed s
        s = np.full(a.shape, s_fix)
        t = np.clip((f + b * s) / np.maximum(e, 1e-18), 0, 1)
        cands.append(dist(s, t))
    for t_fix in (0.0, 1.0):
        t = np.full(a.shape, t_fix)
        s = np.clip((b * t - c) / np.maximum(a, 1e-18), 0, 1)
        cands.append(dist(s, t))
    return np.min(cands, axis=0)


@pytest.fixture(scope="session")
def segment_distance_by_cases():
    return _segment_distance_by_cases
