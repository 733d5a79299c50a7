"""A generic labelled folder of real pressure images, which anyone can make from their own mat::

    images.npy   (N, rows, cols) readings, row 0 at the head end (read with allow_pickle=False)
    labels.csv   one row per image: posture (supine, left, right, lateral, prone; left / right = the
                 side the person lies on, lateral = either), height_m, weight_kg; optional gender
                 (f / m) and subject
    mat.json     {"preset": "boditrak_bt3510"} or {"rows": 64, "cols": 27, "pitch_m": 0.0286
                 (, "pitch_col_m": ..., "max_mmhg": ..., "name": ...)}, and "units": "mmHg" or "raw" (optional "gain": mmHg per
                 raw unit; raw images without a gain are weight-normalised)
"""

from __future__ import annotations

import csv
import json
import math
from pathlib import Path

import numpy as np

from pressurepose.data.readers.images import RealImages, check_person
from pressurepose.data.realprep import UNITS
from pressurepose.errors import BadInput, finite_float32
from pressurepose.files import read_npy
from pressurepose.mat import MatSpec, custom_mat, get_mat

REQUIRED = ("posture", "height_m", "weight_kg")
POSTURES = ("supine", "left", "right", "lateral", "prone")


def read_mat_record(path: str | Path) -> dict:
    """The JSON object of a ``mat.json``; BadInput when the file is missing or not a JSON object."""
    path = Path(path)
    if not path.is_file():
        raise BadInput(f"{path} does not exist; expected a mat.json with preset (or rows, cols, pitch_m) and units")
    try:
        d = json.loads(path.read_text())
    except (OSError, UnicodeError, json.JSONDecodeError) as exc:
        raise BadInput(f"{path}: not readable JSON ({exc})") from None
    if not isinstance(d, dict):
        raise BadInput(f"{path}: expected a JSON object")
    return d


def mat_of_record(d: dict, path: str | Path) -> MatSpec:
    """The mat a ``mat.json`` object (read from ``path``) names: ``preset``, or ``rows``, ``cols``,
    ``pitch_m`` and optionally ``pitch_col_m``, ``max_mmhg`` (the sensor's range, default 100) and
    ``name`` (default 'custom')."""
    try:
        if "preset" in d:
            return get_mat(d["preset"])
        if {"rows", "cols", "pitch_m"} <= set(d):
            name = d.get("name", "custom")
            if not isinstance(name, str) or not name.strip():
                raise BadInput(f"name is {name!r}; expected a word naming the mat")
            return custom_mat(d["rows"], d["cols"], d["pitch_m"], d.get("pitch_col_m"), d.get("max_mmhg", 100.0),
                              name=name)
        raise BadInput("expected 'preset' or 'rows', 'cols' and 'pitch_m'")
    except BadInput as exc:
        raise BadInput(f"{path}: unknown mat: {exc}") from None


def gain_of_record(d: dict, path: str | Path) -> float | None:
    """A ``mat.json`` object's ``gain`` (mmHg per raw unit), or None."""
    gain = d.get("gain")
    if gain is not None and (isinstance(gain, bool) or not isinstance(gain, (int, float)) or not math.isfinite(gain)
                             or gain <= 0):
        raise BadInput(f"{path}: gain is {gain!r}; expected a positive number of mmHg per raw unit")
    return None if gain is None else float(gain)


def read_mat_json(path: str | Path) -> tuple[MatSpec, str, float | None]:
    """(mat, units, gain) from a ``mat.json``."""
    d = read_mat_record(path)
    mat = mat_of_record(d, path)
    units = d.get("units")
    if units not in UNITS:
        raise BadInput(f"{path}: units is {units!r}; expected one of {', '.join(UNITS)}")
    return mat, units, gain_of_record(d, path)


def read_labels(path: str | Path) -> list[dict]:
    """Rows of ``labels.csv`` checked: posture known, height (m) and weight (kg) positive."""
    path = Path(path)
    if not path.is_file():
        raise BadInput(f"{path} does not exist; expected labels.csv with columns {', '.join(REQUIRED)}")
    try:
        with open(path, newline="", encoding="utf-8-sig") as fh:  # Excel's "CSV UTF-8" starts with a BOM
            rows = list(csv.DictReader(fh))
            fields = [f.strip() for f in (rows and rows[0].keys() or [])]
    except (OSError, UnicodeError, csv.Error) as exc:
        raise BadInput(f"{path}: not readable CSV ({exc})") from None
    if not rows:
        raise BadInput(f"{path} has no rows; expected a header and one row per image")
    missing = [c for c in REQUIRED if c not in fields]
    if missing:
        raise BadInput(f"{path} is missing column(s) {', '.join(missing)}; expected {', '.join(REQUIRED)} "
                       f"(and optionally gender, subject)")
    out = []
    for k, raw in enumerate(rows, start=2):
        row = {str(key).strip(): (v or "").strip() for key, v in raw.items() if key is not None}
        posture = row["posture"].lower()
        if posture not in POSTURES:
            raise BadInput(f"{path} line {k}: posture {row['posture']!r}; expected one of {', '.join(POSTURES)}")
        try:
            h, w = float(row["height_m"]), float(row["weight_kg"])
        except ValueError:
            raise BadInput(f"{path} line {k}: height_m and weight_kg must be numbers") from None
        check_person(h, w, f"{path} line {k}")
        g = row.get("gender", "").lower()[:1]
        if g not in ("", "f", "m"):
            raise BadInput(f"{path} line {k}: gender {row['gender']!r}; expected f or m")
        out.append(dict(posture=posture, height_m=h, weight_kg=w, gender=g,
                        subject=row.get("subject", "") or str(k - 1)))
    return out


def read_labelled(folder: str | Path) -> RealImages:
    """Read a generic labelled folder (see the module docstring)."""
    folder = Path(folder)
    mat, units, gain = read_mat_json(folder / "mat.json")
    labels = read_labels(folder / "labels.csv")
    path = folder / "images.npy"
    if not path.is_file():
        raise BadInput(f"{path} does not exist; expected (N, rows, cols) pressure images")
    images = read_npy(path, "images")
    if images.dtype.kind not in "fiu" or images.ndim != 3 or images.shape[1:] != mat.shape:
        raise BadInput(f"{path} has shape {images.shape} ({images.dtype}); its mat {mat.name} is {mat.rows} x "
                       f"{mat.cols}, expected numbers of shape (N, {mat.rows}, {mat.cols})")
    if len(images) != len(labels):
        raise BadInput(f"{path} holds {len(images)} images but {folder / 'labels.csv'} has {len(labels)} rows")
    images = finite_float32(images, str(path))
    if np.any(images < 0):
        raise BadInput(f"{path}: readings must be finite and >= 0 (min {images.min():.3g})")
    n = len(labels)
    col = lambda k: np.array([r[k] for r in labels])  # noqa: E731
    return RealImages(images=images, posture=col("posture"), detail=col("posture"),
                      height_m=col("height_m"), weight_kg=col("weight_kg"), gender=col("gender"),
                      subject=col("subject"), source=np.array([f"{path}[{i}]" for i in range(n)]),
                      frame=np.arange(n), mat=mat, units=units, layout="labelled", gain=gain)
