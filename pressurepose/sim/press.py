"""Physics simulation #2: press a body mesh into the bed and read the pressure mat.

The body's lower surface is sampled on a fine grid (each taxel split into cells of about
``bed.press_cell_m``); given its bones, its surface yields as soft tissue in series with the
mattress (:mod:`pressurepose.sim.tissue`). The body is moved by a vertical shift and two small
tilts about its centre of mass until the foundation (:mod:`pressurepose.sim.foundation`) carries
exactly its weight with no net moment; the cell forces are summed per taxel and read through the
sensor model (:mod:`pressurepose.sim.sensor`).

A limb hanging over the mattress's edge is beside the mattress, not on it, though the settled mesh
spills a few cm over the edge: the mattress carries the body only where its surface lies above the
mattress's bottom (``bed.mattress_thickness_m`` below the unloaded top) where the mesh is given,
and cells within ``EDGE_ZONE_M`` of the mattress's edges that the body would press through the
mattress (the hanging limb's sides) carry nothing. So the mesh must be given at (or near) its
resting height, as physics simulation #1 leaves it; a mesh given lower than it rests loses support
it should have. A body pressed through the mattress anywhere else fails (:class:`PressFailed`).

>>> res = press(vertices, faces, mass_kg=62.5, bed=get_bed("boditrak_bt3510"))
>>> res.pressure.shape, res.force.sum() <= 62.5 * 9.81
((64, 27), True)
"""

from __future__ import annotations

import dataclasses
import math
from dataclasses import dataclass

import numpy as np

from pressurepose.body.mesh import lower_surface
from pressurepose.errors import BadInput
from pressurepose.sim.bed import BedSpec, get_bed
from pressurepose.sim.foundation import (
    PasternakFoundation,
    PressFailed,
    level_sink,
    rigid_jacobian,
    solve_pasternak,
    solve_winkler,
)
from pressurepose.sim.sensor import GRAVITY, read_sensor
from pressurepose.sim.tissue import Bones, tissue_depth

# Depth reported for taxels with no part of the body above them: far above any resting body, so
# "contact = depth < 0" and a sunk-depth target max(0, -depth) both read "nothing here".
DEPTH_EMPTY_M = 1.0
# A body that must turn further than this to find its support was not at rest: it tips over.
MAX_TILT_RAD = 0.3
# Cells pressed through the mattress within this distance of its side or end edges hold the sides
# of a limb hanging over the edge (a settled mesh spills a few cm over it): they are dropped and the
# contact solved again, at most MAX_EDGE_ROUNDS times. Pressed through anywhere else, the body fails.
EDGE_ZONE_M = 0.06
MAX_EDGE_ROUNDS = 3

__all__ = ["press", "press_heightfield", "body_heightfield", "Heightfield", "PressResult", "PressFailed",
           "PressGrid", "press_grid", "mesh_centroid", "tilt_transform", "GRAVITY", "DEPTH_EMPTY_M"]


@dataclass(frozen=True)
class PressGrid:
    """The fine grid of the press over the whole simulated mat (see ``BedSpec.full_grid``):
    each taxel is ``sub = (rows, cols)`` cells; ``shape`` (ny, nx), ``cell_xy`` (dx, dy) m,
    ``origin_xy`` the bed-frame corner."""

    sub: tuple[int, int]
    shape: tuple[int, int]
    cell_xy: tuple[float, float]
    origin_xy: tuple[float, float]

    def centers(self) -> tuple[np.ndarray, np.ndarray]:
        """Bed-frame x (nx,) and y (ny,) of the cell centres."""
        x = self.origin_xy[0] + (np.arange(self.shape[1]) + 0.5) * self.cell_xy[0]
        y = self.origin_xy[1] + (np.arange(self.shape[0]) + 0.5) * self.cell_xy[1]
        return x, y

    def per_taxel(self, cells: np.ndarray, reduce=np.add) -> np.ndarray:
        """(ny, nx) cell values reduced to the full taxel grid (rows, cols) with ``reduce``."""
        sr, sc = self.sub
        ny, nx = self.shape
        blocks = cells.reshape(ny // sr, sr, nx // sc, sc)
        return reduce.reduce(reduce.reduce(blocks, axis=3), axis=1)


def press_grid(bed: BedSpec) -> PressGrid:
    full = bed.full_grid
    sr = max(1, math.ceil(full.pitch_row_m / bed.press_cell_m - 1e-9))
    sc = max(1, math.ceil(full.pitch_col_m / bed.press_cell_m - 1e-9))
    return PressGrid(sub=(sr, sc), shape=(full.rows * sr, full.cols * sc),
                     cell_xy=(full.pitch_col_m / sc, full.pitch_row_m / sr), origin_xy=full.origin_xy)


@dataclass(frozen=True)
class PressResult:
    """What the mat reads under a body at rest, over the sensing area (rows, cols) unless noted.

    pressure: sensor reading, mmHg, clipped to the sensor's range.
    force: newtons carried by each taxel before the sensor model.
    depth: the body's lowest point over each taxel after the press, metres relative to the
        unloaded bed top (negative when sunk); ``DEPTH_EMPTY_M`` (+1 m) where no body is above.
        The lower surface is sampled at the centres of the press cells (``bed.press_cell_m``),
        so a rounded bottom between two centres reads about r (cell / 2)^2 / 2 high.
    contact: ``depth < 0``.
    bed_force: newtons per taxel over the whole simulated mat (``bed.full_grid``); sums to m g.
    transform: (4, 4) the rigid motion the press applied to the body (bed frame): a small rotation
        about the centre of mass and a vertical shift. Apply it to the mesh, root and joints to
        get the body where the image was made.
    com: (3,) the body's centre of mass before the press.
    sink_m: how far the body's lowest point went below the unloaded bed top (positive = sunk).
    iterations: solver iterations used (all passes).
    label: for a body pressed with ``vertex_label``, (rows, cols) int64: the label of the surface
        that carried most of each taxel's force (each press cell's force counts for the vertex of
        the lowest surface nearest the cell's centre), -1 where the body carries nothing; else None.
    """

    pressure: np.ndarray
    force: np.ndarray
    depth: np.ndarray
    contact: np.ndarray
    bed_force: np.ndarray
    transform: np.ndarray
    com: np.ndarray
    sink_m: float
    iterations: int
    label: np.ndarray | None = None

    @property
    def shift_m(self) -> float:
        """How far the press moved the centre of mass up (negative = down)."""
        return float(self.transform[2, :3] @ self.com + self.transform[2, 3] - self.com[2])

    @property
    def tilt_rad(self) -> np.ndarray:
        """(about x, about y): the press's rotation of the body, radians (x-then-y Euler angles)."""
        r = self.transform[:3, :3]
        return np.array([math.atan2(r[2, 1], r[2, 2]), math.asin(max(-1.0, min(1.0, -r[2, 0])))])


def tilt_transform(com: np.ndarray, shift: float, slope) -> np.ndarray:
    """The rigid motion whose first-order effect on heights is ``shift + slope . (xy - com_xy)``:
    rotation about the centre of mass ``com`` (3,), then a vertical shift."""
    ry = -math.atan(slope[0])  # turning about +y by a lowers +x by a per metre
    rx = math.atan(slope[1])   # turning about +x by a raises +y by a per metre
    cx, sx, cy, sy = math.cos(rx), math.sin(rx), math.cos(ry), math.sin(ry)
    rot = np.array([[1, 0, 0], [0, cx, -sx], [0, sx, cx]]) @ np.array([[cy, 0, sy], [0, 1, 0], [-sy, 0, cy]])
    out = np.eye(4)
    out[:3, :3] = rot
    out[:3, 3] = com - rot @ com + np.array([0.0, 0.0, shift])
    return out


def mesh_centroid(vertices: np.ndarray, faces: np.ndarray) -> tuple[float, np.ndarray]:
    """Signed volume (m^3) and volume centroid (3,) of a closed triangle mesh."""
    a, b, c = vertices[faces[:, 0]], vertices[faces[:, 1]], vertices[faces[:, 2]]
    ref = vertices.mean(0)  # tetrahedra from a nearby point keep the sums well conditioned
    a, b, c = a - ref, b - ref, c - ref
    vol6 = np.einsum("fi,fi->f", a, np.cross(b, c))
    volume = vol6.sum() / 6.0
    if volume == 0:
        return 0.0, ref
    centroid = ref + (vol6[:, None] * (a + b + c)).sum(0) / (24.0 * volume)
    return float(volume), centroid


@dataclass(frozen=True)
class Heightfield:
    """A body's lower surface on the press grid of a bed: ``bottom`` (ny, nx) heights (m,
    ``+inf`` where no body), its centre of mass ``com`` (3,) and, for a body with soft tissue,
    ``tissue`` (ny, nx) the tissue's depth over the bone (m, 0 where no body; None: rigid);
    ``label`` (ny, nx) int64 the label of the surface over each cell (-1 where no body; None: not
    labelled). Depends only on the geometry of the bed (mat, mattress, press_cell_m), not on its
    stiffness or sensor constants."""

    bottom: np.ndarray
    com: np.ndarray
    grid: PressGrid
    tissue: np.ndarray | None = None
    label: np.ndarray | None = None


def body_heightfield(vertices, faces, bed: BedSpec | None = None, *, com_xy=None,
                     bones: Bones | None = None, vertex_label=None) -> Heightfield:
    """Sample a closed mesh's lower surface on the press grid of ``bed``.

    vertices (V, 3) bed frame, metres; faces (F, 3) int, a closed surface (either winding).
    ``com_xy`` overrides the centre of mass's x, y (default: the mesh's volume centroid).
    Surface deeper than the mattress's bottom (``-bed.mattress_thickness_m``) is beside the
    mattress (a limb hanging over its edge) and is left out: the cells over it read the body's
    lowest surface above that depth, or nothing. ``bones`` (same frame): the body has soft tissue
    over them (:mod:`pressurepose.sim.tissue`); None: the body is rigid. ``vertex_label`` (V,)
    ints >= 0 (e.g. :func:`pressurepose.body.sites.vertex_sites`): each cell gets the label of the
    vertex of the lowest surface nearest its centre.
    """
    bed = _check_bed(bed)
    verts, tris = _check_mesh(vertices, faces)
    labels = _check_labels(vertex_label, len(verts))
    volume, com = mesh_centroid(verts, tris)
    if abs(volume) < 1e-12:
        raise BadInput("the mesh encloses no volume; faces must form a closed surface")
    if com_xy is not None:
        xy = np.asarray(com_xy, dtype=np.float64)
        if xy.shape != (2,) or not np.all(np.isfinite(xy)):
            raise BadInput(f"com_xy is {com_xy!r}; expected two finite numbers (x, y) in metres")
        com = np.array([xy[0], xy[1], com[2]])
    # the lowest point over any spot lies on a face turned downward (outward normals: volume > 0)
    e1, e2 = verts[tris[:, 1]] - verts[tris[:, 0]], verts[tris[:, 2]] - verts[tris[:, 0]]
    normal_z = e1[:, 0] * e2[:, 1] - e1[:, 1] * e2[:, 0]
    down = tris[normal_z * np.sign(volume) < 0]
    grid = press_grid(bed)
    bottom, nearest = lower_surface(verts, down, grid.origin_xy, grid.cell_xy, grid.shape,
                                    floor=-bed.mattress_thickness_m, return_vertex=True)
    label = None if labels is None else np.where(nearest >= 0, labels[nearest], -1)
    return with_tissue(Heightfield(bottom, com, grid, label=label), bones)


def with_tissue(hf: Heightfield, bones: Bones | None) -> Heightfield:
    """``hf`` with the tissue over ``bones`` (None: a rigid body), e.g. the same surface over other bones."""
    if bones is None:
        return dataclasses.replace(hf, tissue=None)
    if not isinstance(bones, Bones):
        raise BadInput(f"bones is {type(bones).__name__}; expected a pressurepose.sim.tissue.Bones")
    tissue = np.zeros(hf.grid.shape)
    jj, ii = np.nonzero(np.isfinite(hf.bottom))
    xs, ys = hf.grid.centers()
    tissue[jj, ii] = tissue_depth(np.stack([xs[ii], ys[jj], hf.bottom[jj, ii]], axis=1), bones)
    return dataclasses.replace(hf, tissue=tissue)


def press(vertices, faces, mass_kg: float, bed: BedSpec | None = None, *, com_xy=None,
          bones: Bones | None = None, margin_m: float | None = None, tol: float = 1e-7,
          max_linear_tilt: float = 0.01, max_passes: int = 4, vertex_label=None) -> PressResult:
    """Rest a body mesh (rigid, or with soft tissue over its bones) on the bed and read the mat.

    vertices (V, 3) bed frame, metres, at the body's resting height or above it (the press finds
    the height; surface deeper than the mattress's bottom hangs beside it: see the module doc);
    faces (F, 3) int, a closed surface (either winding); mass_kg > 0. ``com_xy`` overrides the
    centre of mass's x, y (default: the mesh's volume centroid).
    ``bones`` (K segments in the same frame, :func:`pressurepose.sim.tissue.body_bones`): the body's
    surface yields over them as soft tissue in series with the mattress (modulus
    ``bed.tissue_modulus_pa``); None presses a rigid body. ``margin_m``: the Pasternak
    foundation is solved on the part of the bed within this distance of the body (default
    ``max(0.15, 6 sqrt(G / k_A))``, where a dent has faded to < 0.3 %); ``tol``: the solver stops
    when the forces change by less than ``tol`` m g in an iteration. ``vertex_label`` (V,) ints >= 0:
    the result's ``label`` says which label carried each taxel's force (e.g. the body sites of
    :func:`pressurepose.body.sites.vertex_sites`).

    The contact solve treats the tilt to first order (heights change by slope . (xy - com));
    while it asks for more than ``max_linear_tilt`` rad, the mesh is turned by it about its
    centre of mass and sampled again (at most ``max_passes`` passes), so the returned transform
    is a rigid motion whose image was actually pressed.
    Raises :class:`PressFailed` when the body has no equilibrium on the bed.
    """
    bed = _check_bed(bed)
    verts, tris = _check_mesh(vertices, faces)
    turned = np.eye(4)
    iterations = 0
    for n in range(1, max_passes + 1):
        moved = verts @ turned[:3, :3].T + turned[:3, 3]
        hf = body_heightfield(moved, tris, bed, com_xy=com_xy, bones=None if bones is None else bones.moved(turned),
                              vertex_label=vertex_label)
        res = press_heightfield(hf, mass_kg, bed, margin_m=margin_m, tol=tol)
        iterations += res.iterations
        total = res.transform @ turned
        angle = math.acos(max(-1.0, min(1.0, (np.trace(total[:3, :3]) - 1) / 2)))
        if angle > MAX_TILT_RAD:
            raise PressFailed(f"no equilibrium: the body tips over (turns {angle:.2f} rad to find its support)")
        if np.abs(res.tilt_rad).max() <= max_linear_tilt or n == max_passes:
            break
        turned = _rotation_part(res.transform, res.com) @ turned  # about the centre of mass: it stays put
    return dataclasses.replace(res, transform=total, iterations=iterations)


def _rotation_part(transform: np.ndarray, pivot: np.ndarray) -> np.ndarray:
    """The rotation of a rigid transform, about ``pivot``, without its translation of the pivot."""
    out = np.eye(4)
    out[:3, :3] = transform[:3, :3]
    out[:3, 3] = pivot - transform[:3, :3] @ pivot
    return out


def press_heightfield(hf: Heightfield, mass_kg: float, bed: BedSpec, *, margin_m: float | None = None,
                      tol: float = 1e-7) -> PressResult:
    """One contact solve for a body already sampled with :func:`body_heightfield` on this bed's
    grid (for many presses of one shape, e.g. calibration). The tilt is first order only: see
    :func:`press`."""
    bed = _check_bed(bed)
    if isinstance(mass_kg, bool) or not isinstance(mass_kg, (int, float, np.integer, np.floating)) \
            or not math.isfinite(mass_kg) or mass_kg <= 0:
        raise BadInput(f"mass_kg is {mass_kg!r}; expected a positive number of kilograms")
    grid = press_grid(bed)
    if grid != hf.grid:
        raise BadInput("the heightfield was sampled on another bed's grid; sample it with this bed")
    weight = float(mass_kg) * GRAVITY
    b0, com = hf.bottom, hf.com
    cell_area = grid.cell_xy[0] * grid.cell_xy[1]
    # m/N of tissue in series with each cell's spring
    comp = np.zeros(grid.shape) if hf.tissue is None else hf.tissue / (bed.tissue_modulus_pa * cell_area)
    k_cell = bed.stiffness_n_m3 * cell_area
    edge = _edge_zone(grid, bed)
    b0 = _drop_hanging_sides(b0, edge, k_cell / (1.0 + k_cell * comp), weight, bed.mattress_thickness_m)
    iterations = 0
    for attempt in range(MAX_EDGE_ROUNDS + 1):
        under, jac, sol, its = _contact_solve(b0, com, grid, bed, weight, margin_m, tol, comp)
        iterations += its
        bottom = np.full(grid.shape, np.inf)
        bottom[under] = b0[under] + jac @ sol.q
        sink = float(-bottom[under].min())
        sheet = bottom.copy()  # where the mattress's top is pushed to: the bottom less the squeezed tissue
        sheet[under] += comp[under] * sol.lam
        through = sheet < -bed.mattress_thickness_m
        if not through.any():
            break
        if (through & ~edge).any() or attempt == MAX_EDGE_ROUNDS:
            raise PressFailed(f"the body sinks {sink:.2f} m, through the {bed.mattress_thickness_m:.2f} m mattress")
        b0 = np.where(through, np.inf, b0)
    lam = np.zeros(grid.shape)
    lam[under] = sol.lam
    bed_force = grid.per_taxel(lam)
    depth_full = grid.per_taxel(bottom, reduce=np.minimum)
    sl = bed.full_grid.sensing_slice
    force = bed_force[sl].copy()
    depth = np.where(np.isfinite(depth_full[sl]), depth_full[sl], DEPTH_EMPTY_M)
    return PressResult(
        pressure=read_sensor(force, bed),
        force=force,
        depth=depth,
        contact=depth < 0,
        bed_force=bed_force,
        transform=tilt_transform(com, float(sol.q[0]), sol.q[1:]),
        com=com.copy(),
        sink_m=sink,
        iterations=iterations,
        label=None if hf.label is None else _taxel_label(lam, hf.label, grid)[sl],
    )


def _taxel_label(cell_force: np.ndarray, cell_label: np.ndarray, grid: PressGrid) -> np.ndarray:
    """(rows, cols) over the full taxel grid: the label whose cells carry most of each taxel's force
    (``cell_force`` and ``cell_label`` (ny, nx)); -1 where no labelled cell carries any."""
    sr, sc = grid.sub
    ny, nx = grid.shape
    rows, cols = ny // sr, nx // sc
    on = (cell_force > 0) & (cell_label >= 0)
    out = np.full(rows * cols, -1, dtype=np.int64)
    if not on.any():
        return out.reshape(rows, cols)
    jj, ii = np.nonzero(on)
    n_labels = int(cell_label[on].max()) + 1
    taxel = (jj // sr) * cols + ii // sc
    sums = np.bincount(taxel * n_labels + cell_label[on], weights=cell_force[on],
                       minlength=rows * cols * n_labels).reshape(rows * cols, n_labels)
    carried = sums.max(axis=1) > 0
    out[carried] = np.argmax(sums[carried], axis=1)
    return out.reshape(rows, cols)


def _contact_solve(b0: np.ndarray, com: np.ndarray, grid: PressGrid, bed: BedSpec, weight: float,
                   margin_m: float | None, tol: float, comp: np.ndarray):
    """The contact solve over the cells with a body above them, ``comp`` (ny, nx) m/N of tissue in
    series with each cell: (under (ny, nx) bool, jacobian, ContactSolution, iterations)."""
    under = np.isfinite(b0)
    if not under.any():
        raise PressFailed("the body is not over the mattress")
    xs, ys = grid.centers()
    jj, ii = np.nonzero(under)
    jac = rigid_jacobian(xs[ii], ys[jj], com[:2])
    dx, dy = grid.cell_xy
    k_cell = bed.stiffness_n_m3 * dx * dy
    c = comp[under]
    sol = solve_winkler(b0[under], jac, k_cell / (1.0 + k_cell * c), weight, max_slope=MAX_TILT_RAD)
    iterations = sol.iterations
    if bed.coupling_n_m > 0:
        margin = max(0.15, 6.0 * bed.spread_length_m) if margin_m is None else float(margin_m)
        j0, j1 = _fast_window(jj.min(), jj.max() + 1, math.ceil(margin / dy), grid.shape[0])
        i0, i1 = _fast_window(ii.min(), ii.max() + 1, math.ceil(margin / dx), grid.shape[1])
        found = PasternakFoundation((j1 - j0, i1 - i0), grid.cell_xy, bed.stiffness_n_m3, bed.coupling_n_m)
        flat = (jj - j0) * (i1 - i0) + (ii - i0)
        sol = solve_pasternak(b0[under], jac, flat, found, weight, sol.lam, tol=tol, max_slope=MAX_TILT_RAD,
                              compliance=c)
        iterations += sol.iterations
    return under, jac, sol, iterations


def _drop_hanging_sides(b0: np.ndarray, edge: np.ndarray, k_cell: np.ndarray, weight: float,
                        thickness: float) -> np.ndarray:
    """``b0`` (ny, nx) heights without the edge-zone cells that a level sink of the body (springs
    ``k_cell`` (ny, nx) N/m per cell, ``weight`` N) pushes deeper than ``thickness`` (the sides of a limb
    hanging over the mattress's edge): a first guess, made before those sides can turn the body
    in the contact solve."""
    b0 = b0.copy()
    for _ in range(MAX_EDGE_ROUNDS):
        finite = np.isfinite(b0)
        if not finite.any():
            break
        through = finite & edge & (b0 - level_sink(b0[finite], k_cell[finite], weight) < -thickness)
        if not through.any():
            break
        b0[through] = np.inf
    return b0


def _edge_zone(grid: PressGrid, bed: BedSpec) -> np.ndarray:
    """(ny, nx) bool: press cells within ``EDGE_ZONE_M`` of the mattress's edges."""
    x0, x1, y0, y1 = bed.mattress_bounds
    xs, ys = grid.centers()
    near_x = (xs - x0 < EDGE_ZONE_M) | (x1 - xs < EDGE_ZONE_M)
    near_y = (ys - y0 < EDGE_ZONE_M) | (y1 - ys < EDGE_ZONE_M)
    return near_x[None, :] | near_y[:, None]


def _check_bed(bed) -> BedSpec:
    bed = get_bed() if bed is None else bed
    if not isinstance(bed, BedSpec):
        raise BadInput(f"bed is {type(bed).__name__}; expected a BedSpec (see get_bed)")
    return bed


def _fast_window(lo: int, hi: int, margin: int, n: int) -> tuple[int, int]:
    """A window [start, stop) of [0, n) holding [lo, hi) plus ``margin`` cells each side where the
    grid allows, whose length has only small prime factors (cosine transforms of prime lengths are
    ten times slower)."""
    want = min(hi - lo + 2 * margin, n)
    up = [m for m in range(want, n + 1) if _smooth(m)]
    length = up[0] if up else next((m for m in range(want - 1, hi - lo - 1, -1) if _smooth(m)), hi - lo)
    start = min(max((lo + hi - length) // 2, 0), n - length)
    return start, start + length


def _smooth(m: int) -> bool:
    for p in (2, 3, 5, 7):
        while m % p == 0:
            m //= p
    return m == 1


def _check_labels(vertex_label, n_vertices: int) -> np.ndarray | None:
    if vertex_label is None:
        return None
    lab = np.asarray(vertex_label)
    if lab.shape != (n_vertices,) or lab.dtype.kind not in "iu" or (lab.size and lab.min() < 0):
        raise BadInput(f"vertex_label has shape {lab.shape} and dtype {lab.dtype}; expected ({n_vertices},) "
                       f"integers >= 0, one per vertex")
    return lab.astype(np.int64)


def _check_mesh(vertices, faces) -> tuple[np.ndarray, np.ndarray]:
    try:
        v = np.asarray(vertices, dtype=np.float64)
    except (TypeError, ValueError):
        raise BadInput("vertices must be a numeric (V, 3) array in metres") from None
    if v.ndim != 2 or v.shape[1] != 3 or len(v) < 4:
        raise BadInput(f"vertices has shape {v.shape}; expected (V, 3) with V >= 4, bed frame metres")
    if not np.all(np.isfinite(v)):
        raise BadInput("vertices contain NaN or infinite values")
    f = np.asarray(faces)
    if f.ndim != 2 or f.shape[1] != 3 or len(f) < 4 or not np.issubdtype(f.dtype, np.integer):
        raise BadInput(f"faces has shape {f.shape} and dtype {f.dtype}; expected (F, 3) integer triangles, F >= 4")
    if f.min() < 0 or f.max() >= len(v):
        raise BadInput(f"faces index vertices {f.min()}..{f.max()}; the mesh has {len(v)} vertices")
    return v, f.astype(np.int64)
