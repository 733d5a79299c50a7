"""Fit the bed's foundation and sensor constants with CMA-ES (paper, appendix A.4 and A.5).

* :func:`calibrate` fits them to real measurements (rigid capsules of known size and weight, the
  mat's image under each and how far each sank; :mod:`pressurepose.calibrate.measurements`) by
  minimising the paper's loss ``L_F + L_C + L_Q`` per object (:func:`calibration_loss`).
* :func:`calibrate_targets` fits them to documented physical targets when there is no real data
  (default :data:`DEFAULT_TARGETS`: sink depth and peak pressure of an average body).

Each fitted constant is searched in a box (:data:`PARAMETERS`), mapped to [0, 1] for CMA-ES;
proposals outside the box or making the sensor's response fall with rising pressure are
penalised, as are beds on which an object finds no equilibrium.
"""

from __future__ import annotations

import dataclasses
import math
from dataclasses import dataclass

import numpy as np

from pressurepose.calibrate.measurements import CapsuleMeasurements
from pressurepose.errors import BadInput, require_whole
from pressurepose.sim.bed import BedSpec
from pressurepose.sim.foundation import PressFailed
from pressurepose.sim.press import (
    Heightfield,
    PressResult,
    body_heightfield,
    press_heightfield,
)
from pressurepose.sim.sensor import MMHG_PA, sensor_law
from pressurepose.sim.stiffness import capsule_mesh, press_objects

PENALTY = 10.0  # loss of a proposal the bed cannot simulate (the loss of a good fit is ~0.01-0.1)


@dataclass(frozen=True)
class Parameter:
    """A fittable constant: searched uniformly between ``low`` and ``high`` (of ``log10`` of the
    value when ``log``)."""

    name: str
    low: float
    high: float
    log: bool = False
    help: str = ""

    def value(self, u: float) -> float:
        v = self.low + u * (self.high - self.low)
        return 10.0 ** v if self.log else v

    def unit(self, value: float) -> float:
        v = math.log10(value) if self.log else value
        return (v - self.low) / (self.high - self.low)


PARAMETERS: dict[str, Parameter] = {p.name: p for p in (
    Parameter("stiffness", math.log10(3e3), math.log10(1e6), True, "Winkler modulus k_A, N/m^3"),
    Parameter("spread", 0.0, 0.10, False, "sqrt(G / k_A), m: how far the foundation spreads a dent"),
    Parameter("c0", -20.0, 20.0, False, "sensor offset, mmHg"),
    Parameter("c1", 0.2, 5.0, False, "sensor gain"),
    Parameter("c2", -0.02, 0.02, False, "sensor curvature, 1/mmHg"),
    Parameter("tissue", math.log10(2e2), math.log10(1e5), True, "soft tissue's Young's modulus E, Pa"),
    Parameter("threshold", 0.0, 10.0, False, "sensor threshold, mmHg: readings below it are 0"),
)}


def bed_params(bed: BedSpec) -> dict[str, float]:
    """The fittable constants of a bed, by :data:`PARAMETERS` name."""
    return {"stiffness": bed.stiffness_n_m3, "spread": bed.spread_length_m, "c0": bed.sensor_c0,
            "c1": bed.sensor_c1, "c2": bed.sensor_c2, "tissue": bed.tissue_modulus_pa,
            "threshold": bed.sensor_threshold_mmhg}


def with_params(bed: BedSpec, params: dict[str, float]) -> BedSpec:
    """``bed`` with some of its :data:`PARAMETERS` replaced."""
    p = {**bed_params(bed), **params}
    return dataclasses.replace(bed, stiffness_n_m3=p["stiffness"], coupling_n_m=p["stiffness"] * p["spread"] ** 2,
                               sensor_c0=p["c0"], sensor_c1=p["c1"], sensor_c2=p["c2"], tissue_modulus_pa=p["tissue"],
                               sensor_threshold_mmhg=p["threshold"])


# ------------------------------------------------------------------ objects and loss
def measurement_heightfields(data: CapsuleMeasurements, bed: BedSpec) -> list[Heightfield]:
    """Each measured object's lower surface on ``bed``'s press grid (computed once per fit)."""
    if bed.mat.shape != data.mat.shape or not np.allclose(
            [bed.mat.pitch_row_m, bed.mat.pitch_col_m], [data.mat.pitch_row_m, data.mat.pitch_col_m]):
        raise BadInput(f"the bed's {bed.mat.name} mat differs from the measurements' {data.mat.name} mat")
    return [body_heightfield(*capsule_mesh(data.radius_m[j], data.length_m[j], data.center_xy_m[j],
                                           data.yaw_rad[j]), bed) for j in range(len(data))]


def readings(force_n: np.ndarray, bed: BedSpec) -> np.ndarray:
    """The mat's readings (mmHg) of ``bed``'s sensor for taxel forces (..., rows, cols) N."""
    x = np.asarray(force_n) / (bed.mat.taxel_area_m2 * MMHG_PA)
    u = sensor_law(x, bed.sensor_c0, bed.sensor_c1, bed.sensor_c2, bed.mat.max_mmhg)
    return np.where(u >= bed.sensor_threshold_mmhg, u, 0.0)


def _paired_terms(sim: np.ndarray, real: np.ndarray) -> np.ndarray:
    """Per object: 1/2 sum|s - r| / sum(s + r) + 1/2 |sum(s - r)| / sum(s + r) (0 if both empty)."""
    axes = tuple(range(1, sim.ndim))
    tot = (sim + real).sum(axes)
    diff = np.abs(sim - real).sum(axes)
    net = np.abs((sim - real).sum(axes))
    return np.divide(0.5 * diff + 0.5 * net, tot, out=np.zeros_like(tot, dtype=np.float64), where=tot > 0)


def loss_terms(sim_pressure, sim_sink, real_pressure, real_sink) -> dict[str, np.ndarray]:
    """The paper's loss terms per object (appendix A.4): ``force`` L_F on the readings,
    ``contact`` L_C on the binary contact maps (reading > 0), ``sink`` L_Q on the sink depths."""
    sp, rp = np.asarray(sim_pressure, float), np.asarray(real_pressure, float)
    sq, rq = np.asarray(sim_sink, float), np.asarray(real_sink, float)
    denom = np.abs(sq) + np.abs(rq)
    return {"force": _paired_terms(sp, rp),
            "contact": _paired_terms((sp > 0).astype(float), (rp > 0).astype(float)),
            "sink": np.divide(np.abs(sq - rq), denom, out=np.zeros_like(denom), where=denom > 0)}


def calibration_loss(sim_pressure, sim_sink, real_pressure, real_sink) -> float:
    """Mean over objects of ``L_F + L_C + L_Q`` (the paper sums them; the mean keeps the stopping
    tolerance independent of how many objects there are)."""
    t = loss_terms(sim_pressure, sim_sink, real_pressure, real_sink)
    return float(np.mean(t["force"] + t["contact"] + t["sink"]))


def sensor_penalty(params: dict[str, float], max_mmhg: float) -> float:
    """How far the sensor law's slope c1 + 2 c2 x falls below 0 for x in [0, 2 max_mmhg]."""
    worst = min(params["c1"], params["c1"] + 4.0 * params["c2"] * max_mmhg)
    return PENALTY * max(0.0, -worst)


# ------------------------------------------------------------------ CMA-ES
@dataclass(frozen=True)
class FitResult:
    """bed: the fitted bed; loss: its loss; fitted: the fitted constants by name; evaluations and
    generations used; history: best loss of each generation; stop: why CMA-ES stopped."""

    bed: BedSpec
    loss: float
    fitted: dict
    evaluations: int
    generations: int
    history: tuple
    stop: dict


def minimize_cma(objective, names: tuple[str, ...], start: dict[str, float], *, popsize: int = 50, seed: int = 0,
                 max_evals: int = 5000, sigma0: float = 0.2, tolfun: float = 1e-4, tolx: float = 5e-4,
                 progress=None) -> tuple[dict[str, float], float, int, int, tuple, dict]:
    """Minimise ``objective(params: dict) -> float`` over the named :data:`PARAMETERS` with CMA-ES.

    CMA-ES works on [0, 1] per parameter (the parameter's box), starts at ``start``, and draws its
    samples from ``numpy.random.default_rng(seed)``: the same seed gives the same fit. The paper's
    settings where they apply: mean learning rate 1 (pycma's default), x tolerance 5e-4,
    function-history tolerance 1e-12, stagnation after 100 generations; ``tolfun`` applies to
    :func:`calibration_loss`, a mean over objects (the paper's 1e-3 was on their sum).
    """
    import cma

    unknown = [n for n in names if n not in PARAMETERS]
    if unknown or not names:
        raise BadInput(f"cannot fit {unknown or 'nothing'}; expected some of {', '.join(PARAMETERS)}")
    require_whole("popsize", popsize, 4)
    params = [PARAMETERS[n] for n in names]
    x0 = np.clip([p.unit(start[p.name]) for p in params], 0.02, 0.98)
    rng = np.random.default_rng(seed)
    opts = {"popsize": popsize, "bounds": [0.0, 1.0], "maxfevals": max_evals, "tolfun": tolfun, "tolx": tolx,
            "tolfunhist": 1e-12, "tolstagnation": 100, "seed": np.nan, "verbose": -9,
            "randn": lambda *shape: rng.standard_normal(shape)}
    es = cma.CMAEvolutionStrategy(list(x0), sigma0, opts)

    def to_params(u):
        return {p.name: p.value(float(min(max(v, 0.0), 1.0))) for p, v in zip(params, u)}

    history = []
    while not es.stop():
        xs = es.ask()
        losses = []
        for u in xs:
            outside = float(np.sum(np.maximum(0, -np.asarray(u)) + np.maximum(0, np.asarray(u) - 1)))
            losses.append(objective(to_params(u)) + PENALTY * outside)
        es.tell(xs, losses)
        history.append(float(min(losses)))
        if progress is not None:
            progress(len(history), es.result.evaluations, float(es.result.fbest))
    best = to_params(es.result.xbest)
    return best, float(es.result.fbest), int(es.result.evaluations), len(history), tuple(history), dict(es.stop())


def calibrate(data: CapsuleMeasurements, bed: BedSpec | None = None, *,
              fit: tuple[str, ...] = ("stiffness", "spread", "c0", "c1", "c2"), popsize: int = 50, seed: int = 0,
              max_evals: int = 5000, sigma0: float = 0.2, tolfun: float = 1e-4, progress=None) -> FitResult:
    """Fit ``fit`` (names in :data:`PARAMETERS`) so the simulated capsules match the measurements.

    ``bed`` gives the starting constants and everything not fitted (default: the default bed
    carrying the measurements' mat).
    """
    if not isinstance(data, CapsuleMeasurements):
        raise BadInput("data must be CapsuleMeasurements (see pressurepose.calibrate.measurements)")
    bed = BedSpec(mat=data.mat) if bed is None else bed
    fields = measurement_heightfields(data, bed)
    cache: dict = {}

    def objective(params):
        trial = with_params(bed, params)
        key = (trial.stiffness_n_m3, trial.coupling_n_m)
        if key not in cache:  # a new sensor alone needs no new press
            cache.clear()
            try:
                cache[key] = press_objects(trial, fields, data.mass_kg)
            except PressFailed:
                cache[key] = None
        if cache[key] is None:
            return PENALTY
        force, sink = cache[key]
        return (calibration_loss(readings(force, trial), sink, data.pressure_mmhg, data.sink_m)
                + sensor_penalty(bed_params(trial), trial.mat.max_mmhg))

    start = bed_params(bed)
    best, loss, evals, gens, hist, stop = minimize_cma(objective, tuple(fit), start, popsize=popsize, seed=seed,
                                                       max_evals=max_evals, sigma0=sigma0, tolfun=tolfun,
                                                       progress=progress)
    fitted_bed = with_params(bed, best)
    return FitResult(fitted_bed, loss, bed_params(fitted_bed), evals, gens, hist, stop)


# ------------------------------------------------------------------ physical targets (no real data)
@dataclass(frozen=True)
class PhysicalTargets:
    """What an average body does on the bed, when there are no measurements to fit.

    max_sink_m: depth of the body's lowest point below the unloaded mattress top; peak_mmhg: the
    highest taxel reading; for a body of ``mass_kg`` lying supine, arms at its sides.
    """

    max_sink_m: float = 0.065
    peak_mmhg: float = 47.0
    mass_kg: float = 62.5
    sources: tuple[str, ...] = (
        "max sink 6.5 cm and peak 47 mmHg: measured in MuJoCo on a capsule ragdoll of an average body settled on "
        "a 35 x 72 grid of spring-loaded cells (Winkler foundation, k_A = 1e5 N/m^3); figures typical of a "
        "foam mattress",
        "62.5 kg: the average female body mass the paper's public code uses (Tozeren 1999; paper appendix A.2)",
    )


DEFAULT_TARGETS = PhysicalTargets()


def targets_loss(result: PressResult, targets: PhysicalTargets) -> float:
    """``|s - s*| / (s + s*) + |p - p*| / (p + p*)`` for sink s and peak reading p (L_Q's form)."""
    s, p = result.sink_m, float(result.pressure.max())
    return abs(s - targets.max_sink_m) / (abs(s) + targets.max_sink_m) + abs(p - targets.peak_mmhg) / (
        abs(p) + targets.peak_mmhg)


def supine_body_mesh(body, bed: BedSpec, betas=None, arm_drop_rad: float = 1.3, pose_offset=None):
    """An SMPL-format ``body`` (a BodyModel) lying supine on the bed, arms lowered toward its sides
    by ``arm_drop_rad`` at the shoulders, centred on the sensing area with its lowest point at z = 0.

    Head toward row 0, face up, the body's left toward -x. ``pose_offset`` (72,) is added to the
    joint angles (its first three values, the root, are ignored). Returns vertices (V, 3) and
    faces (F, 3) of the mesh and its joints (24, 3), bed frame.
    """
    from pressurepose.body.joints import joint_index

    betas = np.zeros(body.num_betas) if betas is None else np.asarray(betas, dtype=np.float64)
    pose = np.zeros(3 * body.num_joints)
    if pose_offset is not None:
        pose[3:] = np.asarray(pose_offset, dtype=np.float64)[3:]
    # SMPL's own joint frames (y up, z forward): turning the left arm (+x) about -z lowers it
    pose[3 * joint_index("left_shoulder") + 2] -= arm_drop_rad
    pose[3 * joint_index("right_shoulder") + 2] += arm_drop_rad
    verts, joints = body.forward(betas, pose)
    # project frame (z up, facing -y, left +x) -> bed: head toward -y, face up (+z)
    rot = np.array([[-1.0, 0.0, 0.0], [0.0, 0.0, -1.0], [0.0, -1.0, 0.0]])
    v, j = verts[0] @ rot.T, joints[0] @ rot.T
    centre = (v.max(0) + v.min(0)) / 2
    shift = np.array([bed.mat.width_m / 2 - centre[0], bed.mat.length_m / 2 - centre[1], -v[:, 2].min()])
    return v + shift, np.asarray(body.faces), j + shift


def calibrate_targets(vertices, faces, targets: PhysicalTargets = DEFAULT_TARGETS, bed: BedSpec | None = None,
                      *, fit: tuple[str, ...] = ("stiffness", "spread"), popsize: int = 50, seed: int = 0,
                      max_evals: int = 2000, sigma0: float = 0.2, tolfun: float = 1e-4, progress=None) -> FitResult:
    """Fit ``fit`` so that a body mesh (bed frame; e.g. :func:`supine_body_mesh`) of
    ``targets.mass_kg`` sinks and presses as the targets say. The sensor stays as in ``bed``
    (default: ideal), since two targets can fix two constants."""
    bed = BedSpec() if bed is None else bed
    hf = body_heightfield(vertices, faces, bed)

    def objective(params):
        trial = with_params(bed, params)
        try:
            return targets_loss(press_heightfield(hf, targets.mass_kg, trial), targets)
        except PressFailed:
            return PENALTY

    best, loss, evals, gens, hist, stop = minimize_cma(objective, tuple(fit), bed_params(bed), popsize=popsize,
                                                       seed=seed, max_evals=max_evals, sigma0=sigma0,
                                                       tolfun=tolfun, progress=progress)
    fitted_bed = with_params(bed, best)
    return FitResult(fitted_bed, loss, bed_params(fitted_bed), evals, gens, hist, stop)


