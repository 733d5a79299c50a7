"""The pressure mat's geometry: one :class:`MatSpec` for the simulator, the network and the readers.

Taxel ``(r, c)`` covers ``x in [c, c+1) * pitch_col_m``, ``y in [r, r+1) * pitch_row_m`` of the bed
frame (origin at the head-end, left corner of the sensing area; x across the bed, y toward the foot;
row 0 at the head end). Presets by name (:data:`MATS`, :func:`get_mat`) or any grid (:func:`custom_mat`).
"""

from __future__ import annotations

import dataclasses
from dataclasses import dataclass

from pressurepose.errors import BadInput, require_positive, require_whole

# taxel pitches a pressure mat can have (1 mm to 0.5 m), and the most taxels a mat grid may hold
MIN_PITCH_M, MAX_PITCH_M = 0.001, 0.5
MAX_TAXELS = 1_000_000


@dataclass(frozen=True)
class MatSpec:
    """A pressure-sensing mat: a grid of ``rows x cols`` taxels.

    rows run along the bed (y, row 0 at the head end), cols across it (x). ``pitch_row_m`` is the
    taxel spacing along the bed, ``pitch_col_m`` across it. ``max_mmhg`` is the top of the
    sensor's range (readings are clipped to ``[0, max_mmhg]``).
    """

    name: str
    rows: int
    cols: int
    pitch_row_m: float
    pitch_col_m: float
    max_mmhg: float = 100.0

    def __post_init__(self):
        for field in ("rows", "cols"):
            require_whole(f"mat {field}", getattr(self, field), 1)
            object.__setattr__(self, field, int(getattr(self, field)))
        for field in ("pitch_row_m", "pitch_col_m", "max_mmhg"):
            require_positive(f"mat {field}", getattr(self, field))
            object.__setattr__(self, field, float(getattr(self, field)))
        for field in ("pitch_row_m", "pitch_col_m"):
            v = getattr(self, field)
            if not MIN_PITCH_M <= v < MAX_PITCH_M:
                raise BadInput(f"mat {field} is {v!r} m; expected a taxel pitch in metres from {MIN_PITCH_M} to "
                               f"{MAX_PITCH_M} (e.g. 0.0286)")
        if self.rows * self.cols > MAX_TAXELS:
            raise BadInput(f"mat of {self.rows} x {self.cols} taxels is larger than any pressure mat; expected at "
                           f"most {MAX_TAXELS} taxels")

    @property
    def shape(self) -> tuple[int, int]:
        return (self.rows, self.cols)

    @property
    def width_m(self) -> float:
        """Sensing-area size across the bed (x)."""
        return self.cols * self.pitch_col_m

    @property
    def length_m(self) -> float:
        """Sensing-area size along the bed (y)."""
        return self.rows * self.pitch_row_m

    @property
    def taxel_area_m2(self) -> float:
        return self.pitch_row_m * self.pitch_col_m

    @property
    def size_m(self) -> tuple[float, float]:
        """(width across x, length along y) of the sensing area, metres."""
        return (self.width_m, self.length_m)

    def same_grid(self, other: "MatSpec") -> bool:
        """True when ``other`` has this mat's rows, cols and pitches (name and range may differ)."""
        return (self.shape == other.shape and abs(self.pitch_row_m - other.pitch_row_m) < 1e-12
                and abs(self.pitch_col_m - other.pitch_col_m) < 1e-12)

    def to_dict(self) -> dict:
        """Plain JSON-ready record; :meth:`from_dict` reads it back."""
        return dataclasses.asdict(self)

    @staticmethod
    def from_dict(d: dict, name: str = "custom") -> "MatSpec":
        """A mat from its record: ``rows``, ``cols``, ``pitch_row_m``, ``pitch_col_m`` and optionally
        ``name`` (default ``name``) and ``max_mmhg``; BadInput naming unknown or missing fields."""
        if not isinstance(d, dict):
            raise BadInput(f"mat record is {type(d).__name__}; expected a dict with rows, cols, pitch_row_m, "
                           f"pitch_col_m")
        known = {f.name for f in dataclasses.fields(MatSpec)}
        unknown = sorted(set(d) - known)
        missing = sorted({"rows", "cols", "pitch_row_m", "pitch_col_m"} - set(d))
        if unknown or missing:
            raise BadInput(f"mat record has unknown fields {unknown} and lacks {missing}; expected rows, cols, "
                           f"pitch_row_m, pitch_col_m and optionally name, max_mmhg")
        return MatSpec(**{"name": name, **d})


# Public facts: BodiTrak BT-3510 (the paper, section 3: 64 x 27 taxels at 2.86 cm); the TIP bed sheet (56 x 40
# taxels at 31.1 x 19.5 mm, non-square);
# SLP: 192 x 84 taxels over about 1.92 x 0.84 m, i.e. 1 cm pitch (the BodyPressure code that reads
# SLP notes "this one is 1.92 x 0.84" and shifts its images in whole centimetres per taxel).
MATS: dict[str, MatSpec] = {
    "boditrak_bt3510": MatSpec("boditrak_bt3510", 64, 27, 0.0286, 0.0286, 100.0),
    "slp": MatSpec("slp", 192, 84, 0.010, 0.010, 100.0),
    "tip": MatSpec("tip", 56, 40, 0.0311, 0.0195, 100.0),
    # Vista Medical FSA SoftFlex 2048 (PhysioNet PMD experiment I): pitch undocumented, fitted from
    # the subjects' heights (pressurepose.data.realprep.fit_pitch; docs/data.md), square taxels assumed
    "fsa_softflex_2048": MatSpec("fsa_softflex_2048", 64, 32, 0.0280, 0.0280, 100.0),
}
DEFAULT_MAT = "boditrak_bt3510"


def get_mat(name: str) -> MatSpec:
    """A mat preset by name; BadInput listing the valid names otherwise."""
    key = str(name).strip().lower()
    if key not in MATS:
        raise BadInput(f"mat preset {name!r} is not known; expected one of {', '.join(sorted(MATS))} "
                       f"(or build one with custom_mat)")
    return MATS[key]


def as_mat(mat: MatSpec | str, what: str = "mat") -> MatSpec:
    """A :class:`MatSpec` as it is, or a preset by name (:func:`get_mat`); BadInput naming ``what``
    for anything else."""
    if isinstance(mat, MatSpec):
        return mat
    if isinstance(mat, str):
        return get_mat(mat)
    raise BadInput(f"{what} is a {type(mat).__name__}; expected a MatSpec or a preset name "
                   f"({', '.join(sorted(MATS))})")


def custom_mat(rows: int, cols: int, pitch_row_m: float, pitch_col_m: float | None = None,
               max_mmhg: float = 100.0, name: str = "custom") -> MatSpec:
    """Any grid: ``rows`` along the bed at ``pitch_row_m``, ``cols`` across at ``pitch_col_m``
    (defaults to square taxels)."""
    return MatSpec(name, rows, cols, pitch_row_m, pitch_row_m if pitch_col_m is None else pitch_col_m,
                   max_mmhg)
