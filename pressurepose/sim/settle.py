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

* ``not_settled``: does not rest within its step budget (``max_steps`` steps of ``timestep_s``, 20 s of
  simulated time by default, whatever the coarse step);
* ``unstable``: produces non-finite numbers, a MuJoCo warning or a capsule faster than 5 m/s;
* ``fell_off_bed``: its centre of mass leaves the mattress outline, or its pelvis drops more than
  ``fall_depth_m`` below the mattress top;
* ``limb_off_bed``: (only when asked, ``hang_depth_m``) hangs a limb over the mattress's edge: a
  limb joint (:data:`pressurepose.sim.settle_config.LIMB_JOINTS`) beyond the outline and more than
  ``hang_depth_m`` below its top, checked with the posture. The caller's test of the resting body
  (:func:`pressurepose.sim.simulate.limb_off_bed`) names the same cause; a hanging limb does not
  come back (over the partitions with such rejections, every attempt that met the test at a check
  still met it at rest, or was rejected for another cause first), so the attempt stops where
  the limb first hangs, after 0.4-0.9 of the steps that settling it to rest takes;
* ``posture_changed``: leaves the posture class (supine / left or right lateral / prone) it started
  in while settling (checked every ``posture_check_steps`` steps, so a body rolling over stops
  early instead of running on until it rests or falls off), or rests in another class (with a
  wedge: leaves 5-100 degrees of roll on the side it started on);
* ``self_collision``: starts with capsules of its limbs more than ``self_collision_tol_m`` inside other
  capsules (:func:`pressurepose.body.contact.start_overlap`, which the sampler applies too);
* ``support_overlap``: (with a wedge) starts with a capsule more than 1 cm inside the wedge (a
  limb behind the back where the wedge goes).

With ``wedge=True`` a foam wedge props the body (:mod:`pressurepose.sim.wedge`): a rigid box
placed against the trunk's back where the body starts, touching the body only; the result holds
the wedge and the forces the body leans on it with.

Model choices measured here (``benchmarks/bench_settle.py``, docs/RESULTS.md): elliptic friction cones
(with pyramidal ones a supine body crept 1-2 cm sideways and resting limbs chattered, taking 2-3x the
steps); cells of 2 x 2 taxels (3-4x faster than one per taxel, the cost being mostly contacts and
cells); collisions only between the body and the cells, and between limb capsules and the rest of
the body. Speed: one compiled model per (bed, config, wedge or not) serves every body
(:class:`~pressurepose.sim.settle_model.SettleModel`), so nothing is compiled per sample.

The settings are :class:`~pressurepose.sim.settle_config.SettleConfig`; the model is built in
:mod:`pressurepose.sim.settle_model`, its cells' stiffness fitted in
:mod:`pressurepose.sim.settle_stiffness`.

Frames: inputs and outputs are SMPL parameters (pose in SMPL's own axis-angle, translation in the
z-up bed frame, as ``BodyModel.forward``); the resting pose is exact for the mesh:
``posed_capsules(body, caps, betas, result.pose, result.transl)`` gives the ragdoll's capsules.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field, replace

import mujoco
import numpy as np

from pressurepose.body.capsules import CAPSULE_JOINTS, CAPSULE_NAMES, capsules_for
from pressurepose.body.contact import start_overlap
from pressurepose.body.joints import PARENTS
from pressurepose.body.lbs_numpy import Y_UP_TO_Z_UP, shaped_rest
from pressurepose.body.masses import segment_masses
from pressurepose.errors import BadInput
from pressurepose.pose.posture import (
    POSTURES,
    posture_class,
    posture_index,
    roll_angle,
    roll_of_rotation,
)
from pressurepose.sim.bed import BedSpec, get_bed
from pressurepose.sim.cellbed import cell_forces, cell_sink
from pressurepose.sim.ragdoll import (
    BallLimits,
    RagdollIndex,
    RagdollParams,
    qpos_to_pose,
    ragdoll_params,
    rotation_to_quat,
)
from pressurepose.sim.settle_config import LIMB_JOINTS, SettleConfig, hanging
from pressurepose.sim.settle_model import SettleModel, capsule_ends
from pressurepose.sim.settle_stiffness import settle_stiffness
from pressurepose.sim.wedge import Wedge, wedge_behind

STATUSES = ("settled", "not_settled", "unstable", "fell_off_bed", "posture_changed", "self_collision",
            "support_overlap", "limb_off_bed")
SUPPORT_OVERLAP_M = 0.01  # a capsule this deep in the wedge where the body starts: rejected
PELVIS = CAPSULE_NAMES.index("pelvis")
_WARNINGS = (mujoco.mjtWarning.mjWARN_BADQACC, mujoco.mjtWarning.mjWARN_BADQPOS, mujoco.mjtWarning.mjWARN_BADQVEL,
             mujoco.mjtWarning.mjWARN_CONTACTFULL, mujoco.mjtWarning.mjWARN_CNSTRFULL)


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
    wedge: Wedge | None = None
    wedge_points: np.ndarray = field(default_factory=lambda: np.zeros((0, 3)))
    wedge_force_z: np.ndarray = field(default_factory=lambda: np.zeros(0))

    @property
    def ok(self) -> bool:
        return self.status == "settled"


_MODELS: dict = {}


def cached_model(bed: BedSpec, config: SettleConfig, params: RagdollParams, support: bool = False) -> SettleModel:
    """The :class:`~pressurepose.sim.settle_model.SettleModel` for (bed, config, support), compiled
    with ``params`` the first time, its cells' stiffness the config's or else
    :func:`~pressurepose.sim.settle_stiffness.settle_stiffness`'s. One per process: it holds one
    ``MjData``, so threads must not settle concurrently."""
    key = (bed, config, bool(support))
    if key not in _MODELS:
        k = config.stiffness_n_m3
        _MODELS[key] = SettleModel(bed, config, params, settle_stiffness(bed, config) if k is None else k,
                                   bool(support))
    return _MODELS[key]


def settle(body, betas, pose, transl, gender: str | None = None, bed: BedSpec | None = None,
           config: SettleConfig | None = None, *, params: RagdollParams | None = None,
           wedge: bool = False, hang_depth_m: float | None = None,
           spring_pose: np.ndarray | None = None) -> SettleResult:
    """Rest one body on the bed; see the module docstring for the procedure and rejection causes.

    body: a ``BodyModel``; betas (S,); pose (72,) SMPL axis-angle; transl (3,) m, z-up bed frame
    (``BodyModel.forward``'s; its height is replaced: the body starts with its lowest capsule point
    ``config.drop_clearance_m`` above the mattress); gender: mass table and mean mass (default the
    body's); bed: a ``BedSpec`` (default ``get_bed()``); config: :class:`SettleConfig`; params: a
    precomputed :class:`RagdollParams` for this body and shape (default built here); wedge: prop
    the body with a foam wedge behind its back (:func:`pressurepose.sim.wedge.wedge_behind`);
    hang_depth_m: m, stop as ``limb_off_bed`` when a limb joint lies beyond the mattress's outline
    and more than this below its top (None: limbs may hang); spring_pose: (72,) SMPL axis-angle the
    joint springs rest at (None: the paper's home pose, :func:`~pressurepose.sim.ragdoll.home_pose`;
    :func:`~pressurepose.sim.simulate.simulate_one` gives the drawn pose of a body posed from real
    lying poses, docs/physics.md "Springs of real poses").
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
    if hang_depth_m is not None and (isinstance(hang_depth_m, bool) or not isinstance(hang_depth_m, (int, float, np.floating))
                                     or not np.isfinite(hang_depth_m) or hang_depth_m < 0):
        raise BadInput(f"hang_depth_m is {hang_depth_m!r}; expected None (limbs may hang) or a finite number of "
                       f"metres >= 0")
    if spring_pose is not None:
        spring_pose = np.asarray(spring_pose, dtype=np.float64)
        if spring_pose.shape != (72,) or not np.all(np.isfinite(spring_pose)):
            raise BadInput(f"spring_pose has shape {spring_pose.shape}; expected finite (72,) SMPL axis-angle, "
                           f"or None for the home pose")
    g = body.gender if gender is None else gender
    if params is None:
        caps = capsules_for(body, betas)
        masses = segment_masses(body, betas, g, caps=caps)
        params = ragdoll_params(body, betas, g, caps=caps, masses=masses, relaxed_neck=config.relaxed_neck,
                                spine_stiffness=config.spine_stiffness)
    if spring_pose is not None:
        params = replace(params, home=spring_pose.reshape(-1, 3)[list(CAPSULE_JOINTS)])
    sm = cached_model(bed, config, params, support=wedge)
    hang = None if hang_depth_m is None else _HangTest(body, betas, bed, float(hang_depth_m), sm.ragdoll)
    return _run(sm, params, betas, g, pose, transl, hang)


class _Ends:
    """The capsules' axis-segment ends of the current state, (20, 2, 3) m, as :func:`capsule_ends`
    gives them but in the model's geom order (``pelvis``: the pelvis capsule's row), from views of
    MuJoCo's arrays taken once, into two buffers used in turn (a call's ends stay valid through the
    next call)."""

    def __init__(self, model: mujoco.MjModel, data: mujoco.MjData, index: RagdollIndex):
        lo = int(index.geom.min())
        hi = lo + len(index.geom)
        if not np.array_equal(np.sort(index.geom), np.arange(lo, hi)):
            raise RuntimeError("the ragdoll's geoms must be numbered consecutively")
        self.pelvis = int(index.geom[PELVIS]) - lo
        self._centre = data.geom_xpos[lo:hi]
        self._axis = data.geom_xmat[lo:hi, 2::3]  # the capsules' local z in the world
        self._half = model.geom_size[lo:hi, 1:2].copy()  # (20, 1) m
        self._buf = np.empty((2, hi - lo, 2, 3))
        self._t = np.empty((hi - lo, 3))
        self._i = 0

    def __call__(self) -> np.ndarray:
        self._i ^= 1
        ends = self._buf[self._i]
        t = np.multiply(self._half, self._axis, out=self._t)
        np.subtract(self._centre, t, out=ends[:, 0])
        np.add(self._centre, t, out=ends[:, 1])
        return ends


class _HangTest:
    """Whether a limb hangs over the mattress's edge, from the ragdoll's bodies: the limb joints with a
    capsule (knees, ankles, elbows, wrists) are their bodies' origins; the feet and hands (SMPL's
    foot and hand joints, no capsule of their own) their rest offsets from the ankle and wrist,
    turned with those bodies. The same joints as ``BodyModel.forward`` gives for the ragdoll's pose."""

    def __init__(self, body, betas: np.ndarray, bed: BedSpec, depth_m: float, index: RagdollIndex):
        _, rest = shaped_rest(body.arrays, np.asarray(betas)[None])
        rest = rest[0] @ Y_UP_TO_Z_UP.T  # (24, 3) z-up
        own = [j for j in LIMB_JOINTS if j in CAPSULE_JOINTS]
        tips = [j for j in LIMB_JOINTS if j not in CAPSULE_JOINTS]
        self.own = index.body[[CAPSULE_JOINTS.index(j) for j in own]]
        self.tip_parent = index.body[[CAPSULE_JOINTS.index(PARENTS[j]) for j in tips]]
        self.tip_offset = np.stack([rest[j] - rest[PARENTS[j]] for j in tips])  # (T, 3)
        self.bounds, self.depth = bed.mattress_bounds, depth_m

    def __call__(self, data: mujoco.MjData) -> bool:
        rot = data.xmat[self.tip_parent].reshape(-1, 3, 3)
        p = np.concatenate([data.xpos[self.own], data.xpos[self.tip_parent] + (rot @ self.tip_offset[..., None])[..., 0]])
        return hanging(p, self.bounds, self.depth)


def _run(sm: SettleModel, params: RagdollParams, betas: np.ndarray, gender: str, pose: np.ndarray,
         transl: np.ndarray, hang: _HangTest | None = None) -> SettleResult:
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
    limits = BallLimits(params, ri, cfg.limit_stiffness_factor)
    cell_dof = sm.cell_index.dof.ravel()
    # views of MuJoCo's arrays, taken once: the loop reads them in place every step
    qpos, qvel, qfrc_applied, qfrc_constraint = d.qpos, d.qvel[:nv], d.qfrc_applied, d.qfrc_constraint
    com = d.subtree_com[ri.body[0]]
    root_xmat = d.xmat[ri.body[0]].reshape(3, 3)
    capsules = _Ends(m, d, ri)
    pelvis = capsules.pelvis
    pelvis_floor = -cfg.fall_depth_m + radius[PELVIS]  # lowest allowed pelvis axis point
    dt = cfg.timestep_s
    m.opt.timestep = dt  # the model is shared: a previous body may have left it at the coarse step
    v_max2, v_rest2, a_rest2, hold_steps = _step_limits(cfg, dt)
    budget_s, used_s = cfg.max_steps * cfg.timestep_s, 0.0

    status = "not_settled"
    touch, hold, step = -1, 0, 0
    prev_ends = prev_move = None
    wedge = _place_wedge(sm, params) if sm.support_geom >= 0 else None
    if cfg.self_collision and start_overlap(capsule_ends(m, d, ri), m.geom_size[ri.geom, 0], cfg.self_collision_tol_m):
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
            limits.apply(qpos, qfrc_applied)
            mujoco.mj_step(m, d)
            used_s += dt
            ends = capsules()  # kinematics of the state this step started from
            pelvis_z = ends[pelvis, :, 2].min()
            if touch < 0:
                if pelvis_z <= radius[PELVIS] or -qfrc_constraint[cell_dof].sum() >= 0.5 * weight:
                    touch = step
                elif step % cfg.zero_every == 0:
                    qvel[:] = 0.0
                    prev_ends = prev_move = None
                    continue
            if not np.isfinite(qvel).all() or (step % 10 == 0 and _troubled(d)):
                status = "unstable"
                break
            if step % cfg.posture_check_steps == 0:
                if not kept(float(roll_of_rotation(root_xmat))):
                    status = "posture_changed"
                    break
                if hang is not None and hang(d):
                    status = "limb_off_bed"
                    break
            if not (x_min <= com[0] <= x_max and y_min <= com[1] <= y_max) or pelvis_z < pelvis_floor:
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


def _place_wedge(sm: SettleModel, params: RagdollParams) -> Wedge:
    """Put the support box where the wedge for the body as it starts goes; returns the Wedge."""
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


def _support_forces(sm: SettleModel, wedge: Wedge) -> tuple[np.ndarray, np.ndarray]:
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
