"""The settle model's contact stiffness (paper appendix A.5): the stiffness at which rigid objects sink
into a dynamic bed model as deep as the press model (or a measurement) says they do.

* :func:`capsule_mesh`: a rigid capsule lying on the unloaded bed, the objects of the fit.
* :func:`press_objects`: taxel forces and sink depths of objects on the press model of a bed.
* :func:`fit_settle_stiffness`: the stiffness of any other bed model at which its objects sink as
  measured, given a function that simulates the sinks.

The settle's cells are fitted with these (and the fit kept on disk) in
:mod:`pressurepose.sim.settle_stiffness`.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
import scipy.optimize

from pressurepose.errors import BadInput
from pressurepose.sim.bed import BedSpec
from pressurepose.sim.press import Heightfield, press_heightfield


def capsule_mesh(radius: float, length: float, center_xy, yaw: float, sections: int = 32):
    """A capsule lying on the unloaded bed: axis horizontal at angle ``yaw`` from x, lowest point
    at z = 0. Returns (vertices (V, 3), faces (F, 3))."""
    import trimesh

    cap = trimesh.creation.capsule(height=length - 2 * radius, radius=radius, count=[sections, sections])
    v = cap.vertices - (cap.vertices.max(0) + cap.vertices.min(0)) / 2  # centre it
    v = v[:, [2, 0, 1]]  # axis z -> x
    c, s = math.cos(yaw), math.sin(yaw)
    v = v @ np.array([[c, s, 0.0], [-s, c, 0.0], [0.0, 0.0, 1.0]])
    v += np.array([center_xy[0], center_xy[1], radius])
    return v, np.asarray(cap.faces)


def press_objects(bed: BedSpec, fields: list[Heightfield], masses) -> tuple[np.ndarray, np.ndarray]:
    """Taxel forces (J, rows, cols) N and sink depths (J,) m of objects on ``bed``."""
    results = [press_heightfield(hf, float(m), bed) for hf, m in zip(fields, masses)]
    return np.stack([r.force for r in results]), np.array([r.sink_m for r in results])


@dataclass(frozen=True)
class SettleStiffness:
    """stiffness: the fitted constant; sinks: the simulated sinks there (m); relative_error: per
    object (sim - measured) / measured."""

    stiffness: float
    sinks: np.ndarray
    relative_error: np.ndarray


def fit_settle_stiffness(measured_sink_m, sink_fn, bounds: tuple[float, float] = (1e2, 1e8),
                         xtol: float = 1e-4) -> SettleStiffness:
    """The contact stiffness at which a bed model's objects sink as measured (appendix A.5).

    ``sink_fn(k) -> (J,)`` simulates the sinks (m, positive down) of the J measured objects in
    the caller's model (e.g. MuJoCo) with stiffness ``k`` in whatever unit that model uses; the
    fit minimises the mean squared relative error over ``log k`` in ``bounds`` (sinks fall as k
    rises, so the minimum is well defined).
    """
    q = np.asarray(measured_sink_m, dtype=np.float64)
    if q.ndim != 1 or len(q) < 1 or not np.all(np.isfinite(q)) or np.any(q <= 0):
        raise BadInput(f"measured_sink_m has shape {q.shape}; expected (J,) positive sink depths in metres")
    lo, hi = bounds
    if not (0 < lo < hi and math.isfinite(hi)):
        raise BadInput(f"bounds {bounds!r} must be 0 < low < high")

    def err(log_k):
        s = np.asarray(sink_fn(10.0 ** log_k), dtype=np.float64)
        if s.shape != q.shape:
            raise BadInput(f"sink_fn returned shape {s.shape}; expected {q.shape}")
        return float(np.mean(((s - q) / q) ** 2)) if np.all(np.isfinite(s)) else np.inf

    res = scipy.optimize.minimize_scalar(err, bounds=(math.log10(lo), math.log10(hi)), method="bounded",
                                         options={"xatol": xtol})
    k = 10.0 ** res.x
    s = np.asarray(sink_fn(k), dtype=np.float64)
    return SettleStiffness(float(k), s, (s - q) / q)


def stiffness_from_penetration(weights_n, penetration_sums_m) -> float:
    """The paper's A.5 average: ``k = mean_j(w_j / sum_i x_ij)`` for objects of weight w_j held at
    their measured sink with particle penetrations x_ij (N/m)."""
    w = np.asarray(weights_n, dtype=np.float64)
    x = np.asarray(penetration_sums_m, dtype=np.float64)
    if w.shape != x.shape or w.ndim != 1 or np.any(w <= 0) or np.any(x <= 0) or not np.all(np.isfinite(w / x)):
        raise BadInput("weights_n and penetration_sums_m must be equal-length positive arrays")
    return float(np.mean(w / x))
