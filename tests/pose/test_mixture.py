"""Gaussian mixtures: EM finds known components, honours the smallest component size, draws reproducibly."""

import numpy as np
import pytest

from pressurepose.errors import BadInput
from pressurepose.pose.mixture import GaussianMixture, fit_mixture


def two_blobs(rng, n=(300, 100)):
    a = rng.normal([0.0, 0.0, 0.0], 0.1, (n[0], 3))
    b = rng.normal([2.0, -1.0, 0.5], [0.2, 0.1, 0.3], (n[1], 3))
    return np.concatenate([a, b])


def test_em_recovers_two_known_components():
    x = two_blobs(np.random.default_rng(0))
    mix = fit_mixture(x, 2, 1e-6, seed=3, min_count=20)
    order = np.argsort(mix.means[:, 0])
    np.testing.assert_allclose(mix.weights[order], [0.75, 0.25], atol=0.01)
    # blobs this far apart: each component is its blob's own mean and covariance
    np.testing.assert_allclose(mix.means[order], [x[:300].mean(0), x[300:].mean(0)], atol=1e-4)
    np.testing.assert_allclose(mix.covariances[order[1]], np.cov(x[300:].T, bias=True) + 1e-6 * np.eye(3), atol=1e-5)


def test_every_component_averages_over_min_count_points():
    x = two_blobs(np.random.default_rng(1), (400, 30))
    mix = fit_mixture(x, 6, 1e-4, seed=0, min_count=50)
    assert np.all(mix.weights * len(x) >= 50 - 1e-6)
    with pytest.raises(BadInput, match="at least"):
        fit_mixture(x[:40], 2, 1e-4, min_count=50)


def test_starting_groups_and_no_iterations_give_the_groups_statistics():
    x = two_blobs(np.random.default_rng(2))
    labels = np.repeat([0, 1], [300, 100])
    mix = fit_mixture(x, 99, 1e-3, labels=labels, iterations=1, min_count=10)
    np.testing.assert_allclose(mix.means, [x[:300].mean(0), x[300:].mean(0)])
    np.testing.assert_allclose(mix.covariances[1], np.cov(x[300:].T, bias=True) + 1e-3 * np.eye(3))


def test_one_component_density_is_the_normal_density_and_draws_repeat():
    from scipy.stats import multivariate_normal

    cov = np.array([[1.0, 0.3], [0.3, 0.5]])
    mix = GaussianMixture(np.ones(1), np.array([[1.0, -2.0]]), cov[None])
    pts = np.array([[0.0, 0.0], [1.0, -2.0], [3.0, 1.0]])
    np.testing.assert_allclose(mix.log_density(pts), multivariate_normal([1.0, -2.0], cov).logpdf(pts))
    a = mix.sample(np.random.default_rng(5), 2000)
    np.testing.assert_array_equal(a, mix.sample(np.random.default_rng(5), 2000))
    np.testing.assert_allclose(np.cov(a.T), cov, atol=0.08)


def test_bad_parameters():
    with pytest.raises(BadInput, match="summing to 1"):
        GaussianMixture(np.array([0.5, 0.2]), np.zeros((2, 2)), np.stack([np.eye(2)] * 2))
    with pytest.raises(BadInput, match="positive definite"):
        GaussianMixture(np.ones(1), np.zeros((1, 2)), -np.eye(2)[None])
    with pytest.raises(BadInput, match="reg"):
        fit_mixture(np.zeros((100, 2)), 1, 0.0)
