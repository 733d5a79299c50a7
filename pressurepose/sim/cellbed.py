"""The soft mattress of physics simulation #1: a grid of spring-loaded vertical slider cells.

Each cell is a box whose top is the mattress surface (z = 0 in the bed frame when unloaded) on a
vertical slider with a spring ``k_A dx dy`` and a damper, so the mattress pushes back in proportion to
both the area pressed and the depth (a Winkler foundation). Neighbouring cells
are tied by spring tendons (the Pasternak shear layer of :class:`~pressurepose.sim.bed.BedSpec`,
``G dy/dx`` and ``G dx/dy``), which spreads a dent as a real mattress and sheet do and keeps the cell
edges from acting as a bed of nails. Cells carry gravity compensation, so the unloaded mattress is flat
at z = 0; their mass is numerical (see :func:`cell_bed`). A cell pressed through the whole mattress
thickness stops there (a joint limit: the bed frame under the foam), as under a limb levered over
the mattress edge.

The exact force each cell carries is the constraint force on its slider,
``-qfrc_constraint[dof]`` (the contact rows of ``efc_force`` mapped through the Jacobian).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import mujoco
import numpy as np

from pressurepose.errors import BadInput, require_non_negative, require_positive, require_whole
from pressurepose.sim.bed import BedSpec
from pressurepose.sim.ragdoll import BED_BIT

CELL_HALF_HEIGHT_M = 0.05
# A cell's spring-mass frequency times the time step. Its spring is integrated explicitly (only damping
# is implicit), and measured here: at 0.4 and above a resting capsule chatters on the cells, at 0.3
# and below it comes to rest.
CELL_OMEGA_DT = 0.25


@dataclass(frozen=True)
class CellBed:
    """A grid of ``ny`` (along the bed, y) x ``nx`` (across, x) slider cells of ``dx`` x ``dy`` m whose
    head-left corner is at bed-frame (x0, y0).

    k_cell: N/m spring per cell; b_cell: N s/m damper per cell; coupling_x / coupling_y: N/m spring
    tendons between x / y neighbours (0: none); friction: Coulomb friction with the body;
    cell_mass: kg per cell (numerical: see :func:`cell_bed`);
    thickness_m: the mattress thickness: a cell stops there, on the bed frame;
    contact_timeconst_s: MuJoCo's contact time constant (``solref[0]``) between body
    and cells; at 2 steps (0.02 s, MuJoCo's floor) contacts chatter, 0.05 s keeps them quiet.
    """

    nx: int
    ny: int
    x0: float
    y0: float
    dx: float
    dy: float
    k_cell: float
    b_cell: float
    coupling_x: float
    coupling_y: float
    friction: float
    cell_mass: float = 0.1
    thickness_m: float = 0.2
    contact_timeconst_s: float = 0.05

    def __post_init__(self):
        if self.nx < 1 or self.ny < 1:
            raise BadInput(f"cell bed has {self.ny} x {self.nx} cells; expected at least one")
        for name in ("dx", "dy", "k_cell", "cell_mass", "thickness_m", "contact_timeconst_s"):
            require_positive(f"cell bed {name}", getattr(self, name))
        for name in ("b_cell", "coupling_x", "coupling_y", "friction"):
            require_non_negative(f"cell bed {name}", getattr(self, name))

    @property
    def stiffness_n_m3(self) -> float:
        """The foundation modulus k_A, N/m^3."""
        return self.k_cell / (self.dx * self.dy)

    @property
    def bounds(self) -> tuple[float, float, float, float]:
        """(x_min, x_max, y_min, y_max) of the cell grid in the bed frame."""
        return (self.x0, self.x0 + self.nx * self.dx, self.y0, self.y0 + self.ny * self.dy)

    def centers(self) -> np.ndarray:
        """(ny, nx, 2) bed-frame xy of the cell centres."""
        x = self.x0 + (np.arange(self.nx) + 0.5) * self.dx
        y = self.y0 + (np.arange(self.ny) + 0.5) * self.dy
        return np.stack(np.meshgrid(x, y), axis=-1)


def cell_bed(bed: BedSpec, cell_m: float | None = None, *, taxels_per_cell: int = 1,
             stiffness_n_m3: float | None = None, coupling: bool = True, cell_mass: float | None = None,
             timestep_s: float = 0.01, contact_timeconst_s: float = 0.05) -> CellBed:
    """The cell grid over the whole mattress of ``bed``.

    cell_m: target cell size; default ``taxels_per_cell`` taxel pitches (along and across the bed
    separately); the mattress is split into whole cells of about that size. stiffness_n_m3: the settle model's own foundation modulus (default the bed's;
    appendix A.5 calibrates it separately, see :func:`rigid_sink`); the damping keeps the bed's time
    constant. coupling: tie neighbouring cells with the bed's shear stiffness. cell_mass: kg per cell;
    default the mass that puts a cell's own spring-mass frequency at ``CELL_OMEGA_DT / timestep_s``
    (lighter cells chatter under a resting body at dt = 0.01 s, heavier ones slow its fall).
    """
    x_min, x_max, y_min, y_max = bed.mattress_bounds
    w, length = x_max - x_min, y_max - y_min
    require_whole("taxels_per_cell", taxels_per_cell, 1)
    cx = taxels_per_cell * bed.mat.pitch_col_m if cell_m is None else float(cell_m)
    cy = taxels_per_cell * bed.mat.pitch_row_m if cell_m is None else float(cell_m)
    if not (math.isfinite(cx) and cx > 0):
        raise BadInput(f"cell size {cell_m!r} must be a positive number of metres")
    nx, ny = max(1, round(w / cx)), max(1, round(length / cy))
    dx, dy = w / nx, length / ny
    springs = bed.cell_springs(dx, dy)
    scale = 1.0 if stiffness_n_m3 is None else float(stiffness_n_m3) / bed.stiffness_n_m3
    if not (math.isfinite(scale) and scale > 0):
        raise BadInput(f"settle stiffness {stiffness_n_m3!r} must be a positive number (N/m^3)")
    k_cell = springs["vertical"] * scale
    if cell_mass is None:
        cell_mass = k_cell * (timestep_s / CELL_OMEGA_DT) ** 2
    return CellBed(nx=nx, ny=ny, x0=x_min, y0=y_min, dx=dx, dy=dy, k_cell=k_cell,
                   b_cell=springs["damping"] * scale, coupling_x=springs["coupling_x"] if coupling else 0.0,
                   coupling_y=springs["coupling_y"] if coupling else 0.0, friction=springs["friction"],
                   cell_mass=cell_mass, thickness_m=bed.mattress_thickness_m,
                   contact_timeconst_s=contact_timeconst_s)


def cell_name(row: int, col: int) -> str:
    return f"cell_{row}_{col}"


def add_cells(spec: mujoco.MjSpec, cells: CellBed) -> None:
    """Add the cell grid (bodies ``cell_<row>_<col>``, one slider each) and its coupling tendons."""
    h = CELL_HALF_HEIGHT_M
    xy = cells.centers()
    for r in range(cells.ny):
        for c in range(cells.nx):
            b = spec.worldbody.add_body(name=cell_name(r, c), pos=[xy[r, c, 0], xy[r, c, 1], -h], gravcomp=1.0)
            b.add_joint(name=cell_name(r, c), type=mujoco.mjtJoint.mjJNT_SLIDE, axis=[0.0, 0.0, 1.0],
                        stiffness=cells.k_cell, damping=cells.b_cell, limited=mujoco.mjtLimited.mjLIMITED_TRUE,
                        range=[-cells.thickness_m, cells.thickness_m])
            b.add_geom(type=mujoco.mjtGeom.mjGEOM_BOX, size=[cells.dx / 2, cells.dy / 2, h], mass=cells.cell_mass,
                       contype=BED_BIT, conaffinity=0, condim=3, friction=[cells.friction, 0.005, 0.0001],
                       solref=[cells.contact_timeconst_s, 1.0])
    for r in range(cells.ny):
        for c in range(cells.nx):
            for rr, cc, k in ((r, c + 1, cells.coupling_x), (r + 1, c, cells.coupling_y)):
                if k > 0 and rr < cells.ny and cc < cells.nx:
                    t = spec.add_tendon(stiffness=k)
                    t.wrap_joint(cell_name(r, c), 1.0)
                    t.wrap_joint(cell_name(rr, cc), -1.0)


@dataclass(frozen=True)
class CellIndex:
    """Addresses of the cells in a compiled model, each (ny, nx): slider qpos and dof, body, geom."""

    qpos: np.ndarray
    dof: np.ndarray
    body: np.ndarray
    geom: np.ndarray

    @staticmethod
    def of(model: mujoco.MjModel, cells: CellBed) -> "CellIndex":
        names = [cell_name(r, c) for r in range(cells.ny) for c in range(cells.nx)]
        jnt = np.array([model.joint(n).id for n in names])
        body = np.array([model.body(n).id for n in names])
        shape = (cells.ny, cells.nx)
        geom = model.body_geomadr[body]
        return CellIndex(qpos=model.jnt_qposadr[jnt].reshape(shape), dof=model.jnt_dofadr[jnt].reshape(shape),
                         body=body.reshape(shape), geom=geom.reshape(shape))


def cell_forces(data: mujoco.MjData, index: CellIndex) -> np.ndarray:
    """(ny, nx) N: the vertical force the body presses on each cell (the constraint force on its
    slider: contact rows of ``efc_force`` mapped through the Jacobian). Sums to m g at rest."""
    return -data.qfrc_constraint[index.dof]


def cell_sink(data: mujoco.MjData, index: CellIndex) -> np.ndarray:
    """(ny, nx) m: each cell's displacement (negative = pressed down)."""
    return data.qpos[index.qpos].copy()


def cell_window(cells: CellBed, x_lo: float, x_hi: float, y_lo: float, y_hi: float) -> CellBed:
    """The cells of ``cells`` (same lattice and constants) that overlap the bed-frame box
    [x_lo, x_hi] x [y_lo, y_hi]; BadInput if none do."""
    c0 = max(0, math.floor((x_lo - cells.x0) / cells.dx))
    c1 = min(cells.nx, math.ceil((x_hi - cells.x0) / cells.dx))
    r0 = max(0, math.floor((y_lo - cells.y0) / cells.dy))
    r1 = min(cells.ny, math.ceil((y_hi - cells.y0) / cells.dy))
    if c1 <= c0 or r1 <= r0:
        raise BadInput(f"the window x [{x_lo:.3f}, {x_hi:.3f}], y [{y_lo:.3f}, {y_hi:.3f}] m is off the bed")
    return CellBed(**{**cells.__dict__, "nx": c1 - c0, "ny": r1 - r0, "x0": cells.x0 + c0 * cells.dx,
                      "y0": cells.y0 + r0 * cells.dy})


@dataclass(frozen=True, eq=False)
class SinkResult:
    """A rigid object at rest on the cell bed.

    sink_m: depth of its lowest point below the unloaded mattress top (positive down);
    cell_force: (ny, nx) N on each cell of ``cells``; cell_sink: (ny, nx) m displacement of each
    cell (negative down); cells: the (windowed) grid simulated; steps: steps run; rested: whether it
    came to rest (speed below 0.1 mm/s for 20 steps) within the step budget.
    """

    sink_m: float
    cell_force: np.ndarray
    cell_sink: np.ndarray
    cells: CellBed
    steps: int
    rested: bool


def rigid_sink(cells: CellBed, shape: str, size, mass_kg: float, center_xy=(0.0, 0.0), yaw_rad: float = 0.0,
               *, margin_m: float = 0.15, timestep_s: float = 0.01, max_steps: int = 3000,
               solver_iterations: int = 50) -> SinkResult:
    """Rest one rigid object on the cell bed and measure how deep it sinks (paper appendix A.5); the
    object moves only up and down.

    shape 'capsule': size (radius, length of the cylinder part) m, lying with its axis along x
    rotated by ``yaw_rad`` about z; shape 'box': size (half x, half y, half z) m, flat face down,
    rotated by ``yaw_rad``. center_xy: bed-frame position, m. Only the cells within ``margin_m`` of
    the object are simulated (a dent spreads over ``sqrt(G / k_A)``, a few cm). The object starts
    1 mm above the mattress, at rest.
    """
    size = np.asarray(size, dtype=np.float64).ravel()
    if shape == "capsule":
        if size.shape != (2,) or np.any(size < 0) or size[0] <= 0:
            raise BadInput(f"capsule size {size.tolist()} must be (radius > 0, length >= 0) metres")
        half = np.array([size[1] / 2 + size[0], size[0], size[0]])
        geom = dict(type=mujoco.mjtGeom.mjGEOM_CAPSULE, size=[size[0], size[1] / 2, 0.0],
                    quat=[np.cos(np.pi / 4), 0.0, np.sin(np.pi / 4), 0.0])  # local z -> x
    elif shape == "box":
        if size.shape != (3,) or np.any(size <= 0):
            raise BadInput(f"box size {size.tolist()} must be three positive half-sizes (metres)")
        half = size
        geom = dict(type=mujoco.mjtGeom.mjGEOM_BOX, size=size.tolist())
    else:
        raise BadInput(f"shape {shape!r} is not known; expected 'capsule' or 'box'")
    if not (math.isfinite(mass_kg) and mass_kg > 0):
        raise BadInput(f"mass_kg {mass_kg!r} must be positive")
    cx, cy = (float(v) for v in center_xy)
    reach = float(np.hypot(half[0], half[1])) + margin_m
    window = cell_window(cells, cx - reach, cx + reach, cy - reach, cy + reach)
    spec = mujoco.MjSpec()
    o = spec.option
    o.timestep = timestep_s
    o.integrator = mujoco.mjtIntegrator.mjINT_IMPLICITFAST
    o.solver = mujoco.mjtSolver.mjSOL_NEWTON
    o.cone = mujoco.mjtCone.mjCONE_ELLIPTIC
    o.iterations = solver_iterations
    body = spec.worldbody.add_body(name="object", pos=[cx, cy, half[2] + 0.001],
                                   quat=[np.cos(yaw_rad / 2), 0.0, 0.0, np.sin(yaw_rad / 2)])
    # held level and in place, as an object pressed into its dent is: on coarse cells a free capsule
    # would roll from cell row to cell row instead of coming to rest
    body.add_joint(type=mujoco.mjtJoint.mjJNT_SLIDE, axis=[0.0, 0.0, 1.0])
    body.add_geom(mass=mass_kg, contype=0, conaffinity=BED_BIT, condim=3,
                  friction=[window.friction, 0.005, 0.0001], solref=[window.contact_timeconst_s, 1.0], **geom)
    add_cells(spec, window)
    model = spec.compile()
    data = mujoco.MjData(model)
    index = CellIndex.of(model, window)
    still, step = 0, 0
    z0 = half[2] + 0.001  # the slider measures the object's height from its start
    z_prev = data.qpos[0]
    for step in range(1, max_steps + 1):
        mujoco.mj_step(model, data)
        still = still + 1 if abs(data.qpos[0] - z_prev) < 1e-4 * timestep_s else 0
        z_prev = data.qpos[0]
        if still >= 20:
            break
    mujoco.mj_forward(model, data)
    return SinkResult(sink_m=float(half[2] - z0 - data.qpos[0]), cell_force=cell_forces(data, index),
                      cell_sink=cell_sink(data, index), cells=window, steps=step, rested=still >= 20)


def capsule_sinks(cells: CellBed, radius_m, length_m, mass_kg, center_xy_m, yaw_rad) -> np.ndarray:
    """Sinks (J,) m of J rigid capsules, each resting alone on ``cells``. The arguments are as in
    :class:`~pressurepose.calibrate.measurements.CapsuleMeasurements`: radius and mass (J,), length
    (J,) end to end *with* the caps, bed-frame centre (J, 2), yaw of the axis from the x axis (J,)."""
    radius, length, mass = (np.atleast_1d(np.asarray(a, dtype=np.float64)) for a in (radius_m, length_m, mass_kg))
    if np.any(length < 2 * radius - 1e-12):
        raise BadInput("capsule length_m is end to end, caps included: it must be at least 2 x radius_m")
    out = []
    for r, L, m, xy, yaw in zip(radius, length, mass, np.atleast_2d(center_xy_m), np.atleast_1d(yaw_rad)):
        out.append(rigid_sink(cells, "capsule", (r, max(L - 2 * r, 0.0)), float(m), xy, float(yaw)).sink_m)
    return np.array(out)
