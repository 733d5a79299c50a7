"""Does an input image look like a person lying on the mat? A check before anyone reads an estimate.

PressureNet returns a body for any image, also for sensor noise, an empty mat or a box. The check
here reads the image alone, in the model's units (mmHg on the model's mat, after the road every real
recording takes: :meth:`pressurepose.data.readers.images.RealImages.model_input`), with four
statistics of its load above the contact floor (:data:`CONTACT_FLOOR_MMHG`; readings at or below it
count as 0, as the model drops them):

* ``loaded_share``: the share of the mat's taxels that read above the floor;
* ``length_m``: how far along the bed the load reaches: the rows between the 1 % and the 99 % points
  of the load's distribution along the bed, times the row pitch (a few stray taxels do not stretch it);
* ``peak_over_mean``: the highest reading over the mean reading of the loaded taxels (a body presses
  hardest under its bones; a box or a uniform reading presses evenly);
* ``smoothness``: the correlation of each taxel's reading with its neighbour's, across and along the
  bed (a body's load changes gradually from taxel to taxel; sensor noise does not).

:func:`image_stats` measures them; :func:`check_plausible` compares them with thresholds measured
on real and simulated bodies and on images that are not a body (the constants below;
docs/real-mats.md) and says, per image, whether it looks like a lying person and if not why.
"""

from __future__ import annotations

import enum
from dataclasses import dataclass

import numpy as np

from pressurepose.errors import BadInput, require_non_negative
from pressurepose.mat import MatSpec

# Contact: readings above the shipped model's contact floor (InputConfig.contact_floor_mmhg), below
# which it drops readings. The thresholds below were measured with it, on the shipped model's mat
# (BodiTrak BT3510, 64 x 27 taxels of 2.86 cm) and hold for the image, whatever model reads it.
CONTACT_FLOOR_MMHG = 5.0
# Correlation of neighbouring taxels' readings (the pairs (r, c)-(r, c+1) and (r, c)-(r+1, c) pooled,
# readings at or below the floor as 0). Measured: PMD experiment I 0.669-0.924 (flat-bed frames),
# 0.720-0.917 (inclined); simulated 0.745-0.921. Not a body: uniform noise on the model's mat
# -0.05-0.07, in mmHg or raw and weight-normalised to 70 kg through the reading road (where its
# loaded share, 0.35-0.37, looks like a body's); noise on PMD's FSA mat resampled onto the model's
# (which smooths it) 0.16-0.34. The bound lies 0.17 under the real minimum and 0.16 over the noise.
MIN_SMOOTHNESS = 0.5
# Share of the mat's taxels above the floor. Measured: PhysioNet PMD experiment I, 0.156-0.348 over
# its 2,178 flat-bed frames (0.160-0.314 on its 468 inclined-bed frames); simulated bodies
# (`generate`, partitions general and general_lateral, f and m, 30 each, seed 7) 0.102-0.301. Not a
# body: load on 1-20 scattered taxels 0.001-0.012, a 0.29 x 0.23 m block 0.046, uniform noise of
# 0-10 / 0-20 / 0-100 mmHg 0.47-0.52 / 0.74-0.78 / 0.94-0.96, a real body plus 0-20 mmHg noise
# 0.83-0.87, a constant image 1. The bounds lie at half the simulated minimum and 0.10 above the
# real maximum (the sparsest noise, 0-10 mmHg, is 0.12 above it).
MIN_LOADED_SHARE = 0.05
MAX_LOADED_SHARE = 0.45
# Length along the bed holding the middle 98 % of the load. Measured: PMD experiment I 1.00-1.77 m
# (flat-bed frames); simulated 0.77-1.83 m (the shortest a curled side-lying body; 1 % of them under
# 0.86 m). Not a body: the pelvis and thigh rows of real images alone (as a person sitting loads
# the mat) 0.23-0.40 m, a block 0.5 m long 0.51 m. The bound lies 0.17 m under the simulated
# minimum and 0.2 m over the sitting images.
MIN_LENGTH_M = 0.6
# Peak reading over the mean reading of the loaded taxels. Measured: PMD experiment I 2.84-8.16;
# simulated 2.05-5.52. Not a body: a block or a constant image 1.0, uniform noise 0-20 mmHg
# 1.58-1.63 (caught by its loaded share), 0-100 mmHg 1.86-1.99 (likewise). The bound lies 0.55 under
# the simulated minimum.
MIN_PEAK_OVER_MEAN = 1.5
_TAIL = 0.01  # share of the load left out at each end of the bed when measuring its length


class Doubt(enum.Enum):
    """Why an image does not look like a person lying on the mat (checked in this order)."""

    EMPTY = enum.auto()       # nothing reads above the floor
    TOO_LITTLE = enum.auto()  # too few taxels loaded
    TOO_SPREAD = enum.auto()  # too many taxels loaded
    NOISY = enum.auto()       # neighbouring taxels read unrelated values
    TOO_SHORT = enum.auto()   # the load reaches too short a way along the bed
    TOO_EVEN = enum.auto()    # the load is nearly even over its taxels


@dataclass(frozen=True)
class ImageStats:
    """Statistics of B images (module doc), each (B,) float64: loaded_share (share of the mat's
    taxels above the floor), length_m (metres along the bed holding the middle 98 % of the load),
    peak_mmhg (highest reading), mean_mmhg (mean reading of the taxels above the floor; 0 where there
    are none), smoothness (correlation of neighbouring taxels' readings, -1..1; 0 where the readings
    do not vary) and loaded (count of taxels above the floor)."""

    loaded_share: np.ndarray
    length_m: np.ndarray
    smoothness: np.ndarray
    peak_mmhg: np.ndarray
    mean_mmhg: np.ndarray
    loaded: np.ndarray

    def __len__(self) -> int:
        return int(len(self.loaded_share))

    @property
    def peak_over_mean(self) -> np.ndarray:
        """(B,) peak reading over the mean reading of the loaded taxels (0 where none is loaded)."""
        return np.divide(self.peak_mmhg, self.mean_mmhg, out=np.zeros(len(self)), where=self.mean_mmhg > 0)


def _images(pressure) -> np.ndarray:
    """(B, R, C) float64 readings, checked: BadInput for NaN, infinite or negative ones."""
    arr = np.asarray(pressure, dtype=np.float64)
    if not np.all(np.isfinite(arr)) or np.any(arr < 0):
        raise BadInput("images hold NaN, infinite or negative readings; expected pressures >= 0 (mmHg)")
    return arr


def neighbour_correlation(images: np.ndarray) -> np.ndarray:
    """(B,) Pearson correlation of each image's (B, R, C) readings with their neighbours' across
    (r, c)-(r, c+1) and along (r, c)-(r+1, c) the bed, both kinds of pair pooled; 0 where it is
    undefined (readings that do not vary)."""
    B = len(images)
    a = np.concatenate([images[:, :, :-1].reshape(B, -1), images[:, :-1, :].reshape(B, -1)], axis=1)
    b = np.concatenate([images[:, :, 1:].reshape(B, -1), images[:, 1:, :].reshape(B, -1)], axis=1)
    a = a - a.mean(1, keepdims=True)
    b = b - b.mean(1, keepdims=True)
    norm = np.sqrt((a * a).sum(1) * (b * b).sum(1))
    return np.divide((a * b).sum(1), norm, out=np.zeros(B), where=norm > 0)


_CHUNK = 1024  # images measured at a time (bounded memory on a night of frames)


def image_stats(pressure, mat: MatSpec, floor_mmhg: float = CONTACT_FLOOR_MMHG) -> ImageStats:
    """:class:`ImageStats` of images (B, R, C) or (R, C), mmHg on ``mat`` (its row pitch gives the
    length); contact: readings above ``floor_mmhg``. Measured :data:`_CHUNK` images at a time."""
    require_non_negative("contact floor (mmHg)", floor_mmhg)
    given = np.asarray(pressure)
    given = given[None] if given.ndim == 2 else given
    if given.ndim != 3 or given.shape[1:] != mat.shape or given.dtype.kind not in "fiub":
        raise BadInput(f"images of shape {np.shape(pressure)} ({given.dtype}): expected ({mat.rows}, {mat.cols}) or "
                       f"(B, {mat.rows}, {mat.cols}) readings (mmHg) on the mat {mat.name!r}")
    parts = [_chunk_stats(_images(given[s:s + _CHUNK]), mat, floor_mmhg)
             for s in range(0, max(len(given), 1), _CHUNK)]
    return ImageStats(**{k: np.concatenate([getattr(p, k) for p in parts]) for k in ImageStats.__dataclass_fields__})


def _chunk_stats(arr: np.ndarray, mat: MatSpec, floor_mmhg: float) -> ImageStats:
    load = np.where(arr > floor_mmhg, arr, 0.0)
    loaded = (load > 0).sum((1, 2)).astype(np.float64)
    total = load.sum((1, 2))
    along = np.cumsum(load.sum(2), axis=1) / np.where(total > 0, total, 1.0)[:, None]  # (B, R) share up to each row
    first = (along < _TAIL).sum(1)            # the row where the load passes 1 %
    last = (along < 1.0 - _TAIL).sum(1)       # the row where it passes 99 %
    length = np.where(total > 0, (last - first + 1) * mat.pitch_row_m, 0.0)
    return ImageStats(loaded_share=loaded / (mat.rows * mat.cols), length_m=length.astype(np.float64),
                      smoothness=neighbour_correlation(load), peak_mmhg=arr.max((1, 2), initial=0.0),
                      mean_mmhg=np.divide(total, loaded, out=np.zeros_like(total), where=loaded > 0), loaded=loaded)


@dataclass(frozen=True)
class Plausibility:
    """Per image of a batch of B: whether it looks like a person lying on the mat.

    doubt: (B,) a :class:`Doubt` where the image does not, None where it does; reason: (B,) the
    doubt in words ('' where there is none); stats: the :class:`ImageStats` the verdict rests on.
    """

    doubt: tuple[Doubt | None, ...]
    reason: tuple[str, ...]
    stats: ImageStats

    def __len__(self) -> int:
        return len(self.doubt)

    @property
    def ok(self) -> np.ndarray:
        """(B,) bool: True where the image looks like a person lying on the mat."""
        return np.array([d is None for d in self.doubt], dtype=bool)

    @property
    def doubtful(self) -> np.ndarray:
        """Indices of the images that do not look like a person lying on the mat."""
        return np.flatnonzero(~self.ok)

    def record(self, i: int) -> dict:
        """{"plausible": bool} for image ``i``, with "doubt": the reason in words where it is False."""
        return {"plausible": True} if self.doubt[i] is None else {"plausible": False, "doubt": self.reason[i]}


def _doubt(share: float, loaded: float, length: float, ratio: float, smooth: float) -> tuple[Doubt | None, str]:
    """The first doubt about one image's statistics and its sentence (None, '' when there is none)."""
    if loaded == 0:
        return Doubt.EMPTY, (f"the mat reads no load above {CONTACT_FLOOR_MMHG:g} mmHg: nobody lies on it")
    if share < MIN_LOADED_SHARE:
        return Doubt.TOO_LITTLE, (f"only {loaded:.0f} taxels ({100 * share:.1f} % of the mat) carry load, where a "
                                  f"person lying down loads at least {100 * MIN_LOADED_SHARE:.0f} %: nobody lies on "
                                  f"the mat, or only a small object")
    if share > MAX_LOADED_SHARE:
        return Doubt.TOO_SPREAD, (f"{100 * share:.0f} % of the mat carries load, where a person lying down loads at "
                                  f"most about 35 %: sensor noise, a uniform reading or something covering the mat")
    if smooth < MIN_SMOOTHNESS:
        return Doubt.NOISY, (f"neighbouring taxels read unrelated values (correlation {smooth:.2f}, where a person's "
                             f"image gives 0.67 or more): sensor noise, not a person")
    if length < MIN_LENGTH_M:
        return Doubt.TOO_SHORT, (f"the load reaches only {length:.2f} m along the bed, where a person lying down "
                                 f"reaches 0.8 m or more: a person sitting, or an object")
    if ratio < MIN_PEAK_OVER_MEAN:
        return Doubt.TOO_EVEN, (f"the load is nearly even (the highest reading {ratio:.1f} times the mean), where a "
                                f"person's load peaks at twice the mean or more under the bones: an object or a "
                                f"uniform reading")
    return None, ""


def check_plausible(pressure, mat: MatSpec) -> Plausibility:
    """Whether each image (B, R, C) or (R, C), mmHg on ``mat`` (a model's input: after
    :meth:`~pressurepose.data.readers.images.RealImages.model_input` for a real recording), looks
    like a person lying on the mat, by the thresholds of this module; the first failed check is
    the image's doubt (:class:`Doubt`, in the order of its members)."""
    stats = image_stats(pressure, mat)
    found = [_doubt(*v) for v in zip(stats.loaded_share.tolist(), stats.loaded.tolist(), stats.length_m.tolist(),
                                      stats.peak_over_mean.tolist(), stats.smoothness.tolist())]
    return Plausibility(doubt=tuple(d for d, _ in found), reason=tuple(r for _, r in found), stats=stats)
