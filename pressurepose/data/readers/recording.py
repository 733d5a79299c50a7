"""A bare recording from any mat, without labels: frames of one person, read as :class:`RealImages`.

``read_recording(source, mat, units, weight_kg=None, gain=None, head_row="first")`` reads

* a ``.npy`` file: one frame (rows, cols) or several (F, rows, cols), every one kept;
* a ``.csv`` file: one frame, ``rows`` lines of ``cols`` comma-separated readings;
* a text recording (``.txt``): one frame a line, ``rows * cols`` readings separated by tabs or
  spaces (PhysioNet PMD experiment I's layout; the frames that carry the body are kept, as
  ``evaluate-real --frames all`` keeps them: :func:`pressurepose.data.realprep.valid_frames`), or one
  frame as ``rows`` lines of ``cols`` readings (PMD experiment II's layout);
* a numpy array (rows, cols) or (F, rows, cols), every frame kept.

``mat`` is a preset name (:func:`pressurepose.mat.get_mat`), a ``mat.json`` (as in a labelled folder,
:mod:`.labelled`: ``preset``, or ``rows``, ``cols``, ``pitch_m`` and optionally ``pitch_col_m``;
its ``units``, if given, must agree, and its ``gain`` is used when no weight or gain is given) or
a :class:`~pressurepose.mat.MatSpec`. ``units``: 'raw' (the mat's own readings: they need the
person's ``weight_kg`` or a calibration ``gain`` to become mmHg) or 'mmHg'. ``head_row``: 'first'
when row 0 of the frames is at the head end, 'last' when it is at the feet (then the rows are
flipped). The frames then reach a model by :meth:`RealImages.model_input`.

``read_frames(source, shape)`` reads a recording over time as stored, every frame kept (blank ones
too: a timeline needs them all), from a file as above or a folder of one-frame files. Both read a
file by :func:`read_file_frames`, and keep frames in float32 (a night of 28,800 frames of a 64 x 32
mat is 236 MB).
"""

from __future__ import annotations

import re
import warnings
from pathlib import Path

import numpy as np

from pressurepose.data.readers.images import WEIGHT_RANGE_KG, RealImages
from pressurepose.data.readers.labelled import (
    gain_of_record,
    mat_of_record,
    read_mat_record,
)
from pressurepose.data.readers.pmd import read_frame_lines, read_image_lines
from pressurepose.data.realprep import UNITS, orient, valid_frames
from pressurepose.errors import BadInput, finite_float32
from pressurepose.files import read_npy
from pressurepose.mat import MATS, MatSpec, get_mat

HEAD_ROWS = ("first", "last")
RECORDING_SUFFIXES = (".npy", ".csv", ".txt")


def resolve_mat(mat) -> tuple[MatSpec, dict]:
    """(the mat, its ``mat.json`` object or {}) from a MatSpec, a preset name or a mat.json path."""
    if isinstance(mat, MatSpec):
        return mat, {}
    name = str(mat)
    if name.strip().lower() in MATS:
        return get_mat(name), {}
    path = Path(name)
    if path.suffix.lower() == ".json" or path.is_file():
        d = read_mat_record(path)
        return mat_of_record(d, path), d
    raise BadInput(f"mat {name!r} is neither a preset ({', '.join(sorted(MATS))}) nor a mat.json file")


def read_array_file(path: str | Path, what: str = "pressure") -> np.ndarray:
    """The numbers of a ``.npy`` file (any shape) or a ``.csv`` file (R rows of C comma-separated
    values, (R, C)); BadInput naming ``what`` and the file otherwise."""
    path = Path(path)
    if path.is_dir():
        raise BadInput(f"{what} file {str(path)!r} is a folder; expected a file")
    if not path.is_file():
        raise BadInput(f"{what} file {str(path)!r} does not exist")
    suffix = path.suffix.lower()
    if suffix == ".npy":
        return read_npy(path, what)
    if suffix != ".csv":
        raise BadInput(f"{what} file {str(path)!r}: expected .npy or .csv")
    try:
        with warnings.catch_warnings():  # an empty file: our error below, not numpy's warning
            warnings.simplefilter("ignore", UserWarning)
            arr = np.loadtxt(path, delimiter=",", ndmin=2)
    except (ValueError, OSError) as exc:
        raise BadInput(f"{what} file {str(path)!r} could not be read ({exc})") from None
    if arr.size == 0:
        raise BadInput(f"{what} file {str(path)!r} holds no numbers; expected R rows of C comma-separated values")
    return arr


def _text_frames(path: Path, shape: tuple[int, int]) -> np.ndarray:
    """(F, rows, cols) from a text recording: one frame a line, or one frame as rows lines."""
    try:
        with path.open(encoding="utf-8") as fh:
            first = next((ln for ln in fh if ln.strip()), "")
    except (OSError, UnicodeError) as exc:
        raise BadInput(f"{path}: cannot read as utf-8 text ({exc})") from None
    n = len(first.split())
    if n == shape[0] * shape[1]:
        return read_frame_lines(path, shape)
    if n == shape[1]:
        return read_image_lines(path, shape)[None]
    raise BadInput(f"{path}: its first line has {n} readings; for a {shape[0]} x {shape[1]} mat expected one frame a "
                   f"line ({shape[0] * shape[1]} readings) or one frame as {shape[0]} lines of {shape[1]} readings")


def read_file_frames(path: str | Path, shape: tuple[int, int], what: str = "recording") -> np.ndarray:
    """The frames of one recording file as stored, float32 (F, ...): a ``.npy`` (one frame (rows, cols)
    gets a leading axis; other shapes are returned for the caller to refuse with its own hint), a
    ``.csv`` of one frame, or a ``.txt`` of one frame a line or one frame as ``rows`` lines (PhysioNet
    PMD experiments I and II). BadInput naming ``what`` and the file for anything else, and for
    readings that are not finite numbers or are negative."""
    path = Path(path)
    suffix = path.suffix.lower()
    if path.is_dir():
        raise BadInput(f"{what} {str(path)!r} is a folder; expected a file ({', '.join(RECORDING_SUFFIXES)})")
    if suffix not in RECORDING_SUFFIXES:
        raise BadInput(f"{what} {str(path)!r}: expected {', '.join(RECORDING_SUFFIXES)}")
    if not path.is_file():
        raise BadInput(f"{what} {str(path)!r} does not exist" + (" as a file" if path.exists() else ""))
    arr = _text_frames(path, shape) if suffix == ".txt" else read_array_file(path, what)
    if not (arr.dtype == np.float32 and np.isfinite(arr.sum(dtype=np.float64))):  # else no copy
        arr = finite_float32(arr, f"{what} {str(path)!r}")
    if arr.size and arr.min() < 0:
        raise BadInput(f"{what} {str(path)!r} has negative readings (min {arr.min():.3g}); a pressure mat's "
                       f"readings are >= 0")
    return arr[None] if arr.ndim == 2 else arr


def _frames(source, shape: tuple[int, int]) -> tuple[np.ndarray, np.ndarray, str]:
    """(frames (F, rows, cols) as stored, their indices in the source, the source's name)."""
    if isinstance(source, (str, Path)):
        path = Path(source)
        stack = read_file_frames(path, shape)
        if path.suffix.lower() != ".txt" or len(stack) == 1:
            return stack, np.arange(len(stack)), str(path)
        ok = valid_frames(stack)
        if not ok.any():
            raise BadInput(f"recording {str(path)!r}: none of its {len(stack)} frames carries a body (all blank, "
                           f"or every frame's load far from the others')")
        return stack[ok], np.flatnonzero(ok), str(path)
    arr = np.asarray(source.detach().cpu() if hasattr(source, "detach") else source)
    if arr.dtype.kind not in "fiub":
        raise BadInput(f"the recording has dtype {arr.dtype}; expected numbers")
    return (arr[None] if arr.ndim == 2 else arr), np.arange(len(arr) if arr.ndim > 2 else 1), "the recording"


def read_recording(source, mat, units: str, weight_kg=None, gain: float | None = None,
                   head_row: str = "first") -> RealImages:
    """A bare recording (module docstring) as RealImages: (F, rows, cols) float32 frames, row 0 at
    the head end, in ``units`` on ``mat``; ``frame`` the index of each frame in the source, ``weight_kg``
    (F,) the person's weight (NaN when not given), ``gain`` the calibration; posture, height and
    gender unknown. BadInput for a wrong shape, NaN or negative readings, unknown units or head
    row, or raw readings with neither a weight nor a gain (nothing turns them into mmHg)."""
    if units not in UNITS:
        raise BadInput(f"units {units!r} is not known; expected raw (the mat's own readings) or mmHg")
    if head_row not in HEAD_ROWS:
        raise BadInput(f"head row {head_row!r} is not known; expected first (row 0 at the head end) or last "
                       f"(row 0 at the feet)")
    spec, record = resolve_mat(mat)
    if record.get("units") not in (None, units):
        raise BadInput(f"the recording's units are {units!r} but its mat.json says {record['units']!r}")
    if units == "mmHg" and (weight_kg is not None or gain is not None):
        raise BadInput("a weight or a gain turns raw readings into mmHg; these readings are in mmHg already "
                       "(give units raw, or leave the weight and the gain out)")
    if weight_kg is not None and gain is not None:
        raise BadInput("give the person's weight or a calibration gain, not both: each alone turns raw readings "
                       "into mmHg")
    if gain is not None and (isinstance(gain, bool) or not isinstance(gain, (int, float, np.integer, np.floating))
                             or not np.isfinite(gain) or gain <= 0):
        raise BadInput(f"gain is {gain!r}; expected a positive number of mmHg per raw unit")
    if units == "raw" and weight_kg is None and gain is None:
        gain = gain_of_record(record, mat)
        if gain is None:
            raise BadInput("raw readings need the person's weight in kg (--weight-kg, weight_kg in Python) or your "
                           "mat's calibration gain in mmHg per raw unit (--gain, gain) to become mmHg, the unit the "
                           "model reads: the weight sets each frame's total load (sum of p x taxel area) to the "
                           "body's m g")
    frames, index, name = _frames(source, spec.shape)
    if frames.ndim != 3 or frames.shape[1:] != spec.shape or len(frames) == 0:
        hint = (" (rows and columns swapped? row 0 runs across the bed at the head or the feet)"
                if frames.ndim == 3 and frames.shape[1:] == spec.shape[::-1] else "")
        got = (f"has frames of {frames.shape[1]} x {frames.shape[2]}" if frames.ndim == 3 and len(frames)
               else f"has shape {frames.shape}")  # one frame: its own shape, not the (1, R, C) it was read as
        raise BadInput(f"{name} {got}; the {spec.name} mat is {spec.rows} x {spec.cols}: expected "
                       f"({spec.rows}, {spec.cols}) or (F, {spec.rows}, {spec.cols}){hint}")
    frames = finite_float32(frames, name)
    if np.any(frames < 0):
        raise BadInput(f"{name}: readings must be finite and >= 0 (min {frames.min():.3g})")
    n = len(frames)
    if weight_kg is None:
        weight = np.full(n, np.nan)
    else:
        try:
            given = np.asarray(weight_kg)
        except ValueError:  # ragged
            given = np.asarray(None)
        if isinstance(weight_kg, (str, bytes)) or given.dtype.kind not in "iuf":  # not text, True (1 kg), a dict
            raise BadInput(f"weight_kg is {weight_kg!r:.80}; expected a positive number of kg, or one per frame ({n})")
        try:
            weight = np.broadcast_to(given.astype(np.float64), (n,)).copy()
        except ValueError:
            raise BadInput(f"weight_kg has shape {np.shape(weight_kg)}; expected one weight, or one per frame "
                           f"({n})") from None
        lo, hi = WEIGHT_RANGE_KG
        if not np.all(np.isfinite(weight) & (weight >= lo) & (weight <= hi)):
            raise BadInput(f"weight {weight_kg!r} is not a person's weight in kg; expected {lo:g} to {hi:g} kg")
    empty = lambda value: np.full(n, value)  # noqa: E731
    return RealImages(images=orient(frames, head_row0=head_row == "first"), posture=empty(""),
                      detail=empty(""), height_m=empty(np.nan), weight_kg=weight, gender=empty(""), subject=empty(""),
                      source=empty(name), frame=np.asarray(index, dtype=int), mat=spec, units=units,
                      layout="recording", gain=None if gain is None else float(gain))


# ---------------------------------------------------------------------------------------- over time
FRAME_SUFFIXES = RECORDING_SUFFIXES  # one-frame files of a folder: any recording file holding one frame


def _natural_key(path) -> list:
    return [int(tok) if tok.isdigit() else tok for tok in re.split(r"(\d+)", path.name)]


def read_frames(source, shape: tuple[int, int]) -> np.ndarray:
    """Every frame (T, rows, cols) float32 of a recording from a ``rows x cols`` mat, as stored: a
    recording file (:func:`read_file_frames`: a ``.npy`` of (T, rows, cols) or one frame, a text file
    of one frame a line as PhysioNet PMD experiment I's, or of one frame), or a folder of one-frame
    files (.npy, .csv, or .txt) in the natural order of their names (frame_2 before frame_10). No
    frame is left out: the timeline needs them all. BadInput naming the file for anything else."""
    path = Path(source)
    if path.is_dir():
        files = sorted((p for p in path.iterdir() if p.is_file() and p.suffix.lower() in FRAME_SUFFIXES),
                       key=_natural_key)
        if not files:
            raise BadInput(f"recording folder {str(path)!r} holds no frame files ({', '.join(FRAME_SUFFIXES)})")
        frames = []
        for f in files:
            img = read_file_frames(f, shape, "frame")
            if img.shape != (1, *shape):
                raise BadInput(f"frame file {str(f)!r} has shape {img.shape[1:] if len(img) == 1 else img.shape}; "
                               f"expected one {shape[0]} x {shape[1]} frame")
            frames.append(img[0])
        return np.stack(frames)
    if not path.exists():
        raise BadInput(f"recording {str(path)!r} does not exist")
    arr = read_file_frames(path, shape)
    if arr.ndim != 3 or arr.shape[1:] != tuple(shape):
        raise BadInput(f"recording {str(path)!r} has shape {arr.shape}; the mat is {shape[0]} x {shape[1]}: expected "
                       f"(T, {shape[0]}, {shape[1]}) frames")
    return arr
