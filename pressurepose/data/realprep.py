"""Preprocessing real pressure-mat recordings for a model trained on simulated images.

Each step is a pure function over numpy arrays (images are ``(..., rows, cols)``, row 0 at the
head end unless a function says otherwise):

* :func:`valid_frames`: which frames of a recording carry the body (blank and start-up frames out);
* :func:`combine_frames`: one image per recording (the median of its valid frames);
* :func:`remove_baseline`: zero-load frame and per-row offsets (cross-talk streaks) removed;
* :func:`repair_taxels`: stuck-high and dead taxels replaced by their neighbours' median;
* :func:`orient`: flip so that row 0 is the head end (and optionally mirror the columns);
* :func:`to_mmhg`: raw readings to mmHg, by weight normalisation (the image carries the body's
  weight, ``sum(p) * A_taxel = m g``) or by a user's calibration gain;
* :func:`to_model_mat`: force-preserving resampling onto another mat, centred
  (:mod:`pressurepose.data.resample`);
* :func:`contact_extent_rows` and :func:`fit_pitch`: the taxel pitch of an undocumented mat from
  the head-to-heel contact extent of supine subjects of known height.

The FSA SoftFlex 2048 mat of PhysioNet PMD experiment I (64 x 32 taxels) has no documented pitch.
``FSA_PITCH_M`` was fitted by :func:`fit_pitch` on that data (``benchmarks/bench_real.py
--fit-pitch``; docs/data.md): the contact extent (first to last row with contact) of each
subject's supine images (postures 1, 8 and 9: legs straight) against the subject's height, least
squares through ``extent * pitch = height - HEAD_HEEL_OFFSET_M``. The offset is the part of the
standing height that does not press on the mat: from the vertex to the top of the occiput's
contact patch (about 6 cm; the occiput's most posterior point lies about 9-10 cm below the vertex
and its patch reaches a few cm above it), the heel's contact reaching the sole's level. Subjects
whose contact reaches the last row (feet cut off by the mat's end) are left out.

Result (13 subjects, 169-186 cm): 14 of the 39 supine images end before the last row; the fit
gives 0.02795 m (preset 0.0280 m, mat 1.79 m long), RMS residual 8.3 cm. The fit is weak: every
body spans 58-63 rows whatever its height (the extents even correlate negatively with height,
r = -0.61, as the taller subjects' heels run off the mat and head positions vary), so it amounts
to the mean of (height - offset) / extent; the offset's uncertainty (+-3 cm) moves it by
+-0.0005 m. Square taxels are assumed (the columns' pitch is not constrained by the data).
"""

from __future__ import annotations

import warnings

import numpy as np

from pressurepose.data.resample import MMHG_PA, resample_pressure
from pressurepose.errors import BadInput
from pressurepose.mat import MatSpec, get_mat

G = 9.80665                # m/s^2
HEAD_HEEL_OFFSET_M = 0.06  # standing height minus supine head-to-heel contact extent (see module doc)
FSA_PITCH_M = get_mat("fsa_softflex_2048").pitch_row_m  # fitted on PMD experiment I (module doc)
UNITS = ("raw", "mmHg")  # a recording's units: the mat's own (raw) or calibrated mmHg


def _images(images, what: str = "images", ndim_min: int = 2) -> np.ndarray:
    arr = np.asarray(images, dtype=np.float64)
    if arr.ndim < ndim_min or arr.size == 0:
        raise BadInput(f"{what} has shape {arr.shape}; expected (..., rows, cols)")
    if not np.all(np.isfinite(arr)):
        raise BadInput(f"{what} contains NaN or infinite values")
    return arr


def valid_frames(frames, low: float = 0.5, high: float = 2.0) -> np.ndarray:
    """(F,) bool: the frames of one recording (F, rows, cols) that carry the body.

    A frame is blank when it is all zero, or when its total reading lies outside ``[low, high]``
    times the median total of the non-zero frames: a person lying still loads the mat about equally
    in every frame, so a near-empty frame or a saturated start-up frame is an artefact.
    """
    f = np.asarray(frames)
    if f.ndim < 3 or f.size == 0 or f.dtype.kind not in "fiub":
        raise BadInput(f"frames have shape {f.shape} ({f.dtype}); expected numbers (..., rows, cols)")
    total = f.reshape(len(f), -1).sum(1, dtype=np.float64)  # frames as they are: no float64 copy of a night
    if not np.all(np.isfinite(total)):
        raise BadInput("frames contain NaN or infinite values")
    nonzero = total > 0
    if not nonzero.any():
        return nonzero
    med = np.median(total[nonzero])
    return nonzero & (total >= low * med) & (total <= high * med)


def combine_frames(frames, mode: str = "median") -> np.ndarray:
    """One image (rows, cols) from the valid frames of a recording (F, rows, cols): their per-taxel
    ``median`` (default; robust to a frame's glitches) or ``mean``. BadInput when none is valid."""
    f = _images(frames, "frames", 3)
    ok = valid_frames(f)
    if not ok.any():
        raise BadInput("recording has no frame carrying a body (all frames blank)")
    if mode == "median":
        return np.median(f[ok], axis=0)
    if mode == "mean":
        return f[ok].mean(0)
    raise BadInput(f"frame combination {mode!r} is not known; expected median or mean")


def remove_baseline(images, zero_load=None, row_quantile: float | None = 0.25) -> np.ndarray:
    """Readings minus the mat's zero-load output, clipped at 0.

    zero_load: (rows, cols) readings of the empty mat (or None). row_quantile: then subtract each
    row's ``row_quantile`` quantile (a lying body covers well under 75 % of a row, so this is the
    row's unloaded level; it removes the cross-talk streaks some mats show along a loaded row);
    None skips it.
    """
    p = _images(images)
    if zero_load is not None:
        z = _images(zero_load, "zero-load frame")
        if z.shape != p.shape[-2:]:
            raise BadInput(f"zero-load frame has shape {z.shape}; the images are {p.shape[-2:]}")
        p = p - z
    if row_quantile is not None:
        if not 0 <= row_quantile < 1:
            raise BadInput(f"row_quantile is {row_quantile}; expected a number in [0, 1)")
        p = p - np.clip(np.quantile(p, row_quantile, axis=-1, keepdims=True), 0, None)
    return np.clip(p, 0, None)


def _neighbours(p: np.ndarray) -> np.ndarray:
    """(8, ..., rows, cols) the 8 neighbours of every taxel (NaN beyond the edge)."""
    pad = np.pad(p, [(0, 0)] * (p.ndim - 2) + [(1, 1), (1, 1)], constant_values=np.nan)
    r, c = p.shape[-2:]
    return np.stack([pad[..., 1 + dr:1 + dr + r, 1 + dc:1 + dc + c]
                     for dr in (-1, 0, 1) for dc in (-1, 0, 1) if dr or dc])


def repair_taxels(images, stuck_factor: float = 3.0, level: float | None = None) -> np.ndarray:
    """Stuck-high and dead taxels replaced by the median of their loaded neighbours.

    A taxel is stuck high when it reads more than ``stuck_factor`` times the largest of its 8
    neighbours and more than ``level`` (default: the image's median non-zero reading); a load on
    a real mattress spreads over several taxels, so a lone spike is a sensor fault. A taxel is dead
    when it reads 0 while its 4 direct neighbours all read more than ``level``.
    """
    p = _images(images).copy()
    nb = _neighbours(p)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", RuntimeWarning)  # all-NaN neighbourhoods: no loaded neighbour
        nb_max = np.nanmax(nb, axis=0)
        loaded = np.where(nb > 0, nb, np.nan)
        nb_med = np.nan_to_num(np.nanmedian(loaded, axis=0))
    if level is None:
        flat = p.reshape(-1, *p.shape[-2:])
        lv = np.array([np.median(f[f > 0]) if (f > 0).any() else 0.0 for f in flat]).reshape(p.shape[:-2] + (1, 1))
    else:
        lv = float(level)
    stuck = (p > stuck_factor * np.nan_to_num(nb_max)) & (p > lv)
    direct = nb[[1, 3, 4, 6]]  # up, left, right, down
    dead = (p == 0) & np.all(np.nan_to_num(direct) > lv, axis=0)
    bad = stuck | dead
    p[bad] = nb_med[bad]
    return p


def orient(images, head_row0: bool = True, mirror_cols: bool = False) -> np.ndarray:
    """Images with row 0 at the head end: flipped along the rows when ``head_row0`` is False (the
    recording has the feet at row 0); ``mirror_cols`` also reverses the columns."""
    p = np.asarray(images)
    if not head_row0:
        p = p[..., ::-1, :]
    if mirror_cols:
        p = p[..., :, ::-1]
    return np.ascontiguousarray(p)


def to_mmhg(images, mat: MatSpec, weight_kg=None, gain: float | None = None) -> np.ndarray:
    """Raw readings (N, rows, cols) to mmHg.

    With ``gain`` (mmHg per raw unit, from the user's calibration): ``p * gain``. Otherwise weight
    normalisation, per image: ``p_mmHg = p * (m g) / (sum(p) * A_taxel) / 133.322``, so the image's
    total force (pressure x taxel area) equals the body's weight ``m g`` (weight_kg: one per image
    or one for all). A lying body's weight rests on the mattress, and the mat under it sees it all.
    """
    p = _images(images, ndim_min=3)
    if np.any(p < 0):
        raise BadInput("images have negative readings; remove the baseline first")
    if gain is not None:
        if not np.isfinite(gain) or gain <= 0:
            raise BadInput(f"gain is {gain!r}; expected a positive number of mmHg per raw unit")
        return p * float(gain)
    if weight_kg is None:
        raise BadInput("to convert raw readings to mmHg give the body weights (kg) or a calibration gain")
    w = np.broadcast_to(np.asarray(weight_kg, dtype=np.float64), (len(p),))
    if not np.all(np.isfinite(w) & (w > 0)):
        raise BadInput(f"body weights {w[~(np.isfinite(w) & (w > 0))][:3]} are not positive kg")
    total = p.reshape(len(p), -1).sum(1)
    if np.any(total <= 0):
        blank = np.flatnonzero(total <= 0)
        raise BadInput(f"{len(blank)} of {len(p)} images carry no load ({', '.join(map(str, blank[:10].tolist()))}"
                       f"{' ...' if len(blank) > 10 else ''}, counted from 0: every reading 0 once the baseline is "
                       f"removed, nobody on the mat), so no weight can set their load; leave them out, or give the "
                       f"mat's calibration gain instead of the weight")
    scale = w * G / (total * mat.taxel_area_m2) / MMHG_PA
    return p * scale[:, None, None]


def to_model_mat(images, src: MatSpec, dst: MatSpec) -> np.ndarray:
    """Pressure images on ``src`` resampled onto ``dst`` (same unit), centred on each other, the
    force kept where the mats overlap (:func:`pressurepose.data.resample.resample_pressure`)."""
    if src.shape == dst.shape and src.pitch_row_m == dst.pitch_row_m and src.pitch_col_m == dst.pitch_col_m:
        return _images(images).copy()
    return resample_pressure(images, src, dst, align="center")


def contact_extent_rows(image, rel_threshold: float = 0.05, min_taxels: int = 2) -> tuple[int, int]:
    """(first, last) row index with contact in one image (rows, cols): a row has contact when at
    least ``min_taxels`` taxels read more than ``rel_threshold`` times the image's 99th percentile
    of non-zero readings. (-1, -1) for an image without contact."""
    p = _images(image)
    if p.ndim != 2:
        raise BadInput(f"image has shape {p.shape}; expected one image (rows, cols)")
    nz = p[p > 0]
    if nz.size == 0:
        return (-1, -1)
    rows = np.nonzero((p > rel_threshold * np.percentile(nz, 99)).sum(1) >= min_taxels)[0]
    return (int(rows[0]), int(rows[-1])) if rows.size else (-1, -1)


def fit_pitch(extent_rows, heights_m, offset_m: float = HEAD_HEEL_OFFSET_M) -> tuple[float, float]:
    """Least-squares pitch (m) of ``extent_rows * pitch = heights_m - offset_m`` over subjects, and
    the RMS residual (m). extent_rows: (K,) contact extents in rows (last - first + 1)."""
    n = np.asarray(extent_rows, dtype=np.float64)
    h = np.asarray(heights_m, dtype=np.float64) - offset_m
    if n.shape != h.shape or n.size == 0 or np.any(n <= 0):
        raise BadInput(f"fit_pitch needs matching positive extents and heights; got {n.shape} and {h.shape}")
    pitch = float(np.dot(n, h) / np.dot(n, n))
    return pitch, float(np.sqrt(np.mean((n * pitch - h) ** 2)))


def prepare(images, mat: MatSpec, units: str, dst: MatSpec, weight_kg=None, gain: float | None = None,
            zero_load=None) -> np.ndarray:
    """Model input from real images (N, mat.rows, mat.cols), row 0 at the head: baseline removed,
    stuck and dead taxels repaired, raw units turned to mmHg (``gain``, else weight normalisation
    with ``weight_kg``), resampled onto ``dst`` keeping the force, clipped to ``dst``'s range as the
    simulated sensor is. Returns (N, dst.rows, dst.cols) float32 mmHg. Real images reach a model
    through :meth:`pressurepose.data.readers.images.RealImages.model_input`, which calls this."""
    if units not in UNITS:
        raise BadInput(f"units {units!r} is not known; expected raw or mmHg")
    p = _images(images, ndim_min=3)
    if p.shape[-2:] != mat.shape:
        raise BadInput(f"images have shape {p.shape}; the {mat.name} mat is {mat.rows} x {mat.cols}")
    p = repair_taxels(remove_baseline(p, zero_load))
    if units == "raw":
        p = to_mmhg(p, mat, weight_kg, gain)
    return np.clip(to_model_mat(p, mat, dst), 0, dst.max_mmhg).astype(np.float32)
