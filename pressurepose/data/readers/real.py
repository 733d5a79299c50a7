"""Real pressure images with their labels, from any supported folder layout.

``read_real(folder)`` detects the layout and returns :class:`RealImages`:

* PhysioNet PMD experiment I (``subject-info-i.csv``, ``S<n>/<posture>.txt``) and experiment II
  (``subject-info-ii.csv``, ``S<n>/{Sponge,Air}_Mat/Matrix_*.txt``): :mod:`.pmd`;
* a generic labelled folder (``images.npy``, ``labels.csv``, ``mat.json``): :mod:`.labelled`.

Images come back as recorded (raw units or mmHg, on their own mat) but turned so that row 0 is the
head end; :func:`pressurepose.data.realprep.prepare` makes them model input.
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

import numpy as np

from pressurepose.errors import BadInput
from pressurepose.mat import MatSpec

# posture labels: 'lateral' = on either side; 'inclined' = recorded on a non-flat bed (not scored);
# '' = not known (not scored for posture)
POSTURE_LABELS = ("supine", "left", "right", "lateral", "prone", "inclined", "")
FRAME_MODES = ("one", "all")
LAYOUTS = ("pmd-i", "pmd-ii", "labelled")


@dataclass(frozen=True, eq=False)
class RealImages:
    """N real pressure images and what is known of the people on them.

    images: (N, rows, cols) float32 readings, row 0 at the head end, in ``units`` ('raw' or 'mmHg')
    on ``mat``. posture: (N,) str, one of :data:`POSTURE_LABELS` ('left' / 'right': the side the
    person lies on). detail: (N,) str, the source's own posture name. height_m, weight_kg: (N,)
    float (NaN when unknown). gender: (N,) 'f', 'm' or '' (not recorded). subject: (N,) str.
    source: (N,) str, the file each image came from. frame: (N,) int, the frame's index in its file,
    -1 for the median of the file's valid frames. layout: one of :data:`LAYOUTS`.
    gain: mmHg per raw unit from a calibration, or None (then raw images are weight-normalised).
    """

    images: np.ndarray
    posture: np.ndarray
    detail: np.ndarray
    height_m: np.ndarray
    weight_kg: np.ndarray
    gender: np.ndarray
    subject: np.ndarray
    source: np.ndarray
    frame: np.ndarray
    mat: MatSpec
    units: str
    layout: str
    gain: float | None = None

    def __len__(self) -> int:
        return int(self.images.shape[0])

    def select(self, keep) -> "RealImages":
        """The images where ``keep`` (N,) bool is True (or at the given indices)."""
        idx = np.arange(len(self))[keep]
        arrays = {k: getattr(self, k)[idx] for k in ("images", "posture", "detail", "height_m", "weight_kg",
                                                      "gender", "subject", "source", "frame")}
        return RealImages(**arrays, mat=self.mat, units=self.units, layout=self.layout, gain=self.gain)


def make_real(records: list[dict], mat: MatSpec, units: str, layout: str, gain: float | None = None) -> RealImages:
    """RealImages from one dict per image (keys: image, posture, detail, height_m, weight_kg,
    gender, subject, source, frame)."""
    if not records:
        raise BadInput(f"no images found ({layout} layout)")
    col = lambda k, dt=None: np.array([r[k] for r in records], dtype=dt)  # noqa: E731
    return RealImages(images=np.stack([r["image"] for r in records]).astype(np.float32), posture=col("posture", str),
                      detail=col("detail", str), height_m=col("height_m", float), weight_kg=col("weight_kg", float),
                      gender=col("gender", str), subject=col("subject", str), source=col("source", str),
                      frame=col("frame", int), mat=mat, units=units, layout=layout, gain=gain)


def detect_layout(folder: str | Path) -> str:
    """'pmd-i', 'pmd-ii' or 'labelled' for a folder; BadInput naming what each layout needs."""
    folder = Path(folder)
    if not folder.is_dir():
        raise BadInput(f"real-data folder {folder} does not exist (or is not a folder)")
    if (folder / "images.npy").is_file() or (folder / "labels.csv").is_file():
        return "labelled"
    subjects = [p for p in folder.glob("S*") if p.is_dir() and p.name[1:].isdigit()]
    if (folder / "subject-info-ii.csv").is_file() or any((s / "Air_Mat").is_dir() or (s / "Sponge_Mat").is_dir()
                                                         for s in subjects):
        return "pmd-ii"
    if (folder / "subject-info-i.csv").is_file() or any(any(s.glob("[0-9]*.txt")) for s in subjects):
        return "pmd-i"
    raise BadInput(f"{folder} is neither a PMD experiment folder (subject-info-i.csv with S<n>/<posture>.txt, or "
                   f"subject-info-ii.csv with S<n>/Air_Mat|Sponge_Mat/Matrix_*.txt) nor a labelled folder "
                   f"(images.npy, labels.csv, mat.json)")


def read_real(folder: str | Path, frames: str = "one") -> RealImages:
    """Read a real-data folder of any supported layout (:func:`detect_layout`).

    frames: 'one' (default) one image per recording (the median of its non-blank frames; a still
    person's frames barely differ) or 'all' (every non-blank frame). Generic folders hold one image
    per row already.
    """
    if frames not in FRAME_MODES:
        raise BadInput(f"frames {frames!r} is not known; expected one of {', '.join(FRAME_MODES)}")
    layout = detect_layout(folder)
    if layout == "labelled":
        from pressurepose.data.readers.labelled import read_labelled

        return read_labelled(folder)
    from pressurepose.data.readers import pmd

    return pmd.read_pmd_i(folder, frames) if layout == "pmd-i" else pmd.read_pmd_ii(folder)
