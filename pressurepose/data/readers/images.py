"""Real pressure images with what is known of the people on them: the one type every reader returns."""

from __future__ import annotations

from dataclasses import dataclass

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
