"""Gaussian mixtures: fitted by expectation-maximisation, drawn from with a caller's generator.

Plain numpy (no scikit-learn). Covariances are full, each regularised by adding ``reg`` to its
diagonal, so a component stays well conditioned in directions its points barely vary along (SMPL's
hand and foot joints, the knees' off-hinge components). A component whose share of the points falls
below ``min_count`` points is dropped and the rest refitted, so each component is an average over
at least that many points.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from pressurepose.errors import BadInput, require_whole


@dataclass(frozen=True, eq=False)
class GaussianMixture:
    """K Gaussian components in D dimensions: weights (K,) summing to 1, means (K, D), covariances
    (K, D, D) symmetric positive definite."""

    weights: np.ndarray
    means: np.ndarray
    covariances: np.ndarray

    def __post_init__(self):
        w, m, c = (np.asarray(a, dtype=np.float64) for a in (self.weights, self.means, self.covariances))
        k = len(w)
        if w.ndim != 1 or not k or m.ndim != 2 or len(m) != k or c.shape != (k, m.shape[1], m.shape[1]):
            raise BadInput(f"mixture weights {w.shape}, means {m.shape}, covariances {c.shape}; expected (K,), "
                           f"(K, D), (K, D, D) with K >= 1")
        if not (np.all(np.isfinite(w)) and np.all(np.isfinite(m)) and np.all(np.isfinite(c))):
            raise BadInput("mixture parameters contain NaN or infinite values")
        if np.any(w < 0) or abs(w.sum() - 1.0) > 1e-6:
            raise BadInput(f"mixture weights {np.round(w, 4).tolist()}; expected values >= 0 summing to 1")
        try:
            chol = np.linalg.cholesky(c)
        except np.linalg.LinAlgError:
            raise BadInput("a mixture covariance is not positive definite") from None
        for name, a in (("weights", w / w.sum()), ("means", m), ("covariances", c), ("_chol", chol)):
            object.__setattr__(self, name, a)

    @property
    def dim(self) -> int:
        return self.means.shape[1]

    def sample(self, rng: np.random.Generator, count: int = 1) -> np.ndarray:
        """(count, D) points: for each, a component drawn by weight, then a point from it (one
        ``rng.choice`` and D normals per point, in order)."""
        out = np.empty((count, self.dim))
        for i in range(count):
            k = rng.choice(len(self.weights), p=self.weights)
            out[i] = self.means[k] + self._chol[k] @ rng.standard_normal(self.dim)
        return out

    def log_density(self, x) -> np.ndarray:
        """(N,) log density at points x (N, D)."""
        return _logsumexp(self._component_log(np.atleast_2d(np.asarray(x, dtype=np.float64))), axis=1)

    def _component_log(self, x: np.ndarray) -> np.ndarray:
        """(N, K) log(weight_k N(x; mean_k, cov_k))."""
        d = self.dim
        out = np.empty((len(x), len(self.weights)))
        for k in range(len(self.weights)):
            z = np.linalg.solve(self._chol[k], (x - self.means[k]).T)
            logdet = 2.0 * np.sum(np.log(np.diag(self._chol[k])))
            out[:, k] = math.log(max(self.weights[k], 1e-300)) - 0.5 * (np.sum(z * z, axis=0) + logdet
                                                                       + d * math.log(2 * math.pi))
        return out


def _logsumexp(a: np.ndarray, axis: int) -> np.ndarray:
    top = np.max(a, axis=axis, keepdims=True)
    return np.squeeze(top, axis) + np.log(np.sum(np.exp(a - top), axis=axis))


def _kmeans_pp(x: np.ndarray, k: int, rng: np.random.Generator) -> np.ndarray:
    """k starting means chosen from x by k-means++ seeding."""
    centres = [x[rng.integers(len(x))]]
    for _ in range(1, k):
        d2 = np.min(((x[:, None] - np.array(centres)[None]) ** 2).sum(-1), axis=1)
        centres.append(x[rng.choice(len(x), p=d2 / d2.sum())] if d2.sum() > 0 else x[rng.integers(len(x))])
    return np.array(centres)


def fit_mixture(x, components: int, reg: float, seed: int = 0, min_count: int = 50, iterations: int = 200,
                tol: float = 1e-6, labels=None) -> GaussianMixture:
    """A Gaussian mixture of up to ``components`` components fitted to points x (N, D) by EM.

    reg: added to every covariance's diagonal (units of x squared; > 0); min_count: a component
    whose responsibilities sum to fewer points is dropped and EM goes on with the rest, so every
    component of the result averages over at least ``min_count`` points; seed: the k-means++ start;
    labels: None, or (N,) a starting group of each point instead (then ``components`` is ignored:
    one component per group; iterations 0 keeps the groups as they are).
    BadInput unless N >= min_count and N >= components.
    """
    x = np.asarray(x, dtype=np.float64)
    if x.ndim != 2 or not np.all(np.isfinite(x)):
        raise BadInput(f"points have shape {x.shape}; expected finite (N, D)")
    n, d = x.shape
    require_whole("components", components, 1)
    if not (isinstance(reg, (int, float)) and math.isfinite(reg) and reg > 0):
        raise BadInput(f"reg is {reg!r}; expected a number > 0")
    if n < max(min_count, components):
        raise BadInput(f"{n} points; a mixture of {components} components with at least {min_count} points "
                       f"each needs at least {max(min_count, components)}")
    if labels is None:
        means = _kmeans_pp(x, min(components, n // max(min_count, 1) or 1), np.random.default_rng(seed))
        start = np.argmin(((x[:, None] - means[None]) ** 2).sum(-1), axis=1)
    else:
        labels = np.asarray(labels)
        if labels.shape != (n,):
            raise BadInput(f"labels have shape {labels.shape}; expected ({n},)")
        groups, start = np.unique(labels, return_inverse=True)
        means = np.array([x[start == g].mean(0) for g in range(len(groups))])
    resp = np.zeros((n, len(means)))
    resp[np.arange(n), start] = 1.0
    eye = reg * np.eye(d)
    last = -np.inf
    for it in range(max(iterations, 1)):
        counts = resp.sum(axis=0)
        keep = counts >= min_count
        if not keep.any():
            keep[np.argmax(counts)] = True
        resp, means = resp[:, keep], means[keep]
        lost = resp.sum(axis=1) < 1e-12  # points whose components were all dropped: to the nearest mean
        if lost.any():
            resp[lost] = 0.0
            resp[lost, np.argmin(((x[lost, None] - means[None]) ** 2).sum(-1), axis=1)] = 1.0
        resp = resp / resp.sum(axis=1, keepdims=True)
        counts = resp.sum(axis=0)
        means = (resp.T @ x) / counts[:, None]
        covs = np.empty((len(counts), d, d))
        for k in range(len(counts)):
            c = x - means[k]
            covs[k] = (resp[:, k, None] * c).T @ c / counts[k] + eye
        mix = GaussianMixture(counts / counts.sum(), means, covs)
        if it + 1 >= iterations:
            break
        log = mix._component_log(x)
        total = _logsumexp(log, axis=1)
        resp = np.exp(log - total[:, None])
        mean_ll = float(total.mean())
        if abs(mean_ll - last) < tol * max(1.0, abs(mean_ll)) and np.all(resp.sum(axis=0) >= min_count):
            break
        last = mean_ll
    return mix
