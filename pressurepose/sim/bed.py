"""The bed: a mattress, the pressure mat on it, and every physical constant of both.

Frames and grids (all metres):

* **Bed frame** (shared by the whole project): origin at the head-end, left corner of the mat's
  *sensing area*, on the top surface of the unloaded mattress; x across the bed (along the mat's
  columns), y along the bed toward the foot (along the rows, row 0 at the head), z up. Taxel
  ``(r, c)`` covers ``x in [c, c+1) * pitch_col_m``, ``y in [r, r+1) * pitch_row_m``.
* **Simulated mat** ("full grid"): the sensing grid extended by whole taxels until it covers the
  mattress (``round(border / pitch)`` taxels on each side), as in the paper (appendix A.3: the
  synthetic mat covers the bed, only the inner sensing area is recorded). For the BodiTrak on a
  twin XL mattress it is 72 x 35 taxels. Both simulations load the bed over this grid.

The foundation is a Pasternak (two-parameter) elastic foundation: pressure = ``k_A * w`` plus a
shear layer of stiffness ``G`` that couples neighbouring points (energy ``G/2 |grad w|^2``). On a
grid of cells of size ``dx x dy`` that is one vertical spring ``k_A dx dy`` per cell and springs
``G dy/dx`` (x neighbours) and ``G dx/dy`` (y neighbours) between neighbouring cells, which is what
:meth:`BedSpec.cell_springs` returns for a dynamic (MuJoCo) model of the same bed.
"""

from __future__ import annotations

import dataclasses
import math
from dataclasses import dataclass

import numpy as np

from pressurepose.errors import (
    BadInput,
    require_finite,
    require_non_negative,
    require_positive,
)
from pressurepose.mat import DEFAULT_MAT, MatSpec, get_mat

INCH = 0.0254
# a mattress side longer than this is no bed; press cells finer than this cost memory and add nothing
MAX_MATTRESS_M = 5.0
MIN_PRESS_CELL_M = 0.001
# Soft tissue's Young's modulus (Pa) for the press; see docs/physics.md for how it was chosen.
TISSUE_MODULUS_PA = 3.0e3
# The press's bones by body part: each part's bone is a core of this fraction of the mean body's
# capsule radius (pressurepose.sim.tissue gives the anatomy behind each default).
BONE_PARTS = ("pelvis", "spine", "shoulder", "neck", "head", "thigh", "calf", "foot", "upper_arm", "forearm", "hand")
TISSUE_BONE_FRACTION = (0.6, 0.7, 0.85, 0.6, 0.93, 0.25, 0.35, 0.6, 0.45, 0.55, 0.6)


def bone_fractions(value) -> tuple[float, ...]:
    """A complete tuple of bone fractions (BONE_PARTS order) from a tuple of all or a dict of some."""
    if isinstance(value, dict):
        unknown = sorted(set(value) - set(BONE_PARTS))
        if unknown:
            raise BadInput(f"bed tissue_bone_fraction has unknown parts {unknown}; expected some of "
                           f"{', '.join(BONE_PARTS)}")
        value = tuple(value.get(k, d) for k, d in zip(BONE_PARTS, TISSUE_BONE_FRACTION))
    try:
        out = tuple(value)
    except TypeError:
        raise BadInput(f"bed tissue_bone_fraction is {value!r}; expected {len(BONE_PARTS)} fractions "
                       f"({', '.join(BONE_PARTS)}) or a dict of some") from None
    if len(out) != len(BONE_PARTS):
        raise BadInput(f"bed tissue_bone_fraction has {len(out)} values; expected {len(BONE_PARTS)} "
                       f"({', '.join(BONE_PARTS)})")
    for k, v in zip(BONE_PARTS, out):
        require_finite(f"bed tissue_bone_fraction {k}", v)
        if not 0 < v <= 1:
            raise BadInput(f"bed tissue_bone_fraction {k} is {v!r}; expected a fraction of the capsule's "
                           f"radius in (0, 1]")
    return tuple(float(v) for v in out)


@dataclass(frozen=True)
class BedSpec:
    """The mattress, the mat on it and the constants of the foundation and the sensor.

    Parameters
    ----------
    mat: the pressure mat (default the BodiTrak BT-3510).
    mattress_width_m, mattress_length_m, mattress_thickness_m: twin XL (39 x 80 in) foam
        mattress, 8 in thick.
    mat_offset_m: (x, y) of the sensing area's head-left corner measured from the mattress's
        head-left corner; ``None`` centres the sensing area on the mattress.
    stiffness_n_m3: the foundation's Winkler modulus k_A (pressure per unit sink), N/m^3.
    coupling_n_m: the Pasternak shear stiffness G that couples neighbouring points, N/m
        (0 = plain Winkler). sqrt(G / k_A) is the length over which a dent spreads.
    damping_s: damping of the foundation as a time constant, damping per area = k_A * damping_s
        (for the dynamic settle; the quasi-static press ignores it).
    friction: Coulomb friction between body and sheet.
    sensor_c0, sensor_c1, sensor_c2: the taxel's quadratic law u = c2 x^2 + c1 x + c0 of its
        mean contact pressure x (mmHg), applied where the taxel carries load
        (see :mod:`pressurepose.sim.sensor`).
    press_cell_m: target size of the cells the press simulation resolves the body's lower surface
        and the foundation on; each taxel is split into ceil(pitch / press_cell_m) cells per side.
    sensor_threshold_mmhg: readings below this are 0 (a mat's noise floor; 0: none).
    tissue_modulus_pa: Young's modulus E of the body's soft tissue, Pa: where the press is given
        the body's bones, the tissue of depth t over them is a spring E A / t per cell area A in
        series with the mattress (:mod:`pressurepose.sim.tissue`).
    tissue_bone_fraction: the radius of each body part's bone (:data:`BONE_PARTS` order) as a
        fraction of the mean body's capsule radius, which sets how deep the tissue over it is; give
        a tuple of all, or a dict of some parts (the rest keep :data:`TISSUE_BONE_FRACTION`).
    """

    mat: MatSpec = dataclasses.field(default_factory=lambda: get_mat(DEFAULT_MAT))
    mattress_width_m: float = 39 * INCH
    mattress_length_m: float = 80 * INCH
    mattress_thickness_m: float = 8 * INCH
    mat_offset_m: tuple[float, float] | None = None
    # fitted by `pressurepose calibrate --targets default` (docs/calibration.md)
    stiffness_n_m3: float = 9.40e4
    coupling_n_m: float = 6.24
    damping_s: float = 0.15
    friction: float = 0.5
    sensor_c0: float = 0.0
    sensor_c1: float = 1.0
    sensor_c2: float = 0.0
    press_cell_m: float = 0.01
    tissue_modulus_pa: float = TISSUE_MODULUS_PA
    sensor_threshold_mmhg: float = 0.0
    tissue_bone_fraction: tuple[float, ...] = TISSUE_BONE_FRACTION

    def __post_init__(self):
        if not isinstance(self.mat, MatSpec):
            raise BadInput(f"bed mat is {type(self.mat).__name__}; expected a MatSpec (see get_mat)")
        for field in ("mattress_width_m", "mattress_length_m", "mattress_thickness_m", "stiffness_n_m3",
                      "press_cell_m", "tissue_modulus_pa"):
            require_positive(f"bed {field}", getattr(self, field))
        for field in ("coupling_n_m", "damping_s", "friction", "sensor_threshold_mmhg"):
            require_non_negative(f"bed {field}", getattr(self, field))
        for field in ("sensor_c0", "sensor_c1", "sensor_c2"):
            require_finite(f"bed {field}", getattr(self, field))
        for field in ("mattress_width_m", "mattress_length_m", "mattress_thickness_m"):
            if getattr(self, field) > MAX_MATTRESS_M:
                raise BadInput(f"bed {field} is {getattr(self, field)!r} m; expected a bed's size, at most "
                               f"{MAX_MATTRESS_M} m")
        if not MIN_PRESS_CELL_M <= self.press_cell_m <= self.mat.pitch_row_m + self.mat.pitch_col_m:
            raise BadInput(f"bed press_cell_m is {self.press_cell_m!r} m; expected from {MIN_PRESS_CELL_M} m up to "
                           f"about the {self.mat.name} mat's taxel pitch ({self.mat.pitch_row_m} m)")
        object.__setattr__(self, "tissue_bone_fraction", bone_fractions(self.tissue_bone_fraction))
        for field in [f.name for f in dataclasses.fields(self)
                      if f.name not in ("mat", "mat_offset_m", "tissue_bone_fraction")]:
            object.__setattr__(self, field, float(getattr(self, field)))
        m = self.mat
        if m.width_m > self.mattress_width_m + 1e-9 or m.length_m > self.mattress_length_m + 1e-9:
            raise BadInput(f"the {m.name} mat's sensing area ({m.length_m:.3f} x {m.width_m:.3f} m) is larger "
                           f"than the mattress ({self.mattress_length_m:.3f} x {self.mattress_width_m:.3f} m)")
        if self.mat_offset_m is None:
            off = ((self.mattress_width_m - m.width_m) / 2, (self.mattress_length_m - m.length_m) / 2)
        else:
            try:
                off = tuple(float(v) for v in self.mat_offset_m)
            except (TypeError, ValueError):
                raise BadInput(f"bed mat_offset_m is {self.mat_offset_m!r}; expected (x, y) in metres") from None
            if len(off) != 2 or not all(math.isfinite(v) for v in off):
                raise BadInput(f"bed mat_offset_m is {self.mat_offset_m!r}; expected two finite numbers (x, y)")
            if (off[0] < -1e-9 or off[1] < -1e-9 or off[0] + m.width_m > self.mattress_width_m + 1e-9
                    or off[1] + m.length_m > self.mattress_length_m + 1e-9):
                raise BadInput(f"bed mat_offset_m {off} puts the {m.length_m:.3f} x {m.width_m:.3f} m sensing area "
                               f"partly off the {self.mattress_length_m:.3f} x {self.mattress_width_m:.3f} m mattress")
        object.__setattr__(self, "mat_offset_m", off)

    # ------------------------------------------------------------------ geometry
    @property
    def mattress_bounds(self) -> tuple[float, float, float, float]:
        """(x_min, x_max, y_min, y_max) of the mattress top in the bed frame."""
        ox, oy = self.mat_offset_m
        return (-ox, self.mattress_width_m - ox, -oy, self.mattress_length_m - oy)

    @property
    def full_grid(self) -> "FullGrid":
        """The simulated mat: the sensing grid extended by whole taxels to cover the mattress."""
        m = self.mat
        ox, oy = self.mat_offset_m
        left = int(round(ox / m.pitch_col_m))
        right = int(round((self.mattress_width_m - ox - m.width_m) / m.pitch_col_m))
        head = int(round(oy / m.pitch_row_m))
        foot = int(round((self.mattress_length_m - oy - m.length_m) / m.pitch_row_m))
        return FullGrid(rows=m.rows + head + foot, cols=m.cols + left + right, row0=head, col0=left,
                        sense_rows=m.rows, sense_cols=m.cols, pitch_row_m=m.pitch_row_m,
                        pitch_col_m=m.pitch_col_m)

    def taxel_centers(self) -> np.ndarray:
        """(rows, cols, 2) bed-frame xy of the sensing taxels' centres, metres."""
        return self.full_grid.centers()[self.full_grid.sensing_slice]

    def xy_to_taxel(self, xy) -> tuple[np.ndarray, np.ndarray]:
        """Sensing-grid (row, col) int indices of the taxels containing bed-frame points xy (..., 2).

        Points outside the sensing area get indices outside ``[0, rows) x [0, cols)``.
        """
        xy = np.asarray(xy, dtype=np.float64)
        if xy.shape[-1:] != (2,):
            raise BadInput(f"xy has shape {xy.shape}; expected (..., 2) bed-frame x, y in metres")
        col = np.floor(xy[..., 0] / self.mat.pitch_col_m).astype(np.int64)
        row = np.floor(xy[..., 1] / self.mat.pitch_row_m).astype(np.int64)
        return row, col

    # ------------------------------------------------------------------ physics
    def cell_springs(self, cell_x_m: float | None = None, cell_y_m: float | None = None) -> dict[str, float]:
        """Spring constants of this foundation on a grid of cells (default: one cell per taxel).

        Returns ``vertical`` (k_A dx dy, N/m per cell), ``damping`` (N s/m per cell),
        ``coupling_x`` / ``coupling_y`` (N/m between neighbouring cells along x / y), ``friction``.
        """
        dx = self.mat.pitch_col_m if cell_x_m is None else float(cell_x_m)
        dy = self.mat.pitch_row_m if cell_y_m is None else float(cell_y_m)
        require_positive("cell_x_m", dx)
        require_positive("cell_y_m", dy)
        k = self.stiffness_n_m3 * dx * dy
        return {"vertical": k, "damping": k * self.damping_s, "coupling_x": self.coupling_n_m * dy / dx,
                "coupling_y": self.coupling_n_m * dx / dy, "friction": self.friction}

    @property
    def spread_length_m(self) -> float:
        """sqrt(G / k_A): the distance over which the foundation spreads a dent (0 for Winkler)."""
        return math.sqrt(self.coupling_n_m / self.stiffness_n_m3)

    # ------------------------------------------------------------------ records
    def to_dict(self) -> dict:
        """Plain JSON-ready dict (mat included)."""
        d = dataclasses.asdict(self)
        d["mat_offset_m"] = list(self.mat_offset_m)
        d["tissue_bone_fraction"] = dict(zip(BONE_PARTS, self.tissue_bone_fraction))
        return d

    @staticmethod
    def from_dict(d: dict) -> "BedSpec":
        """Inverse of :meth:`to_dict`; BadInput for unknown or missing fields."""
        if not isinstance(d, dict) or not isinstance(d.get("mat"), dict):
            raise BadInput("bed record must be a dict with a 'mat' dict (see BedSpec.to_dict)")
        known_mat = {f.name for f in dataclasses.fields(MatSpec)}
        known_bed = {f.name for f in dataclasses.fields(BedSpec)}
        bad = set(d["mat"]) - known_mat | set(d) - known_bed
        if bad:
            raise BadInput(f"bed record has unknown fields {sorted(bad)}")
        missing = sorted(known_bed - set(d))
        if missing:
            raise BadInput(f"bed record lacks {', '.join(missing)}; expected every field of a bed "
                           f"(BedSpec.to_dict, or a `pressurepose calibrate --out` file)")
        try:
            mat = MatSpec(**d["mat"])
            rest = {k: v for k, v in d.items() if k != "mat"}
            if rest.get("mat_offset_m") is not None:
                rest["mat_offset_m"] = tuple(rest["mat_offset_m"])
            return BedSpec(mat=mat, **rest)
        except TypeError as exc:
            raise BadInput(f"bed record is incomplete or malformed: {exc}") from None


@dataclass(frozen=True)
class FullGrid:
    """The simulated mat's taxel grid; its sensing area is ``sense_rows x sense_cols`` taxels
    starting at (row0, col0)."""

    rows: int
    cols: int
    row0: int
    col0: int
    sense_rows: int
    sense_cols: int
    pitch_row_m: float
    pitch_col_m: float

    @property
    def origin_xy(self) -> tuple[float, float]:
        """Bed-frame (x, y) of the grid's head-left corner."""
        return (-self.col0 * self.pitch_col_m, -self.row0 * self.pitch_row_m)

    @property
    def sensing_slice(self) -> tuple[slice, slice]:
        """Index of the sensing area in arrays over this grid (rows, cols, ...)."""
        return (slice(self.row0, self.row0 + self.sense_rows), slice(self.col0, self.col0 + self.sense_cols))

    def centers(self) -> np.ndarray:
        """(rows, cols, 2) bed-frame xy of every cell centre."""
        x0, y0 = self.origin_xy
        x = x0 + (np.arange(self.cols) + 0.5) * self.pitch_col_m
        y = y0 + (np.arange(self.rows) + 0.5) * self.pitch_row_m
        return np.stack(np.meshgrid(x, y), axis=-1)


def load_bed(path) -> BedSpec:
    """The bed in a JSON file: the ``bed`` record written by ``pressurepose calibrate --out FILE``,
    or a bare :meth:`BedSpec.to_dict` record."""
    import json
    from pathlib import Path

    p = Path(path)
    try:
        record = json.loads(p.read_text())
    except FileNotFoundError:
        raise BadInput(f"bed file {str(p)!r} does not exist") from None
    except (OSError, UnicodeDecodeError, json.JSONDecodeError) as exc:
        raise BadInput(f"bed file {str(p)!r} is not readable JSON ({exc})") from None
    if isinstance(record, dict) and isinstance(record.get("bed"), dict):
        record = record["bed"]
    if not isinstance(record, dict) or not isinstance(record.get("mat"), dict):
        raise BadInput(f"bed file {str(p)!r} holds no bed record (write one with pressurepose calibrate, "
                       f"or BedSpec.to_dict)")
    try:
        return BedSpec.from_dict(record)
    except BadInput as exc:
        raise BadInput(f"bed file {str(p)!r}: {exc}") from None


def bed_for(mat: str | MatSpec | None = None, bed_file=None) -> BedSpec:
    """The bed of a command line: the one in ``bed_file`` (:func:`load_bed`) whose mat must then be
    ``mat`` where both are given, else the default bed carrying ``mat`` (a preset's name, default
    :data:`DEFAULT_MAT`, or any MatSpec)."""
    spec = get_mat(DEFAULT_MAT if mat is None else mat) if not isinstance(mat, MatSpec) else mat
    if bed_file is None:
        return BedSpec(mat=spec)
    bed = load_bed(bed_file)
    if mat is not None and spec != bed.mat:
        raise BadInput(f"--mat {spec.name} ({spec.rows} x {spec.cols}) but the bed in {bed_file} carries the "
                       f"{bed.mat.name} mat ({bed.mat.rows} x {bed.mat.cols}); drop --mat or give the bed of that mat")
    return bed


def get_bed(name: str = DEFAULT_MAT, **overrides) -> BedSpec:
    """The default bed carrying the named mat preset, with any BedSpec fields overridden."""
    try:
        return BedSpec(mat=get_mat(name), **overrides)
    except TypeError as exc:
        raise BadInput(f"get_bed: {exc}") from None
