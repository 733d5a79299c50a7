"""Quasi-static contact of a rigid body with an elastic (Winkler or Pasternak) foundation.

The body's lower surface is a height field ``b0`` (m) over a grid of cells; the body may move
rigidly by ``q = (h, sx, sy)``: its bottom becomes ``b = b0 + J q`` with ``J_i = (1, x_i - xc,
y_i - yc)`` (a vertical shift and a small tilt about the centre of mass (xc, yc)). The foundation
deflects by ``w`` (m, down positive) and pushes on cell i with force ``lam_i`` (N). Equilibrium is
the minimum of the total potential energy ``1/2 w'Kw + W h`` subject to ``w_i + b_i >= 0`` (the
sheet cannot rise through the body), ``K = kc I + G L`` (Winkler springs ``kc = k_A dx dy`` per
cell and Pasternak shear springs between neighbours). Its conditions are exactly the physics asked
for: ``K w = lam >= 0``, contact only where the gap ``w + b`` is 0, total force ``sum lam = W``
and zero moment about the centre of mass.

* Winkler (G = 0): ``lam = kc max(0, -b)``, and the problem is a convex one in the 3 unknowns q,
  solved by Newton's method (:func:`solve_winkler`).
* Pasternak (G > 0): the dual problem in ``lam`` (flexibility ``K^-1`` applied with a cosine
  transform, which diagonalises K with free edges) is solved by a conjugate-gradient active-set
  method in the manner of Polonsky and Keer (1999, Wear 231:206), generalised from one load
  constraint to the load and two moments (:func:`solve_pasternak`).
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import TYPE_CHECKING

import numpy as np

# scipy.fft and scipy.sparse are imported by the Pasternak methods that use them: every module of
# pressurepose.sim loads this one (PressFailed), and scipy.fft alone is about 0.25 s of start-up
if TYPE_CHECKING:
    import scipy.sparse


class PressFailed(RuntimeError):
    """The body has no static equilibrium on the bed (e.g. it is off the mattress, or its centre
    of mass is outside its support so it would tip over)."""


@dataclass(frozen=True)
class ContactSolution:
    """lam (n,) cell forces in N; q = (h, sx, sy) rigid shift (m) and slopes; iterations used."""

    lam: np.ndarray
    q: np.ndarray
    iterations: int


def rigid_jacobian(x: np.ndarray, y: np.ndarray, com_xy) -> np.ndarray:
    """(n, 3) rows (1, x - xc, y - yc): how a cell's height changes with (h, sx, sy)."""
    return np.stack([np.ones_like(x), x - com_xy[0], y - com_xy[1]], axis=1)


def level_sink(b0: np.ndarray, k_cell, weight_n: float) -> float:
    """The shift s (m) down at which cells with bottoms ``b0`` (n,) on independent springs
    ``k_cell`` (N/m, a number or (n,)) carry ``weight_n`` without turning:
    ``sum k max(0, s - b0) = W``, exactly."""
    # the force is piecewise linear in s: when s equals order[m] it is K_m s - sum_{i<m} k_i order[i]
    idx = np.argsort(b0)
    order = b0[idx]
    k = np.broadcast_to(np.asarray(k_cell, dtype=np.float64), b0.shape)[idx]
    ksum, kbsum = np.cumsum(k), np.cumsum(k * order)
    f_at = ksum[:-1] * order[1:] - kbsum[:-1]
    m = int(np.searchsorted(f_at, weight_n)) + 1  # number of cells in contact at the answer
    return float((weight_n + kbsum[m - 1]) / ksum[m - 1])


def solve_winkler(b0: np.ndarray, jac: np.ndarray, k_cell, weight_n: float,
                  max_slope: float = 0.3, max_iter: int = 100) -> ContactSolution:
    """Rigid body on independent springs ``k_cell`` (N/m, a number or one per cell (n,)) under
    cells with bottoms ``b0`` (n,).

    Newton's method on the convex, piecewise-quadratic energy in q; exact to round-off.
    """
    q = np.array([-level_sink(b0, k_cell, weight_n), 0.0, 0.0])
    target = np.array([weight_n, 0.0, 0.0])

    k_cell = np.broadcast_to(np.asarray(k_cell, dtype=np.float64), b0.shape)

    def energy(qq):
        d = np.maximum(-(b0 + jac @ qq), 0.0)
        return 0.5 * (k_cell * d) @ d + weight_n * qq[0]

    scale = np.array([weight_n, weight_n, weight_n])  # N, N m (lever arms are ~1 m)
    for it in range(max_iter):
        d = np.maximum(-(b0 + jac @ q), 0.0)
        lam = k_cell * d
        grad = target - jac.T @ lam
        on = d > 0
        hess = (k_cell[on, None] * jac[on]).T @ jac[on]
        hess += 1e-12 * np.trace(hess) * np.eye(3)
        step = -np.linalg.solve(hess, grad)
        # converged: balanced to 1e-10 of the weight, or moving no cell by 1 nm (round-off)
        if np.all(np.abs(grad) <= 1e-10 * scale) or np.abs(jac[on] @ step).max() < 1e-9:
            if np.any(np.abs(q[1:]) > max_slope):
                raise PressFailed(f"no equilibrium: the body tips over (slope {q[1]:.2f}, {q[2]:.2f}); "
                                  f"its centre of mass is outside the area it rests on")
            return ContactSolution(lam, q, it)
        e0, t = energy(q), 1.0
        if not np.array_equal(b0 + jac @ (q + step) < 0, on):  # the energy is quadratic while contact holds
            while energy(q + t * step) > e0 + 1e-4 * t * grad @ step and t > 1e-8:
                t *= 0.5
        q = q + t * step
        if np.any(np.abs(q[1:]) > 10 * max_slope):  # Newton is heading for a tip-over
            raise PressFailed(f"no equilibrium: the body tips over (slope {q[1]:.2f}, {q[2]:.2f}); "
                              f"its centre of mass is outside the area it rests on")
    raise PressFailed(f"Winkler contact did not converge in {max_iter} Newton steps")


class PasternakFoundation:
    """A rectangular patch of (ny, nx) cells of size dx x dy of a Pasternak foundation, free edges.

    Stiffness ``K = k_A dx dy I + G (dy/dx) Lx + G (dx/dy) Ly`` (L: 1-D Laplacians with free ends).
    :meth:`stiffness_matrix` gives K on a set of cells (sparse, 5-point); :meth:`flexibility` applies
    ``K^-1`` to the whole patch, which is diagonal in the type-II cosine basis (two FFT-sized
    transforms).
    """

    def __init__(self, shape: tuple[int, int], cell_xy: tuple[float, float], k_a: float, g: float):
        ny, nx = shape
        dx, dy = cell_xy
        self.shape = shape
        self.k_cell = k_a * dx * dy
        self.gx = g * dy / dx
        self.gy = g * dx / dy
        ex = 2.0 - 2.0 * np.cos(np.pi * np.arange(nx) / nx)
        ey = 2.0 - 2.0 * np.cos(np.pi * np.arange(ny) / ny)
        self.eig = self.k_cell + self.gx * ex[None, :] + self.gy * ey[:, None]

    def flexibility(self, lam_grid: np.ndarray) -> np.ndarray:
        """Deflections (m) under cell forces (N), both (..., ny, nx)."""
        import scipy.fft

        axes = (-2, -1)
        c = scipy.fft.dctn(lam_grid, type=2, norm="ortho", axes=axes, workers=1)
        return scipy.fft.idctn(c / self.eig, type=2, norm="ortho", axes=axes, workers=1)

    def stiffness_matrix(self, flat_index: np.ndarray) -> scipy.sparse.csr_matrix:
        """K restricted to the cells ``flat_index`` of the flattened patch (n x n, sparse): the forces
        on those cells for deflections that are zero elsewhere."""
        import scipy.sparse

        ny, nx = self.shape
        n = len(flat_index)
        where = np.full(ny * nx, -1)
        where[flat_index] = np.arange(n)
        j, i = np.divmod(flat_index, nx)
        diag = np.full(n, self.k_cell)
        rows, cols, vals = [], [], []
        for dj, di, g in ((0, 1, self.gx), (0, -1, self.gx), (1, 0, self.gy), (-1, 0, self.gy)):
            jn, inb = j + dj, i + di
            inside = (jn >= 0) & (jn < ny) & (inb >= 0) & (inb < nx)
            diag[inside] += g  # a spring to every neighbour on the patch (free edges have none)
            other = np.full(n, -1)
            other[inside] = where[jn[inside] * nx + inb[inside]]
            both = other >= 0
            rows.append(np.nonzero(both)[0])
            cols.append(other[both])
            vals.append(np.full(both.sum(), -g))
        rows.append(np.arange(n))
        cols.append(np.arange(n))
        vals.append(diag)
        return scipy.sparse.csr_matrix((np.concatenate(vals), (np.concatenate(rows), np.concatenate(cols))),
                                       shape=(n, n))


def solve_pasternak(b0: np.ndarray, jac: np.ndarray, flat_index: np.ndarray,
                    found: PasternakFoundation, weight_n: float, lam0: np.ndarray,
                    tol: float = 1e-7, max_iter: int = 1000, max_slope: float = 0.3,
                    compliance: np.ndarray | None = None) -> ContactSolution:
    """Rigid body on a Pasternak foundation, by preconditioned conjugate gradients over the forces.

    b0 (n,) bottoms of the candidate cells, jac (n, 3) their rigid Jacobian rows, flat_index (n,)
    their positions in the flattened ``found.shape`` patch, lam0 (n,) a starting guess (e.g. the
    Winkler answer). The dual energy ``1/2 lam' K^-1 lam + lam' b0`` is minimised over lam >= 0
    with the load and both moments fixed; on the cells in contact, K itself (restricted to them and
    projected onto the balanced directions) preconditions the CG steps, which leaves only the
    contact edge to iterate on. Stops when the forces change by less than ``tol * W`` in a step.

    ``compliance`` (n,) m/N: a spring in series between the body and each cell (soft tissue), so
    the flexibility becomes ``K^-1 + diag(compliance)``; the preconditioner is then
    ``S K S`` with ``S = diag(1 / sqrt(1 + k_cell c))``, exact for a Winkler foundation.
    """
    size = found.shape[0] * found.shape[1]
    comp = np.zeros(len(b0)) if compliance is None else np.asarray(compliance, dtype=np.float64)
    scale = 1.0 / np.sqrt(1.0 + found.k_cell * comp)
    k_eff = found.k_cell / (1.0 + found.k_cell * comp)
    target = np.array([weight_n, 0.0, 0.0])

    def on_grid(v):  # (..., n) -> (..., ny, nx), zero off the candidate cells
        g = np.zeros(v.shape[:-1] + (size,))
        g[..., flat_index] = v
        return g.reshape(v.shape[:-1] + found.shape)

    def flex(v):
        return found.flexibility(on_grid(v)).reshape(v.shape[:-1] + (size,))[..., flat_index] + comp * v

    k_cand = found.stiffness_matrix(flat_index)

    def stiff(v, on):  # the preconditioner S K S restricted to the contact cells, v (..., n)
        return np.where(on, scale * (k_cand @ np.where(on, scale * v, 0.0).T).T, 0.0)

    lam = _balance(np.maximum(lam0, 0.0), jac, target)
    w = flex(lam)
    t = np.zeros_like(lam)
    rho_old, conj, on_old = 1.0, False, None
    for it in range(1, max_iter + 1):
        on = lam > 0
        if on_old is None or not np.array_equal(on, on_old):
            kj = stiff(jac.T, on)                         # (3, n) K_A J_A
            jkj = jac[on].T @ kj[:, on].T                 # (3, 3) J' K_A J
            jkj_inv = np.linalg.inv(jkj + 1e-14 * np.trace(jkj) * np.eye(3))
            on_old = on
        raw = w + b0                                      # gap before the rigid move
        coef = jkj_inv @ (kj[:, on] @ raw[on])
        z = stiff(raw, on) - coef @ kj                    # projected, preconditioned gradient
        q = -coef                                         # the rigid move that best closes the gap
        gap = raw + jac @ q
        rho = gap[on] @ z[on]  # not raw: its large rigid part would swamp the round-off test
        t = np.where(on, z + (rho / rho_old) * t if conj else z, 0.0)
        rho_old = rho
        ht = flex(t)
        denom = t[on] @ ht[on]
        tau = (gap[on] @ t[on]) / denom if denom > 0 else 0.0
        lam_old = lam
        step = lam - tau * t
        enter = (step <= 0) & (gap < 0) & ~on
        conj = not enter.any() and not np.any(step[on] <= 0)
        if conj:  # the active set holds: a plain CG step, balanced by construction
            lam = step
            w = w - tau * ht
        else:
            lam = np.maximum(step, 0.0)
            lam[enter] = -gap[enter] * k_eff[enter]
            lam = _balance(lam, jac, target)
            w = flex(lam)
        if np.abs(q[1:]).max() > 10 * max_slope:  # heading for a tip-over
            raise PressFailed(f"no equilibrium: the body tips over (slope {q[1]:.2f}, {q[2]:.2f})")
        if np.abs(lam - lam_old).sum() < tol * weight_n:
            on = lam > 0
            q = np.linalg.lstsq(jac[on], -(flex(lam) + b0)[on], rcond=None)[0]
            if np.abs(q[1:]).max() > max_slope:
                raise PressFailed(f"no equilibrium: the body tips over (slope {q[1]:.2f}, {q[2]:.2f}); "
                                  f"its centre of mass is outside the area it rests on")
            return ContactSolution(lam, q, it)
    raise PressFailed(f"Pasternak contact did not converge in {max_iter} iterations")


def _balance(lam: np.ndarray, jac: np.ndarray, target: np.ndarray) -> np.ndarray:
    """Scale the forces by exp(J a) so that ``J' lam = target`` exactly (load and both moments),
    keeping them non-negative: the three-constraint form of Polonsky and Keer's load scaling."""
    on = lam > 0
    if not on.any():
        raise PressFailed("no cell carries load")
    lj, jj = lam[on], jac[on]
    a = np.zeros(3)
    for _ in range(50):
        f = lj * np.exp(np.clip(jj @ a, -50, 50))
        res = jj.T @ f - target
        if np.all(np.abs(res) <= 1e-12 * target[0]):
            break
        hess = (jj * f[:, None]).T @ jj
        a -= np.linalg.solve(hess + 1e-14 * np.trace(hess) * np.eye(3), res)
    else:
        raise PressFailed("no equilibrium: the load cannot be balanced about the centre of mass on "
                          "the cells in contact (the body would tip over)")
    out = np.zeros_like(lam)
    out[on] = f
    return out
