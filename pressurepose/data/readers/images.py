"""Real pressure images with what is known of the people on them: the one type every reader returns,
and the one road from it to a model's input (:meth:`RealImages.model_input`)."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from pressurepose.data.realprep import prepare
from pressurepose.errors import BadInput, finite_float32
from pressurepose.mat import MatSpec

# posture labels: 'lateral' = on either side; 'inclined' = recorded on a non-flat bed (not scored);
# '' = not known (not scored for posture)
POSTURE_LABELS = ("supine", "left", "right", "lateral", "prone", "inclined", "")
FRAME_MODES = ("one", "all")
LAYOUTS = ("pmd-i", "pmd-ii", "labelled", "recording")
# the statures and body weights a reader takes as a person's (outside them a value is a typo or in
# another unit: a height in mm, a weight in g)
HEIGHT_RANGE_M = (0.5, 2.6)
WEIGHT_RANGE_KG = (2.0, 400.0)


def check_person(height_m: float, weight_kg: float, where: str, height_as_read: str | None = None) -> None:
    """BadInput naming ``where`` (a file, line and subject) unless the height is within
    :data:`HEIGHT_RANGE_M` and the weight within :data:`WEIGHT_RANGE_KG` (NaN is neither);
    ``height_as_read``: the height as the file gives it, with its unit, for the message."""
    lo, hi = HEIGHT_RANGE_M
    if not lo <= height_m <= hi:
        read = f" (read as {height_as_read})" if height_as_read else ""
        raise BadInput(f"{where}: height {height_m:g} m{read} is not a person's stature; expected {lo}-{hi} m")
    lo, hi = WEIGHT_RANGE_KG
    if not lo <= weight_kg <= hi:
        raise BadInput(f"{where}: weight {weight_kg:g} kg is not a person's body weight; expected {lo:g}-{hi:g} kg")


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

    def model_input(self, dst: MatSpec, zero_load=None) -> np.ndarray:
        """(N, dst.rows, dst.cols) float32 mmHg: these images as the input of a model on mat ``dst``.

        The one road from a real recording to a model (``evaluate-real``, ``realism``, ``infer`` and
        ``estimate(..., mat=...)`` all take it): the readers have chosen the frames and turned row 0
        to the head end; :func:`pressurepose.data.realprep.prepare` then removes the baseline
        (``zero_load``: the empty mat's readings, or None), repairs stuck and dead taxels, turns raw
        readings into mmHg (by ``gain``, else by each image's ``weight_kg``: its total force set to
        the body's weight), resamples onto ``dst`` keeping the force and clips to ``dst``'s range.
        """
        if self.units == "raw" and self.gain is None:
            missing = ~(np.isfinite(self.weight_kg) & (self.weight_kg > 0))
            if missing.any():
                raise BadInput(f"{int(missing.sum())} of {len(self)} raw image(s) (e.g. {self.source[missing][0]}) have no "
                               f"body weight and there is no calibration gain: raw readings become mmHg either by "
                               f"the gain (mmHg per raw unit) or by the weight, which sets the image's total load "
                               f"(sum of p x taxel area) to the body's m g")
        return prepare(self.images, self.mat, self.units, dst, weight_kg=self.weight_kg, gain=self.gain,
                       zero_load=zero_load)

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
    images = finite_float32(np.stack([r["image"] for r in records]), f"{layout} images")
    return RealImages(images=images, posture=col("posture", str),
                      detail=col("detail", str), height_m=col("height_m", float), weight_kg=col("weight_kg", float),
                      gender=col("gender", str), subject=col("subject", str), source=col("source", str),
                      frame=col("frame", int), mat=mat, units=units, layout=layout, gain=gain)
