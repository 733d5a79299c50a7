"""The settle's MuJoCo model: the capsule ragdoll (:mod:`pressurepose.sim.ragdoll`) on the cell bed
(:mod:`pressurepose.sim.cellbed`), and with a wedge a box to lean on.

* :func:`settle_cells`: the cell bed a :class:`~pressurepose.sim.settle_config.SettleConfig` settles
  bodies on.
* :func:`build_spec`: the model as an ``MjSpec``: solver, integrator and friction cones of the config.
* :class:`SettleModel`: one compiled model and its ``MjData``, reused for every body on one bed and
  config: per body only the shape-dependent numbers are rewritten
  (:func:`pressurepose.sim.ragdoll.write_params`) and MuJoCo's derived constants recomputed, so
  nothing is compiled per sample.
* :func:`capsule_ends`: where the ragdoll's capsules are in a state of the model.
"""

from __future__ import annotations

import mujoco
import numpy as np

from pressurepose.sim.bed import BedSpec
from pressurepose.sim.cellbed import CellBed, CellIndex, add_cells, cell_bed
from pressurepose.sim.ragdoll import (
    BED_BIT,
    RagdollIndex,
    RagdollParams,
    add_ragdoll,
    pose_to_qpos,
    write_params,
)
from pressurepose.sim.settle_config import SettleConfig


def settle_cells(bed: BedSpec, config: SettleConfig, stiffness_n_m3: float | None = None) -> CellBed:
    """The cell bed ``config`` settles bodies on (``stiffness_n_m3`` overrides the config's)."""
    return cell_bed(bed, config.cell_m, taxels_per_cell=config.taxels_per_cell, coupling=config.coupling,
                    stiffness_n_m3=config.stiffness_n_m3 if stiffness_n_m3 is None else stiffness_n_m3,
                    timestep_s=config.timestep_s)


def build_spec(params: RagdollParams, cells: CellBed, config: SettleConfig, support: bool = False) -> mujoco.MjSpec:
    """The settle model as an MjSpec: the ragdoll first, then the cell bed, then with ``support`` a
    mocap body "support" holding a box (the wedge, sized and placed per body, colliding with the
    body only); implicitfast integrator, Newton solver, elliptic friction cones (:mod:`pressurepose.sim.settle`
    says why)."""
    spec = mujoco.MjSpec()
    spec.modelname = "settle"
    spec.compiler.degree = False
    o = spec.option
    o.timestep = config.timestep_s
    o.integrator = mujoco.mjtIntegrator.mjINT_IMPLICITFAST
    o.solver = mujoco.mjtSolver.mjSOL_NEWTON
    o.cone = mujoco.mjtCone.mjCONE_ELLIPTIC
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


class SettleModel:
    """One compiled MuJoCo model (ragdoll + cell bed, and with ``support`` a wedge, placed per body)
    reused for every body on one bed and config.

    The first body compiles it (``params``); later bodies rewrite the shape-dependent numbers in
    place (:meth:`configure`). ``stiffness_n_m3``: the cells' foundation modulus (N/m^3), resolved
    by the caller (the config's, or :func:`pressurepose.sim.settle_stiffness.settle_stiffness`).
    Attributes: ``model``, ``data``, ``cells``, ``ragdoll`` (a :class:`RagdollIndex`),
    ``cell_index``, ``stiffness_n_m3``, ``support_geom`` and ``support_mocap`` (-1 without a wedge).
    """

    def __init__(self, bed: BedSpec, config: SettleConfig, params: RagdollParams, stiffness_n_m3: float,
                 support: bool = False):
        self.bed, self.config = bed, config
        self.stiffness_n_m3 = float(stiffness_n_m3)
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
