"""Calibrate the bed against people: CMA-ES fits the mattress, tissue and sensor constants so that
simulated bodies press images whose statistics match real images' (the realism report's targets).

The statistics are the realism report's (:mod:`pressurepose.eval.realism`), per posture group:
the median contact area (taxels > 5 mmHg), the median mean and peak contact pressure, and the mean
load share of each body region along the bed. :class:`PeopleTargets` holds them for real images
(:func:`targets_from_images`, or read back from a ``realism.json``).

The simulated side is a small fixed set of bodies already at rest (:class:`RestingBody`: taken
from a generated dataset or a ``simulate`` output, whose settling is done): each body's lower
surface and tissue depth are sampled once on the bed's press grid, and each candidate's constants
only re-press them (:func:`pressurepose.sim.press.press_heightfield`, first-order tilt), about
0.1 s a body; a candidate that changes only the sensor re-reads the same forces. Settling is not
redone, so a body keeps the pose it settled into on the bed it was made on.

Loss (:func:`people_loss`), per posture group present in both, averaged over the groups::

    ((a_s / a_r - 1) / 0.2)^2 + ((m_s / m_r - 1) / 0.2)^2 + ((p_s / p_r - 1) / 0.3)^2
        + (mean over regions (g^2) + max over regions (g^2)) / 2,   all / 4,
    g = (share_s - share_r) / 0.05

with a the contact area, m the mean and p the peak pressure, share the region shares: each term is
1 where the simulation misses by the realism target (20 % area, 5 percentage points per region;
pressures 20 % and 30 %). The target is on every region, so the worst one counts beside the mean: a
mean alone lets one region stay far off while the others are close.

Real images without a pressure calibration are weight-normalised (their load is the body's
weight), so they fix the sensor's shape (threshold ``c0``, curvature ``c2``) but not its gain:
``c1`` is left out of the default fit (a gain would only trade against the load off the mat).
"""

from __future__ import annotations

import dataclasses
import json
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from pressurepose.calibrate.objects import (
    PENALTY,
    FitResult,
    bed_params,
    minimize_cma,
    readings,
    sensor_penalty,
    with_params,
)
from pressurepose.errors import BadInput
from pressurepose.eval import realism as R
from pressurepose.eval.realism_report import AREA_RATIO_TOLERANCE, SHARE_GAP_GOAL_PP
from pressurepose.sim.bed import BedSpec
from pressurepose.sim.foundation import PressFailed
from pressurepose.sim.press import (
    Heightfield,
    body_heightfield,
    press_heightfield,
    with_tissue,
)
from pressurepose.sim.tissue import BoneCores, bone_cores

DEFAULT_FIT = ("stiffness", "tissue", "threshold")
TOLERANCE = {"area": AREA_RATIO_TOLERANCE, "mean": 0.2, "peak": 0.3, "share": SHARE_GAP_GOAL_PP / 100.0}


@dataclass(frozen=True)
class GroupTargets:
    """Statistics of one posture group: medians of contact taxels, mean and peak pressure (mmHg),
    and the mean region shares (7,) in :data:`pressurepose.eval.realism.REGIONS` order; n images."""

    contact_taxels: float
    mean_mmhg: float
    peak_mmhg: float
    shares: tuple[float, ...]
    n: int


@dataclass(frozen=True)
class PeopleTargets:
    """Targets by posture group ('supine', 'lateral', 'prone') and where they came from."""

    groups: dict
    source: str


def group_targets(stats: dict) -> GroupTargets:
    """:class:`GroupTargets` of per-image statistics (:func:`pressurepose.eval.realism.image_stats`)."""
    s = R.summarise(stats)
    return GroupTargets(s["contact_taxels"]["median"], s["mean_mmhg"]["median"], s["peak_mmhg"]["median"],
                        tuple(s[f"share_{r}"]["mean"] for r in R.REGIONS), s["contact_taxels"]["n"])


def targets_from_images(images, posture, mat, source: str, rule: R.RegionRule = R.DEFAULT_RULE) -> PeopleTargets:
    """Targets from mmHg images (N, rows, cols) on ``mat`` with posture groups (N,)."""
    stats = R.image_stats(images, mat, rule)
    posture = np.asarray(posture, dtype=str)
    groups = {g: group_targets(R.select(stats, posture == g)) for g in ("supine", "lateral", "prone")
              if (posture == g).any()}
    if not groups:
        raise BadInput("no image with a supine, lateral or prone posture to take targets from")
    return PeopleTargets(groups, source)


def targets_from_report(path) -> PeopleTargets:
    """The real images' statistics of a ``pressurepose realism`` report (realism.json)."""
    p = Path(path)
    try:
        rep = json.loads(p.read_text())
        groups = {g: GroupTargets(d["real"]["contact_taxels"]["median"], d["real"]["mean_mmhg"]["median"],
                                  d["real"]["peak_mmhg"]["median"],
                                  tuple(d["real"][f"share_{r}"]["mean"] for r in R.REGIONS),
                                  d["real"]["contact_taxels"]["n"]) for g, d in rep["postures"].items()}
    except FileNotFoundError:
        raise BadInput(f"realism report {str(p)!r} does not exist") from None
    except (OSError, UnicodeDecodeError, json.JSONDecodeError, KeyError, TypeError) as exc:
        raise BadInput(f"{str(p)!r} is not a realism.json written by `pressurepose realism` ({exc})") from None
    return PeopleTargets(groups, f"{p} ({rep.get('real_name', 'real images')})")


# ------------------------------------------------------------------ bodies at rest
@dataclass(frozen=True, eq=False)
class RestingBody:
    """A settled body ready to be re-pressed: its lower surface and tissue depth on the bed's press
    grid (:class:`~pressurepose.sim.press.Heightfield`), mass (kg), posture group, its bones
    before the bone fractions (:class:`~pressurepose.sim.tissue.BoneCores`) and the fractions
    (``BedSpec.tissue_bone_fraction``) the field's tissue was made with; ``vertices`` (V, 3) and
    ``faces`` (F, 3): its mesh where it rests, for the full press (:func:`tipping`)."""

    field: Heightfield
    mass_kg: float
    posture: str
    cores: BoneCores
    fraction: tuple[float, ...]
    vertices: np.ndarray | None = None
    faces: np.ndarray | None = None

    def on(self, bed: BedSpec) -> "RestingBody":
        """The body with the tissue of ``bed``'s bone fractions (itself when they are its own)."""
        f = bed.tissue_bone_fraction
        if f == self.fraction:
            return self
        return dataclasses.replace(self, field=with_tissue(self.field, self.cores.bones(f)), fraction=f)


def resting_body(body, betas, pose, transl, mass_kg: float, bed: BedSpec, posture: str) -> RestingBody:
    """A :class:`RestingBody` of a posed body model (``BodyModel.forward(betas, pose, transl)`` in
    the bed frame) with its bones (:func:`pressurepose.sim.tissue.bone_cores`, the bed's fractions)."""
    verts, _ = body.forward(betas, pose, transl)
    cores = bone_cores(body, betas, pose, transl)
    field = body_heightfield(verts[0], body.faces, bed, bones=cores.bones(bed.tissue_bone_fraction))
    return RestingBody(field, float(mass_kg), str(posture), cores, bed.tissue_bone_fraction, verts[0], body.faces)


def resting_bodies(source, bed: BedSpec, per_posture: int = 4,
                   postures: tuple[str, ...] = ("supine", "lateral"), match: dict | None = None,
                   seed: int = 0) -> list[RestingBody]:
    """``per_posture`` bodies of each posture group in a generated dataset (directory) or a
    ``simulate`` .npz, as :class:`RestingBody` on ``bed``: the first ones, or with ``match``
    ({group: real extent ratios (M,)}, :func:`pressurepose.eval.realism.extent_ratio`) distinct
    bodies drawn (seeded) so that their extent ratios follow the real ones', as
    ``realism --match-extent`` compares like postures."""
    from pressurepose.body import BodyModel
    from pressurepose.data.schema import GENDERS
    from pressurepose.eval.posture import posture_of

    fields = ("betas", "pose", "transl", "mass") + (("pressure", "height") if match else ())
    p = Path(source)
    if p.is_dir():
        from pressurepose.data.dataset import DatasetReader

        a = DatasetReader(p).load_arrays(fields, label_dtype=np.float64)
        genders = np.array(GENDERS)[a["gender"]]
    elif p.is_file():
        from pressurepose.files import load_npz

        a = load_npz(p, "settled bodies (a `pressurepose simulate` .npz)", fields + ("gender",))
        genders = np.full(len(a["mass"]), str(a["gender"]))
    else:
        raise BadInput(f"settled bodies {str(p)!r} do not exist; expected a dataset directory or a simulate .npz")
    group = R.posture_group(posture_of(np.asarray(a["pose"], dtype=np.float64)))
    if match:
        pressure = np.asarray(a["pressure"], dtype=np.float64)
        if pressure.shape[1:] != bed.mat.shape:
            raise BadInput(f"{p} holds {pressure.shape[1]} x {pressure.shape[2]} images; the bed's mat "
                           f"{bed.mat.name} is {bed.mat.rows} x {bed.mat.cols}")
        ratio = R.extent_ratio(pressure, bed.mat, np.asarray(a["height"], dtype=np.float64).reshape(-1))
    rng = np.random.default_rng(seed)
    models, out = {}, []
    for g in postures:
        members = np.flatnonzero(group == g)
        if match and g in match and len(members):
            pick, _ = R.match_by(ratio[members], match[g], seed)
            members = members[list(dict.fromkeys(rng.permutation(pick).tolist()))]
        for i in members[:per_posture]:
            body = models.setdefault(genders[i], BodyModel(genders[i]))
            out.append(resting_body(body, a["betas"][i], a["pose"][i], a["transl"][i], a["mass"][i], bed, g))
    if not out:
        raise BadInput(f"{p} holds no body in postures {', '.join(postures)}")
    return out


# ------------------------------------------------------------------ loss and fit
def people_loss(sim: dict, targets: PeopleTargets) -> float:
    """The module docstring's loss of simulated :class:`GroupTargets` by group against the targets."""
    terms = []
    for g, s in sim.items():
        if g not in targets.groups or s is None:
            continue
        t = targets.groups[g]
        area = (s.contact_taxels / max(t.contact_taxels, 1.0) - 1) / TOLERANCE["area"]
        mean = (np.nan_to_num(s.mean_mmhg) / t.mean_mmhg - 1) / TOLERANCE["mean"]
        peak = (s.peak_mmhg / t.peak_mmhg - 1) / TOLERANCE["peak"]
        share = np.nan_to_num(np.subtract(s.shares, t.shares), nan=1.0) / TOLERANCE["share"]
        shares = (float(np.mean(share ** 2)) + float(np.max(share ** 2))) / 2
        terms.append((area ** 2 + mean ** 2 + peak ** 2 + shares) / 4)
    if not terms:
        raise BadInput(f"the bodies' postures ({', '.join(sim)}) and the targets' "
                       f"({', '.join(targets.groups)}) have none in common")
    return float(np.mean(terms))


def press_forces(bodies: list[RestingBody], bed: BedSpec) -> np.ndarray:
    """(B, rows, cols) taxel forces (N) of every body re-pressed on ``bed`` (its bone fractions too)."""
    return np.stack([press_heightfield(b.on(bed).field, b.mass_kg, bed).force for b in bodies])


def pressable(bodies: list[RestingBody], bed: BedSpec) -> tuple[list[RestingBody], int]:
    """(the bodies that ``bed`` re-presses, how many it does not)."""
    keep = []
    for b in bodies:
        try:
            press_heightfield(b.on(bed).field, b.mass_kg, bed)
            keep.append(b)
        except PressFailed:
            pass
    return keep, len(bodies) - len(keep)


def tipping(bodies: list[RestingBody], bed: BedSpec) -> dict[str, tuple[int, int]]:
    """{posture group: (bodies that tip over, bodies)} when each body's mesh is pressed on ``bed``
    with the full press (:func:`pressurepose.sim.press.press`: turned and pressed again while it
    tilts). The fit's first-order re-press does not turn the body, so it can accept a bed on which
    bodies lying on their side would roll over: ``generate`` rejects those (``press_failed``) and
    ``repress`` leaves them out. Bodies without a mesh are not counted."""
    from pressurepose.sim.press import press

    out: dict[str, list[int]] = {}
    for b in bodies:
        if b.vertices is None:
            continue
        count = out.setdefault(b.posture, [0, 0])
        count[1] += 1
        try:
            press(b.vertices, b.faces, b.mass_kg, bed, bones=b.cores.bones(bed.tissue_bone_fraction))
        except PressFailed:
            count[0] += 1
    return {g: (t, n) for g, (t, n) in out.items()}


def simulated_stats(forces: np.ndarray, bodies: list[RestingBody], bed: BedSpec,
                    rule: R.RegionRule = R.DEFAULT_RULE) -> dict:
    """{group: GroupTargets} of the bodies' images read by ``bed``'s sensor."""
    images = readings(forces, bed)
    stats = R.image_stats(images, bed.mat, rule)
    posture = np.array([b.posture for b in bodies])
    return {g: group_targets(R.select(stats, posture == g)) for g in dict.fromkeys(posture.tolist())}


def calibrate_people(bodies: list[RestingBody], targets: PeopleTargets, bed: BedSpec, *,
                     fit: tuple[str, ...] = DEFAULT_FIT, popsize: int = 10, seed: int = 0, max_evals: int = 400,
                     sigma0: float = 0.2, tolfun: float = 1e-3, progress=None) -> FitResult:
    """Fit ``fit`` (names in :data:`pressurepose.calibrate.objects.PARAMETERS`) so that ``bodies``
    re-pressed on the bed match ``targets`` (:func:`people_loss`); ``bed`` gives the start and
    every constant not fitted, and must be the bed the bodies were sampled on."""
    if not bodies:
        raise BadInput("no bodies to calibrate with")
    cache: dict = {}

    def objective(params):
        trial = with_params(bed, params)
        key = (trial.stiffness_n_m3, trial.coupling_n_m, trial.tissue_modulus_pa, trial.tissue_bone_fraction)
        if key not in cache:  # a new sensor alone needs no new press
            cache.clear()
            try:
                cache[key] = press_forces(bodies, trial)
            except PressFailed:
                cache[key] = None
        if cache[key] is None:
            return PENALTY
        return (people_loss(simulated_stats(cache[key], bodies, trial), targets)
                + sensor_penalty(bed_params(trial), trial.mat.max_mmhg))

    best, loss, evals, gens, hist, stop = minimize_cma(objective, tuple(fit), bed_params(bed), popsize=popsize,
                                                       seed=seed, max_evals=max_evals, sigma0=sigma0,
                                                       tolfun=tolfun, progress=progress)
    fitted_bed = with_params(bed, best)
    return FitResult(fitted_bed, loss, bed_params(fitted_bed), evals, gens, hist, stop)


# ------------------------------------------------------------------ the calibrate verb's --targets real
