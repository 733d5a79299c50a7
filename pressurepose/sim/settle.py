"""Physics simulation #1: rest the capsule ragdoll on the soft bed (paper section 3.2, appendix A.2).

The procedure is the paper's: the ragdoll (:mod:`pressurepose.sim.ragdoll`) starts in the sampled
pose with its lowest point just above the mattress (:mod:`pressurepose.sim.cellbed`); until the
pelvis (buttocks) capsule reaches the bed (or, for a body held up by other parts, until the bed
carries half its weight) every 4th step zeroes its velocities, so a limb that touches first does
not let the trunk build momentum; it then runs until the resting criterion (the
fastest capsule point slower than 0.05 m/s and accelerating less than 0.5 m/s^2) has held for
``rest_hold_steps`` consecutive steps (0.2 s), or gives up after 20 s (2000 steps of dt = 0.01 s).
Not the paper's: 150 steps after the pelvis touches, the step doubles to 0.02 s for the slow rest
of the settle (``SettleConfig.coarse_factor``), which saves a fifth to a quarter of its CPU; the
rests it finds differ from the fine step's no more than the rests of a body started 2 mm
elsewhere differ from each other (``benchmarks/bench_settle.py --agreement``, docs/throughput.md).

Why hold the criterion for 20 steps (0.2 s): a single step can pass it at the turning point of a
slow rocking or bouncing motion; the slowest motions here (the trunk rocking on the mattress, a limb
swinging on its damped joints) turn around over a few steps, and 0.2 s is longer than that yet
short against the settle itself (the benchmark measures how far bodies still move after being
declared at rest).

A sample is rejected, and the cause counted, when it:

* ``not_settled``: runs 2000 steps without resting;
* ``unstable``: produces non-finite numbers, a MuJoCo warning or a capsule faster than 5 m/s;
* ``fell_off_bed``: its centre of mass leaves the mattress outline, or its pelvis drops more than
  ``fall_depth_m`` below the mattress top;
* ``posture_changed``: leaves the posture class (supine / left or right lateral / prone) it started
  in while settling (checked every ``posture_check_steps`` steps, so a body rolling over stops
  early instead of running on until it rests or falls off), or rests in another class (with a
  wedge: leaves 5-100 degrees of roll on the side it started on);
* ``self_collision``: starts with capsules of its limbs inside other capsules (the sampler's job);
* ``support_overlap``: (with a wedge) starts with a capsule more than 1 cm inside the wedge (a
  limb behind the back where the wedge goes).

With ``wedge=True`` a foam wedge props the body (:mod:`pressurepose.sim.wedge`): a rigid box
placed against the trunk's back where the body starts, touching the body only; the result holds
the wedge and the forces the body leans on it with.

Model choices measured here (``benchmarks/bench_settle.py``, docs/RESULTS.md): elliptic friction cones
(with pyramidal ones a supine body crept 1-2 cm sideways and resting limbs chattered, taking 2-3x the
steps); cells of 2 x 2 taxels (3-4x faster than one per taxel, the cost being mostly contacts and
cells); collisions only between the body and the cells, and between limb capsules and the rest of
the body. Speed: one compiled model per (bed, config) serves every body; per sample only the
shape-dependent numbers are rewritten (:func:`pressurepose.sim.ragdoll.write_params`) and MuJoCo's
derived constants recomputed, so nothing is compiled per sample.

Frames: inputs and outputs are SMPL parameters (pose in SMPL's own axis-angle, translation in the
z-up bed frame, as ``BodyModel.forward``); the resting pose is exact for the mesh:
``posed_capsules(body, caps, betas, result.pose, result.transl)`` gives the ragdoll's capsules.
"""

from __future__ import annotations

import dataclasses
import hashlib
import json
import math
import os
from dataclasses import dataclass
from functools import lru_cache
from pathlib import Path

import mujoco
import numpy as np

from pressurepose.body.capsules import CAPSULE_NAMES
from pressurepose.errors import BadInput
from pressurepose.pose.posture import (
    POSTURES,
    posture_class,
    posture_index,
    roll_angle,
    roll_of_rotation,
)
from pressurepose.sim.bed import BedSpec, get_bed
from pressurepose.sim.cellbed import (
    CellBed,
    CellIndex,
    add_cells,
    capsule_sinks,
    cell_bed,
    cell_forces,
    cell_sink,
)
from pressurepose.sim.presets import SETTLES
from pressurepose.sim.ragdoll import (
    BED_BIT,
    DAMPING_PER_STIFFNESS_S,
    LIMIT_STIFFNESS_FACTOR,
    RELAXED_LIMB_DAMPING_S,
    RELAXED_SPINE_STIFFNESS,
    RagdollIndex,
    RagdollParams,
    add_ragdoll,
    flexed_neck_home,
    limit_torques,
    local_to_smpl,
    pose_to_qpos,
    qpos_to_pose,
    quat_to_rotvec,
    ragdoll_params,
    rotation_to_quat,
    write_params,
)

STATUSES = ("settled", "not_settled", "unstable", "fell_off_bed", "posture_changed", "self_collision",
            "support_overlap")
SUPPORT_OVERLAP_M = 0.01  # a capsule this deep in the wedge where the body starts: rejected
PELVIS = CAPSULE_NAMES.index("pelvis")
_CONES = {"pyramidal": mujoco.mjtCone.mjCONE_PYRAMIDAL, "elliptic": mujoco.mjtCone.mjCONE_ELLIPTIC}
_WARNINGS = (mujoco.mjtWarning.mjWARN_BADQACC, mujoco.mjtWarning.mjWARN_BADQPOS, mujoco.mjtWarning.mjWARN_BADQVEL,
             mujoco.mjtWarning.mjWARN_CONTACTFULL, mujoco.mjtWarning.mjWARN_CNSTRFULL)


@dataclass(frozen=True)
class SettleConfig:
    """Settings of physics simulation #1 (defaults: the paper's procedure, appendix A.2).

    timestep_s, max_steps, zero_every: step length, step budget, velocity-zeroing period before the
        pelvis touches. rest_speed_m_s, rest_accel_m_s2, rest_hold_steps: the resting criterion and
        how many consecutive steps it must hold. drop_clearance_m: the lowest capsule point's start
        height above the mattress.
    cell_m, taxels_per_cell: cell size of the mattress grid, by default 2 x 2 taxels (see the
        benchmark: 3-4x faster than one cell per taxel; the two grids rest bodies a median 2-3 cm
        apart, trunks closer than limbs). stiffness_n_m3: the settle model's foundation
        modulus; by default fitted so that body-part capsules sink into these cells as deep as into
        the bed's press model (:func:`calibrate_stiffness`, appendix A.5; a few seconds, once per
        bed, config and source version on a machine: :func:`settle_stiffness` keeps it on disk).
        coupling: tie neighbouring cells with the bed's shear stiffness.
    self_collision: limbs (forearms, hands, calves, feet) collide with the other capsules.
    cone: MuJoCo's friction cone, 'pyramidal' or 'elliptic'.
    limit_stiffness_factor: ball-joint limit penalty, multiple of the joint stiffness.
    iterations, ls_iterations, tolerance: Newton solver settings.
    max_speed_m_s: faster capsule points mean the simulation blew up; fall_depth_m: a pelvis this far
        below the mattress top has fallen off; self_collision_tol_m: start overlap allowed between limbs.
    posture_check_steps: how often (steps) the posture class is checked while settling.
    relaxed_neck: soft neck and head joints so the head rests on the bed (default; False: the
        paper's stiffness, see :data:`pressurepose.sim.ragdoll.RELAXED_NECK_STIFFNESS`).
    spine_stiffness: N m/rad of the spine joints for the average body (default a relaxed spine,
        :data:`pressurepose.sim.ragdoll.RELAXED_SPINE_STIFFNESS`; None: the paper's 200).
    coarse_factor, coarse_after_steps: the settle's step grows to ``coarse_factor x timestep_s``
        ``coarse_after_steps`` steps after the pelvis touches the bed (1: never). The drop and the
        first rocking run at ``timestep_s``; the slow end of the settle, where limbs creep on their
        dampers, at the longer step. The resting criterion stays in m/s and seconds (the hold
        becomes ``rest_hold_steps / coarse_factor`` steps) and the step budget in seconds. The
        cells keep the mass chosen for ``timestep_s`` (spring-mass frequency times the coarse step:
        ``coarse_factor x`` CELL_OMEGA_DT, inside the stable range). Rests differ from the fine
        step's no more than those of two starts 2 mm apart do (docs/throughput.md).
    lateral_neck_flexion_deg: for a body drawn on its side (its start pose's posture class), the
        neck's and head's springs rest flexed forward by this many degrees in all (0, the default:
        the home pose's straight neck for every body). An option for side-lying realism studies
        (docs/sim_to_real.md, session 18), not a default: it moves the loaded shoulder of
        simulated side-lying images toward the real ones', and the image-only head-imprint rule
        then misses more heads.
    limb_damping_s: the damping of the limb joints (hips, knees, ankles, collars, shoulders, elbows,
        wrists) as this many seconds x their stiffness; None (the default) keeps the paper's 15 s. With
        the paper's damping a relaxed arm falls at about the resting speed, so 42 % of resting wrists
        stay more than 0.1 m above the bed; 3 rests them on it (the settle preset 'relaxed-limbs'). An
        option, not a default: on PMD-I's images it helps some statistics and hurts others
        (docs/physics.md, "Relaxed limbs").
    """

    timestep_s: float = 0.01
    max_steps: int = 2000
    zero_every: int = 4
    rest_speed_m_s: float = 0.05
    rest_accel_m_s2: float = 0.5
    rest_hold_steps: int = 20
    drop_clearance_m: float = 0.005
    cell_m: float | None = None
    taxels_per_cell: int = 2
    stiffness_n_m3: float | None = None
    coupling: bool = True
    self_collision: bool = True
    limit_stiffness_factor: float = LIMIT_STIFFNESS_FACTOR
    cone: str = "elliptic"
    iterations: int = 50
    ls_iterations: int = 20
    tolerance: float = 1e-8
    max_speed_m_s: float = 5.0
    fall_depth_m: float = 0.25
    self_collision_tol_m: float = 0.002
    posture_check_steps: int = 10
    relaxed_neck: bool = True
    spine_stiffness: float | None = RELAXED_SPINE_STIFFNESS
    coarse_factor: float = 2.0
    coarse_after_steps: int = 150
    lateral_neck_flexion_deg: float = 0.0
    limb_damping_s: float | None = None

    def __post_init__(self):
        for name in ("max_steps", "zero_every", "rest_hold_steps", "iterations", "ls_iterations",
                     "taxels_per_cell", "posture_check_steps", "coarse_after_steps"):
            v = getattr(self, name)
            if isinstance(v, bool) or not isinstance(v, (int, np.integer)) or v < 1:
                raise BadInput(f"settle {name} is {v!r}; expected a positive whole number")
        for name in ("timestep_s", "rest_speed_m_s", "rest_accel_m_s2", "tolerance", "max_speed_m_s",
                     "fall_depth_m", "limit_stiffness_factor"):
            v = getattr(self, name)
            if not (isinstance(v, (int, float)) and math.isfinite(v) and v > 0):
                raise BadInput(f"settle {name} is {v!r}; expected a positive number")
        if self.cone not in _CONES:
            raise BadInput(f"settle cone {self.cone!r} is not known; expected one of {', '.join(_CONES)}")
        v = self.spine_stiffness
        if v is not None and (isinstance(v, bool) or not isinstance(v, (int, float)) or not math.isfinite(v) or v <= 0):
            raise BadInput(f"settle spine_stiffness is {v!r}; expected a positive number of N m/rad, "
                           f"or None for the paper's")
        v = self.limb_damping_s
        if v is not None and (isinstance(v, bool) or not isinstance(v, (int, float)) or not math.isfinite(v) or v <= 0):
            raise BadInput(f"settle limb_damping_s is {v!r}; expected a positive number of seconds, or None for "
                           f"the paper's 15")
        v = self.lateral_neck_flexion_deg
        if isinstance(v, bool) or not isinstance(v, (int, float)) or not 0.0 <= v <= 90.0:
            raise BadInput(f"settle lateral_neck_flexion_deg is {v!r}; expected degrees from 0 to 90")
        c = self.coarse_factor
        if isinstance(c, bool) or not isinstance(c, (int, float)) or not 1.0 <= c <= 4.0:
            raise BadInput(f"settle coarse_factor is {c!r}; expected a number from 1 (no coarse step) to 4")
        for name in ("drop_clearance_m", "self_collision_tol_m"):
            v = getattr(self, name)
            if not (isinstance(v, (int, float)) and math.isfinite(v) and v >= 0):
                raise BadInput(f"settle {name} is {v!r}; expected zero or a positive number")




def settle_preset(name: str) -> SettleConfig:
    """The :class:`SettleConfig` of a named settle: 'relaxed' (the defaults: neck and spine relax so
    bodies rest as people lie), 'paper' (the paper's joint springs throughout) or 'relaxed-limbs'
    (the defaults with the limbs damped at :data:`~pressurepose.sim.ragdoll.RELAXED_LIMB_DAMPING_S`
    x their stiffness, so resting hands lie on the bed, not in the air)."""
    if name == "relaxed":
        return SettleConfig()
    if name == "paper":
        return SettleConfig(relaxed_neck=False, spine_stiffness=None)
    if name == "relaxed-limbs":
        return SettleConfig(limb_damping_s=RELAXED_LIMB_DAMPING_S)
    raise BadInput(f"settle {name!r} is not known; expected one of {', '.join(SETTLES)}")


@dataclass(frozen=True, eq=False)
class SettleResult:
    """Outcome of settling one body.

    status: 'settled' or the cause of rejection (see module docstring; ``STATUSES``).
    pose: (72,) SMPL axis-angle and transl: (3,) m (z-up bed frame) of the resting body (of the last
        state reached when rejected); betas: (S,); gender.
    steps: steps simulated; touch_step: the step the pelvis reached the bed (-1 if never).
    capsules: (20, 2, 3) world axis-segment ends of the ragdoll's capsules at the end, radius (20,).
    posture_start, posture: posture class of the input and of the result.
    mass_kg: body mass; bed_force_n: total vertical force on the mattress at the end (m g at rest);
    max_sink_m: the deepest cell displacement at the end (positive down).
    wedge: the :class:`~pressurepose.sim.wedge.Wedge` that propped the body (None without one);
    wedge_points (K, 3) and wedge_force_z (K,): where the body leans on it at the end and the
    vertical force (N, >= 0) pressing the wedge down there (empty without a wedge).
    """

    status: str
    pose: np.ndarray
    transl: np.ndarray
    betas: np.ndarray
    gender: str
    steps: int
    touch_step: int
    capsules: np.ndarray
    radius: np.ndarray
    posture_start: str
    posture: str
    mass_kg: float
    bed_force_n: float
    max_sink_m: float
    wedge: object = None
    wedge_points: np.ndarray = dataclasses.field(default_factory=lambda: np.zeros((0, 3)))
    wedge_force_z: np.ndarray = dataclasses.field(default_factory=lambda: np.zeros(0))

    @property
    def ok(self) -> bool:
        return self.status == "settled"


class SettleModel:
    """One compiled MuJoCo model (ragdoll + cell bed, and with ``support`` a wedge, placed per body)
    reused for every body on one bed and config.

    The first body compiles it; later bodies rewrite the shape-dependent numbers in place.
    ``model``, ``data``, ``cells``, ``ragdoll`` (a :class:`RagdollIndex`), ``cell_index``,
    ``stiffness_n_m3`` (the cells' foundation modulus, calibrated unless the config sets it).
    """

    def __init__(self, bed: BedSpec, config: SettleConfig, params: RagdollParams, support: bool = False):
        self.bed, self.config = bed, config
        k = config.stiffness_n_m3
        self.stiffness_n_m3 = settle_stiffness(bed, config) if k is None else k
        self.cells: CellBed = settle_cells(bed, config, self.stiffness_n_m3)
        self.model = build_spec(params, self.cells, config, support).compile()
        self.data = mujoco.MjData(self.model)
        self.support_geom = mujoco.mj_name2id(self.model, mujoco.mjtObj.mjOBJ_GEOM, "support") if support else -1
        self.support_mocap = int(self.model.body_mocapid[self.model.geom_bodyid[self.support_geom]]) if support else -1
        self.ragdoll = RagdollIndex.of(self.model)
        self.cell_index = CellIndex.of(self.model, self.cells)
        # the ragdoll comes first in the tree: its dofs are the leading block
        self.nq = 7 + 4 * len(self.ragdoll.ball) + len(self.ragdoll.hinge)
        self.nv = 6 + 3 * len(self.ragdoll.ball) + len(self.ragdoll.hinge)
        if self.ragdoll.qpos.min() != 0 or int(self.model.dof_bodyid[self.nv - 1]) not in set(self.ragdoll.body):
            raise RuntimeError("the ragdoll's joints must lead the model's qpos")
        solo = mujoco.MjSpec()
        solo.compiler.degree = False
        add_ragdoll(solo, params)
        self._solo = solo.compile()
        self._solo_data = mujoco.MjData(self._solo)
        self._solo_index = RagdollIndex.of(self._solo)
        if not (np.array_equal(self._solo_index.dof, self.ragdoll.dof)
                and np.array_equal(self._solo_index.body, self.ragdoll.body)):
            raise RuntimeError("the ragdoll-only model must number bodies and dofs as the full model")

    def configure(self, params: RagdollParams, pose: np.ndarray, transl: np.ndarray) -> None:
        """Load one body: its shape-dependent numbers, then its pose (qpos), velocities zero.

        MuJoCo's derived constants (subtree masses, inverse weights, diagonal inertia at qpos0) are
        recomputed on a ragdoll-only copy of the model, which is exact (the cells are separate trees
        whose constants never change) and 50x cheaper than ``mj_setConst`` on the whole bed.
        """
        m, d, solo, ri = self.model, self.data, self._solo, self.ragdoll
        write_params(m, ri, params)
        write_params(solo, self._solo_index, params)
        mujoco.mj_resetData(m, d)
        pose_to_qpos(m, ri, params, pose, transl, d.qpos)  # also sets hinge swings
        solo.body_quat[self._solo_index.body] = m.body_quat[ri.body]
        mujoco.mj_setConst(solo, self._solo_data)
        sb, b = self._solo_index.body, ri.body
        m.body_subtreemass[b] = solo.body_subtreemass[sb]
        m.body_subtreemass[0] = m.body_mass.sum()
        m.body_invweight0[b] = solo.body_invweight0[sb]
        m.dof_invweight0[: self.nv] = solo.dof_invweight0
        m.dof_M0[: self.nv] = solo.dof_M0
        m.stat.meaninertia = float(np.mean(m.dof_M0))
        m.stat.meanmass = float(np.mean(m.body_mass[1:]))


def settle_cells(bed: BedSpec, config: SettleConfig, stiffness_n_m3: float | None = None) -> CellBed:
    """The cell bed ``config`` settles bodies on (``stiffness_n_m3`` overrides the config's)."""
    return cell_bed(bed, config.cell_m, taxels_per_cell=config.taxels_per_cell, coupling=config.coupling,
                    stiffness_n_m3=config.stiffness_n_m3 if stiffness_n_m3 is None else stiffness_n_m3,
                    timestep_s=config.timestep_s)


@dataclass(frozen=True)
class CapsuleObjects:
    """Rigid capsules lying on the bed, in :class:`~pressurepose.calibrate.measurements.CapsuleMeasurements`'
    terms: radius_m, length_m (end to end, caps included), mass_kg (J,); center_xy_m (J, 2); yaw_rad (J,)."""

    radius_m: tuple[float, ...]
    length_m: tuple[float, ...]
    mass_kg: tuple[float, ...]
    center_xy_m: tuple[tuple[float, float], ...]
    yaw_rad: tuple[float, ...]


# Body-part-like capsules of an average body (trunk, thigh, calf, upper arm, head), spread over the bed
# at assorted angles so that the fit does not hinge on how one object lines up with the cells.
BODY_PART_CAPSULES = CapsuleObjects(
    radius_m=(0.10, 0.07, 0.05, 0.045, 0.09), length_m=(0.50, 0.49, 0.45, 0.34, 0.28),
    mass_kg=(25.0, 8.0, 3.0, 2.0, 5.0),
    center_xy_m=((0.38, 0.90), (0.30, 1.20), (0.50, 0.60), (0.20, 0.40), (0.40, 1.50)),
    yaw_rad=(0.0, 1.57, 0.3, 0.8, 0.0))


def settle_sink_fn(objects, bed: BedSpec, config: SettleConfig | None = None):
    """``k -> sinks (J,)`` m of the capsules ``objects`` (a :class:`CapsuleObjects` or measurements) on
    ``config``'s cell bed with foundation modulus k (N/m^3): the ``sink_fn`` of
    :func:`pressurepose.sim.stiffness.fit_settle_stiffness` (appendix A.5). The cell size matters: a
    coarse cell is pressed as deep as the deepest point above it, so coarse grids need a softer k."""
    config = SettleConfig() if config is None else config
    o = objects

    def sink_fn(k: float) -> np.ndarray:
        return capsule_sinks(settle_cells(bed, config, k), o.radius_m, o.length_m, o.mass_kg, o.center_xy_m,
                             o.yaw_rad)

    return sink_fn


def calibrate_stiffness(bed: BedSpec | None = None, config: SettleConfig | None = None,
                        objects: CapsuleObjects = BODY_PART_CAPSULES):
    """Appendix A.5 without real measurements: the settle bed's modulus at which ``objects`` sink as
    deep as the (calibrated) press model of ``bed`` says they sink. Returns a
    :class:`~pressurepose.sim.stiffness.SettleStiffness`; use ``SettleConfig(stiffness_n_m3=...)``.
    About 15 s on one core."""
    from pressurepose.sim.press import body_heightfield
    from pressurepose.sim.stiffness import (
        capsule_mesh,
        fit_settle_stiffness,
        press_objects,
    )

    bed = get_bed() if bed is None else bed
    o = objects
    fields = [body_heightfield(*capsule_mesh(r, L, xy, yaw), bed)
              for r, L, xy, yaw in zip(o.radius_m, o.length_m, o.center_xy_m, o.yaw_rad)]
    _, press_sinks = press_objects(bed, fields, o.mass_kg)
    k = bed.stiffness_n_m3
    return fit_settle_stiffness(press_sinks, settle_sink_fn(o, bed, config), bounds=(k / 10, k * 10), xtol=2e-3)


CACHE_ENV = "PRESSUREPOSE_CACHE_DIR"


def cache_dir() -> Path | None:
    """Where computed set-up (the settle stiffness) is kept between runs: ``$PRESSUREPOSE_CACHE_DIR``
    (empty: no cache), else ``$XDG_CACHE_HOME/pressurepose``, else ``~/.cache/pressurepose``."""
    if CACHE_ENV in os.environ:
        value = os.environ[CACHE_ENV].strip()
        return Path(value).expanduser() if value else None
    base = os.environ.get("XDG_CACHE_HOME") or Path.home() / ".cache"
    return Path(base) / "pressurepose"


@lru_cache(maxsize=1)
def _source_digest() -> str:
    """sha256 of the simulation package's source: any change to the bed, the press or the fit
    invalidates cached fits."""
    h = hashlib.sha256()
    for path in sorted(Path(__file__).parent.glob("*.py")):
        h.update(path.name.encode() + b"\0" + path.read_bytes())
    return h.hexdigest()


def stiffness_cache_key(bed: BedSpec, config: SettleConfig) -> str:
    """Key of a fitted settle stiffness: everything it depends on (the bed, the config, the source of
    :mod:`pressurepose.sim` and the versions of the libraries that compute it)."""
    import scipy

    from pressurepose import __version__

    text = json.dumps({"bed": repr(bed), "config": repr(dataclasses.replace(config, stiffness_n_m3=None)),
                       "source": _source_digest(), "pressurepose": __version__, "mujoco": mujoco.__version__,
                       "numpy": np.__version__, "scipy": scipy.__version__}, sort_keys=True)
    return hashlib.sha256(text.encode()).hexdigest()


def settle_stiffness(bed: BedSpec, config: SettleConfig) -> float:
    """The foundation modulus (N/m^3) the settle model uses for ``bed`` and ``config``:
    :func:`calibrate_stiffness`'s fit (about 1.5-4 s), computed once and kept in :func:`cache_dir`
    under :func:`stiffness_cache_key`, so worker processes and later runs read it instead. A missing,
    unreadable or unwritable cache only costs the fit."""
    from pressurepose.files import write_json_atomic

    key = stiffness_cache_key(bed, config)
    root = cache_dir()
    path = None if root is None else root / f"settle-stiffness-{key[:32]}.json"
    if path is not None:
        try:
            cached = json.loads(path.read_text())
            k = float(cached["stiffness_n_m3"])
            if cached.get("key") == key and math.isfinite(k) and k > 0:
                return k
        except (OSError, ValueError, KeyError, TypeError):
            pass
    k = float(calibrate_stiffness(bed, config).stiffness)
    if path is not None:
        try:
            path.parent.mkdir(parents=True, exist_ok=True)
            write_json_atomic(path, {"key": key, "stiffness_n_m3": k})
        except OSError:
            pass
    return k


def build_spec(params: RagdollParams, cells: CellBed, config: SettleConfig, support: bool = False) -> mujoco.MjSpec:
    """The settle model as an MjSpec: the ragdoll first, then the cell bed, then with ``support`` a
    mocap body "support" holding a box (the wedge, sized and placed per body, colliding with the
    body only); implicitfast integrator, Newton solver, ``config.cone`` friction cones."""
    spec = mujoco.MjSpec()
    spec.modelname = "settle"
    spec.compiler.degree = False
    o = spec.option
    o.timestep = config.timestep_s
    o.integrator = mujoco.mjtIntegrator.mjINT_IMPLICITFAST
    o.solver = mujoco.mjtSolver.mjSOL_NEWTON
    o.cone = _CONES[config.cone]
    o.iterations = config.iterations
    o.ls_iterations = config.ls_iterations
    o.tolerance = config.tolerance
    o.gravity = [0.0, 0.0, -9.81]
    o.disableflags |= mujoco.mjtDisableBit.mjDSBL_AUTORESET  # keep a blown-up state to report it
    add_ragdoll(spec, params, self_collision=config.self_collision, friction=cells.friction,
                contact_timeconst_s=cells.contact_timeconst_s)
    add_cells(spec, cells)
    if support:
        holder = spec.worldbody.add_body(name="support", mocap=True, pos=[0.0, 0.0, -10.0])
        holder.add_geom(name="support", type=mujoco.mjtGeom.mjGEOM_BOX, size=[0.1, 0.1, 0.1], contype=BED_BIT,
                        conaffinity=0, condim=3, friction=[cells.friction, 0.005, 0.0001],
                        solref=[cells.contact_timeconst_s, 1.0])
    return spec


_MODELS: dict = {}


def settle_model(bed: BedSpec, config: SettleConfig, params: RagdollParams, support: bool = False) -> SettleModel:
    """The cached :class:`SettleModel` for (bed, config, support), compiled with ``params`` the
    first time. One per process: it holds one ``MjData``, so threads must not settle concurrently."""
    key = (bed, config, bool(support))
    if key not in _MODELS:
        _MODELS[key] = SettleModel(bed, config, params, bool(support))
    return _MODELS[key]


def capsule_ends(model: mujoco.MjModel, data: mujoco.MjData, index: RagdollIndex,
                 length: np.ndarray | None = None) -> np.ndarray:
    """(20, 2, 3) world axis-segment ends of the ragdoll's capsules (end 0 at local z = -length/2).
    length: (20,) m cylinder lengths, e.g. ``RagdollParams.length`` (the body's capsules); default the
    contact geoms' (shorter for the trunk, see :mod:`pressurepose.sim.ragdoll`)."""
    g = index.geom
    axis = data.geom_xmat[g].reshape(-1, 3, 3)[:, :, 2]
    half = (model.geom_size[g, 1] if length is None else 0.5 * np.asarray(length))[:, None]
    c = data.geom_xpos[g]
    return np.stack([c - half * axis, c + half * axis], axis=1)


def _self_overlap(model: mujoco.MjModel, data: mujoco.MjData, index: RagdollIndex, tol: float) -> bool:
    """True if two capsules penetrate deeper than tol (from the contacts of the last mj_forward; only
    pairs that may collide, limbs against the rest, make contacts)."""
    if data.ncon == 0:
        return False
    geom = data.contact.geom[: data.ncon]
    ours = np.isin(geom, index.geom).all(axis=1)
    return bool(np.any(ours & (data.contact.dist[: data.ncon] < -tol)))


def settle(body, betas, pose, transl, gender: str | None = None, bed: BedSpec | None = None,
           config: SettleConfig | None = None, *, params: RagdollParams | None = None,
           wedge: bool = False) -> SettleResult:
    """Rest one body on the bed; see the module docstring for the procedure and rejection causes.

    body: a ``BodyModel``; betas (S,); pose (72,) SMPL axis-angle; transl (3,) m, z-up bed frame
    (``BodyModel.forward``'s; its height is replaced: the body starts with its lowest capsule point
    ``config.drop_clearance_m`` above the mattress); gender: mass table and mean mass (default the
    body's); bed: a ``BedSpec`` (default ``get_bed()``); config: :class:`SettleConfig`; params: a
    precomputed :class:`RagdollParams` for this body and shape (default built here); wedge: prop
    the body with a foam wedge behind its back (:func:`pressurepose.sim.wedge.wedge_behind`).
    """
    bed = get_bed() if bed is None else bed
    config = SettleConfig() if config is None else config
    betas = np.asarray(betas, dtype=np.float64)
    pose = np.asarray(pose, dtype=np.float64)
    transl = np.asarray(transl, dtype=np.float64)
    if pose.shape != (72,) or not np.all(np.isfinite(pose)):
        raise BadInput(f"pose has shape {pose.shape}; expected finite (72,) SMPL axis-angle")
    if transl.shape != (3,) or not np.all(np.isfinite(transl)):
        raise BadInput(f"transl has shape {transl.shape}; expected finite (3,) metres")
    g = body.gender if gender is None else gender
    if params is None:
        from pressurepose.body.capsules import capsules_for
        from pressurepose.body.masses import segment_masses

        caps = capsules_for(body, betas)
        masses = segment_masses(body, betas, g, caps=caps)
        params = ragdoll_params(body, betas, g, caps=caps, masses=masses, relaxed_neck=config.relaxed_neck,
                                spine_stiffness=config.spine_stiffness, limb_damping_s=config.limb_damping_s)
    if config.lateral_neck_flexion_deg > 0 and posture_class(pose) in ("left_lateral", "right_lateral"):
        params = dataclasses.replace(params, home=flexed_neck_home(params.home,
                                                                   math.radians(config.lateral_neck_flexion_deg)))
    sm = settle_model(bed, config, params, support=wedge)
    return _run(sm, params, betas, g, pose, transl)


class _BallLimits:
    """Applies :func:`limit_torques` to the limited ball joints each step, cheaply: a joint whose
    rotation angle is below the distance from 0 to the nearest face of its box cannot be outside it.

    The penalty is explicit and the joint's damping implicit, which is stable while
    ``dt * factor / damping-per-stiffness < 2``. A joint damped less than the paper's
    :data:`~pressurepose.sim.ragdoll.DAMPING_PER_STIFFNESS_S` x its stiffness (relaxed limbs) gets the
    paper's damping in ``model`` while it lies outside its box, and its own back once inside
    (:meth:`release` restores every joint)."""

    def __init__(self, params: RagdollParams, index: RagdollIndex, factor: float, model: mujoco.MjModel):
        ball = index.ball[params.limited[index.ball] & (params.stiffness[index.ball] > 0)]
        self.qpos = index.qpos[ball][:, None] + np.arange(4)
        self.dof = index.dof[ball][:, None] + np.arange(3)
        self.lower, self.upper = params.lower[ball], params.upper[ball]
        self.k = factor * params.stiffness[ball]
        inside = np.minimum(-self.lower, self.upper)
        self.safe_cos = np.cos(np.clip(inside.min(axis=1), 0.0, np.pi) / 2)  # cos(half the safe angle)
        self.active = np.zeros(len(ball), dtype=bool)
        self.model = model
        self.own_damping = params.damping[ball]
        self.limit_damping = np.maximum(self.own_damping, DAMPING_PER_STIFFNESS_S * params.stiffness[ball])
        self.raises = self.limit_damping > self.own_damping

    def _damp(self, joints: np.ndarray, damping: np.ndarray) -> None:
        joints = joints & self.raises
        if joints.any():
            self.model.dof_damping[self.dof[joints]] = damping[joints][:, None]

    def release(self) -> None:
        """Every joint back to its own damping (the model is shared between bodies)."""
        self._damp(np.ones(len(self.active), dtype=bool), self.own_damping)
        self.active[:] = False

    def apply(self, data: mujoco.MjData) -> None:
        w0 = np.abs(data.qpos[self.qpos[:, 0]])
        check = w0 < self.safe_cos  # MuJoCo keeps these quaternions unit
        if check.any():
            w = quat_to_rotvec(data.qpos[self.qpos[check]])
            r = local_to_smpl(w)
            out = np.any((r < self.lower[check]) | (r > self.upper[check]), axis=1)
            check[check] = out
            if out.any():
                data.qfrc_applied[self.dof[check]] = limit_torques(w[out], self.lower[check], self.upper[check],
                                                                   self.k[check])
        stale = self.active & ~check
        if stale.any():
            data.qfrc_applied[self.dof[stale]] = 0.0
            self._damp(stale, self.own_damping)
        self._damp(check & ~self.active, self.limit_damping)
        self.active = check


def _run(sm: SettleModel, params: RagdollParams, betas: np.ndarray, gender: str, pose: np.ndarray,
         transl: np.ndarray) -> SettleResult:
    cfg, m, d, ri = sm.config, sm.model, sm.data, sm.ragdoll
    sm.configure(params, pose, transl)
    nv = sm.nv
    radius = params.radius
    # drop: lowest capsule point at the clearance height
    mujoco.mj_kinematics(m, d)
    low = (capsule_ends(m, d, ri)[..., 2] - radius[:, None]).min()  # the contact geoms' lowest point
    d.qpos[ri.qpos[0] + 2] += cfg.drop_clearance_m - low
    mujoco.mj_forward(m, d)
    start_posture = posture_class(pose)
    kept = _posture_kept(start_posture, float(roll_angle(pose)), sm.support_geom >= 0)
    weight = params.total_mass * -m.opt.gravity[2]
    x_min, x_max, y_min, y_max = sm.cells.bounds
    limits = _BallLimits(params, ri, cfg.limit_stiffness_factor, m)
    cell_dof = sm.cell_index.dof.ravel()
    pelvis_floor = -cfg.fall_depth_m + radius[PELVIS]  # lowest allowed pelvis axis point
    dt = cfg.timestep_s
    m.opt.timestep = dt  # the model is shared: a previous body may have left it at the coarse step
    v_max2, v_rest2, a_rest2, hold_steps = _step_limits(cfg, dt)
    budget_s, used_s = cfg.max_steps * cfg.timestep_s, 0.0

    status = "not_settled"
    touch, hold, step = -1, 0, 0
    prev_ends = prev_move = None
    wedge = _place_wedge(sm, params) if sm.support_geom >= 0 else None
    if _self_overlap(m, d, ri, cfg.self_collision_tol_m):
        status = "self_collision"
    elif wedge is not None and _in_support(sm):
        status = "support_overlap"
    else:
        while used_s + 0.5 * dt <= budget_s:
            step += 1
            if (cfg.coarse_factor > 1.0 and dt == cfg.timestep_s and touch >= 0
                    and step > touch + cfg.coarse_after_steps):
                dt = m.opt.timestep = cfg.coarse_factor * cfg.timestep_s
                v_max2, v_rest2, a_rest2, hold_steps = _step_limits(cfg, dt)
                prev_ends = prev_move = None  # displacements per step change scale: measure afresh
                hold = 0
            limits.apply(d)
            mujoco.mj_step(m, d)
            used_s += dt
            ends = capsule_ends(m, d, ri)  # kinematics of the state this step started from
            if touch < 0:
                if ends[PELVIS, :, 2].min() <= radius[PELVIS] or -d.qfrc_constraint[cell_dof].sum() >= 0.5 * weight:
                    touch = step
                elif step % cfg.zero_every == 0:
                    d.qvel[:nv] = 0.0
                    prev_ends = prev_move = None
                    continue
            if not np.isfinite(d.qvel[:nv]).all() or (step % 10 == 0 and _troubled(d)):
                status = "unstable"
                break
            if step % cfg.posture_check_steps == 0:
                if not kept(float(roll_of_rotation(d.xmat[ri.body[0]].reshape(3, 3)))):
                    status = "posture_changed"
                    break
            com = d.subtree_com[ri.body[0]]
            if not (x_min <= com[0] <= x_max and y_min <= com[1] <= y_max) or ends[PELVIS, :, 2].min() < pelvis_floor:
                status = "fell_off_bed"
                break
            if prev_ends is not None:
                move = ends - prev_ends  # per step: velocity * dt
                move2 = (move * move).sum(-1).max()
                if move2 > v_max2:
                    status = "unstable"
                    break
                if prev_move is not None and touch >= 0:
                    dv = move - prev_move  # acceleration * dt^2
                    at_rest = move2 < v_rest2 and (dv * dv).sum(-1).max() < a_rest2
                    hold = hold + 1 if at_rest else 0
                    if hold >= hold_steps:
                        status = "settled"
                        break
                prev_move = move
            prev_ends = ends
    m.opt.timestep = cfg.timestep_s
    limits.release()
    if status in ("settled", "not_settled") and _troubled(d):
        status = "unstable"
    mujoco.mj_forward(m, d)  # positions, contacts and forces of the final state
    out_pose, out_transl = qpos_to_pose(m, ri, params, d.qpos, pose)
    posture = posture_class(out_pose) if np.all(np.isfinite(out_pose)) else "unknown"
    if status == "settled" and (posture == "unknown" or not kept(float(roll_angle(out_pose)))):
        status = "posture_changed"
    points, force_z = _support_forces(sm, wedge) if wedge is not None else (np.zeros((0, 3)), np.zeros(0))
    return SettleResult(status=status, pose=out_pose, transl=out_transl, betas=betas.copy(), gender=str(gender),
                        steps=step, touch_step=touch, capsules=capsule_ends(m, d, ri, params.length),
                        radius=radius.copy(),
                        posture_start=start_posture, posture=posture, mass_kg=params.total_mass,
                        bed_force_n=float(cell_forces(d, sm.cell_index).sum()),
                        max_sink_m=float(-cell_sink(d, sm.cell_index).min()),
                        wedge=wedge, wedge_points=points, wedge_force_z=force_z)


def _step_limits(cfg: SettleConfig, dt: float) -> tuple[float, float, float, int]:
    """The settle's speed limits per step of ``dt`` s, squared (m^2: blow-up, rest speed, rest
    acceleration times dt^2) and how many steps the resting criterion must hold (``cfg``'s hold in
    seconds)."""
    hold = cfg.rest_hold_steps if dt == cfg.timestep_s else max(1, round(cfg.rest_hold_steps * cfg.timestep_s / dt))
    return (cfg.max_speed_m_s * dt) ** 2, (cfg.rest_speed_m_s * dt) ** 2, (cfg.rest_accel_m_s2 * dt**2) ** 2, hold


def _posture_kept(start: str, start_roll: float, wedge: bool):
    """The test a body's roll (rad) must pass while it settles: in its start posture class; with a
    wedge, rolled 5-100 degrees to the side it started on (a body propped near 45 degrees may
    rest in either class on that side; rolling off the wedge onto the back or the front fails)."""
    if not wedge:
        return lambda roll: POSTURES[int(posture_index(roll))] == start
    side = 1.0 if start_roll >= 0 else -1.0
    return lambda roll: math.radians(5.0) <= side * roll <= math.radians(100.0)


def _place_wedge(sm: SettleModel, params: RagdollParams):
    """Put the support box where the wedge for the body as it starts goes; returns the Wedge."""
    from pressurepose.sim.wedge import wedge_behind

    m, d, ri, g = sm.model, sm.data, sm.ragdoll, sm.support_geom
    wedge = wedge_behind(capsule_ends(m, d, ri), params.radius, d.xmat[ri.body[0]].reshape(3, 3))
    half, centre, rot = wedge.box()
    m.geom_size[g] = half
    m.geom_rbound[g] = float(np.linalg.norm(half))
    m.geom_aabb[g] = np.concatenate([np.zeros(3), half])
    d.mocap_pos[sm.support_mocap] = centre
    d.mocap_quat[sm.support_mocap] = rotation_to_quat(rot)
    mujoco.mj_forward(m, d)
    return wedge


def _in_support(sm: SettleModel) -> bool:
    """True if a capsule starts deeper than SUPPORT_OVERLAP_M inside the wedge (last mj_forward)."""
    n = sm.data.ncon
    geom, dist = sm.data.contact.geom[:n], sm.data.contact.dist[:n]
    return bool(np.any((geom == sm.support_geom).any(axis=1) & (dist < -SUPPORT_OVERLAP_M)))


def _support_forces(sm: SettleModel, wedge) -> tuple[np.ndarray, np.ndarray]:
    """(K, 3) contact points of the body on the wedge and (K,) the vertical force (N, >= 0) with
    which the body presses the wedge down at each (last mj_forward). Contacts that carry no normal
    force (MuJoCo lists geoms closer than their margin) are left out: the body does not lean there."""
    m, d = sm.model, sm.data
    f6 = np.zeros(6)
    pts, fz = [], []
    n = wedge.normal
    for i in np.nonzero((d.contact.geom[: d.ncon] == sm.support_geom).any(axis=1))[0]:
        mujoco.mj_contactForce(m, d, int(i), f6)
        if f6[0] <= 0.0:
            continue
        f = d.contact.frame[i].reshape(3, 3).T @ f6[:3]
        if f @ n < 0:
            f = -f  # the force on the body, which the face pushes outward
        pts.append(d.contact.pos[i].copy())
        fz.append(max(0.0, float(f[2])))
    return np.array(pts).reshape(-1, 3), np.array(fz)


def _troubled(data: mujoco.MjData) -> bool:
    """A MuJoCo warning (bad accelerations, full contact buffers) or a non-finite state."""
    return any(data.warning[w].number > 0 for w in _WARNINGS) or not np.isfinite(data.qpos).all()
