"""Shared cases for the press tests, and the ball-joint limit torques joint by joint for the ragdoll
and settle tests."""

from types import SimpleNamespace

import numpy as np
import pytest
import scipy.sparse as sp
import scipy.sparse.linalg as spl
import trimesh

from pressurepose.sim import GRAVITY, get_bed
from pressurepose.sim import ragdoll as rd
from pressurepose.sim.foundation import (
    PasternakFoundation,
    rigid_jacobian,
    solve_pasternak,
    solve_winkler,
)
from pressurepose.sim.press import body_heightfield, press_grid


def _laplacian_1d(n: int):
    main = np.full(n, 2.0)
    main[[0, -1]] = 1.0
    return sp.diags([-np.ones(n - 1), main, -np.ones(n - 1)], [-1, 0, 1])


@pytest.fixture
def pasternak_patch():
    """Solve a tilted 12 kg capsule on a Pasternak bed (k_A 5e4 N/m^3, G 80 N/m) with CG, and the
    same patch's sheet directly: ``case(compliance=None, tol=1e-9)`` returns the solution, the gap
    w + c lam + b + J q per contact cell (w from a sparse direct solve of K w = lam), the direct
    stiffness matrix K and the pieces the checks need. ``compliance``: (n,) or a function of the
    number of cells n and the bed's cell stiffness, giving m/N per cell (tissue in series)."""

    def case(compliance=None, tol=1e-9):
        k_a, g_shear, mass = 5e4, 80.0, 12.0
        bed = get_bed(stiffness_n_m3=k_a, coupling_n_m=g_shear)
        grid = press_grid(bed)
        cap = trimesh.creation.capsule(height=0.25, radius=0.07, count=[24, 24])
        cap.apply_transform(trimesh.transformations.rotation_matrix(np.pi / 2, [1, 0.3, 0]))
        cap.apply_translation([0.35, 0.8, 0.06])
        hf = body_heightfield(cap.vertices, cap.faces, bed)
        under = np.isfinite(hf.bottom)
        jj, ii = np.nonzero(under)
        j0, i0 = jj.min() - 15, ii.min() - 15
        shape = (jj.max() + 16 - j0, ii.max() + 16 - i0)
        xs, ys = grid.centers()
        jac = rigid_jacobian(xs[ii], ys[jj], hf.com[:2])
        dx, dy = grid.cell_xy
        k_cell = k_a * dx * dy
        weight = mass * GRAVITY
        comp = None if compliance is None else (compliance(len(jj), k_cell) if callable(compliance) else compliance)
        k_winkler = k_cell if comp is None else 1 / (1 / k_cell + comp)
        lam0 = solve_winkler(hf.bottom[under], jac, k_winkler, weight).lam
        found = PasternakFoundation(shape, grid.cell_xy, k_a, g_shear)
        flat = (jj - j0) * shape[1] + (ii - i0)
        extra = {} if comp is None else {"compliance": comp}
        sol = solve_pasternak(hf.bottom[under], jac, flat, found, weight, lam0, tol=tol, **extra)
        ny, nx = shape
        stiff = (k_cell * sp.eye(nx * ny) + g_shear * dy / dx * sp.kron(sp.eye(ny), _laplacian_1d(nx))
                 + g_shear * dx / dy * sp.kron(_laplacian_1d(ny), sp.eye(nx))).tocsc()
        lam = np.zeros(nx * ny)
        lam[flat] = sol.lam
        w = spl.spsolve(stiff, lam)
        gap = w[flat] + (0.0 if comp is None else comp * sol.lam) + hf.bottom[under] + jac @ sol.q
        return SimpleNamespace(sol=sol, gap=gap, on=sol.lam > 0, under=under, jac=jac, weight=weight,
                               found=found, flat=flat, stiff=stiff)

    return case


class PerJointLimits:
    """The ball-joint limit torques as the settle applied them joint by joint: for each limited ball
    joint with a stiffness, its quaternion to a rotation vector, each SMPL axis tested against its
    limits, and :func:`~pressurepose.sim.ragdoll.limit_torques` when one is outside; no torque
    otherwise. The same interface as :class:`~pressurepose.sim.ragdoll.BallLimits`."""

    def __init__(self, params, index, factor):
        self.joints = [k for k in index.ball if params.limited[k] and params.stiffness[k] > 0]
        self.qpos = {k: int(index.qpos[k]) for k in self.joints}
        self.dof = {k: int(index.dof[k]) for k in self.joints}
        self.lower, self.upper = params.lower, params.upper
        self.k = {k: factor * params.stiffness[k] for k in self.joints}

    def apply(self, qpos, qfrc_applied):
        for k in self.joints:
            w = rd.quat_to_rotvec(qpos[self.qpos[k]: self.qpos[k] + 4])
            r = rd.local_to_smpl(w)
            outside = any(r[a] < self.lower[k, a] or r[a] > self.upper[k, a] for a in range(3))
            tau = rd.limit_torques(w[None], self.lower[k][None], self.upper[k][None],
                                   np.array([self.k[k]]))[0] if outside else 0.0
            qfrc_applied[self.dof[k]: self.dof[k] + 3] = tau


@pytest.fixture
def per_joint_limits():
    """:class:`PerJointLimits`."""
    return PerJointLimits
