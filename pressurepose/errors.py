"""The one error type users see for bad input (it names the input and what was expected), checks that
raise it for numbers, and how to say which recorded settings differ."""

import math
import os
from pathlib import Path

import numpy as np


class BadInput(ValueError):
    """Raised when an input (array, file, preset name, option) is not what was expected.

    The message names the input and says what was expected, e.g.
    ``pressure image has shape (60, 27); the boditrak_bt3510 mat is 64 x 27``.
    """


def record_difference(old: dict, new: dict, most: int = 4) -> str:
    """'settle.timestep_s 0.01 -> 0.02, ...': the first ``most`` settings that differ between two
    records of settings ({part: {name: value}} or {part: value}), for messages that refuse to mix
    work done under other settings."""
    diffs = []
    for part in sorted(set(old) | set(new)):
        a, b = old.get(part, {}), new.get(part, {})
        if not isinstance(a, dict) or not isinstance(b, dict):
            if a != b:
                diffs.append(f"{part} {a!r} -> {b!r}")
            continue
        diffs += [f"{part}.{k} {a.get(k)!r} -> {b.get(k)!r}" for k in sorted(set(a) | set(b)) if a.get(k) != b.get(k)]
    return ", ".join(diffs[:most]) + (", ..." if len(diffs) > most else "")


def require_finite(name: str, v) -> None:
    """BadInput unless ``v`` is a finite real number (a bool is not)."""
    if isinstance(v, bool) or not isinstance(v, (int, float, np.integer, np.floating)) or not math.isfinite(v):
        raise BadInput(f"{name} is {v!r}; expected a finite number")


def require_numbers(name: str, v, n: int, positive: bool = False) -> tuple[float, ...]:
    """``v`` as a tuple of ``n`` floats; BadInput naming ``name`` (and the index) unless it is a
    sequence of ``n`` finite numbers (positive ones with ``positive``)."""
    if isinstance(v, (str, bytes, dict)) or not hasattr(v, "__len__") or len(v) != n:
        raise BadInput(f"{name} is {v!r:.80}; expected {n} numbers")
    for i, x in enumerate(v):
        (require_positive if positive else require_finite)(f"{name}[{i}]", x)
    return tuple(float(x) for x in v)


def require_path(name: str, v) -> Path:
    """``v`` as a Path; BadInput naming ``name`` unless it is a str or an os.PathLike (not None, a
    number, a list ...)."""
    if not isinstance(v, (str, os.PathLike)):
        raise BadInput(f"{name} is {' '.join(repr(v).split())[:80]}; expected a path (a str or pathlib.Path)")
    return Path(v)


def require_bool(name: str, v) -> bool:
    """``v`` as a bool; BadInput naming ``name`` unless it is True or False (a numpy bool too): a
    flag given as 'no', 1 or None would otherwise read as true or false by accident."""
    if not isinstance(v, (bool, np.bool_)):
        raise BadInput(f"{name} is {v!r}; expected True or False")
    return bool(v)


def require_whole(name: str, v, lo: int, hi: int | None = None) -> None:
    """BadInput unless ``v`` is a whole number (an int or numpy integer, not a bool) from ``lo`` to
    ``hi``, or ``lo`` and up when ``hi`` is None."""
    if isinstance(v, bool) or not isinstance(v, (int, np.integer)) or v < lo or (hi is not None and v > hi):
        expected = f">= {lo}" if hi is None else f"from {lo} to {hi}"
        raise BadInput(f"{name} is {v!r}; expected a whole number {expected}")


def require_positive(name: str, v) -> None:
    """BadInput unless ``v`` is a finite number > 0."""
    require_finite(name, v)
    if v <= 0:
        raise BadInput(f"{name} is {v!r}; expected a positive number")


def require_non_negative(name: str, v) -> None:
    """BadInput unless ``v`` is a finite number >= 0."""
    require_finite(name, v)
    if v < 0:
        raise BadInput(f"{name} is {v!r}; expected zero or a positive number")


def require_between(name: str, v, lo: float, hi: float) -> None:
    """BadInput unless ``v`` is a real number (not a bool) from ``lo`` to ``hi``, both included (so
    NaN and, for finite bounds, infinities are refused)."""
    if isinstance(v, bool) or not isinstance(v, (int, float, np.integer, np.floating)) or not lo <= v <= hi:
        raise BadInput(f"{name} is {v!r}; expected a number from {lo} to {hi}")


FLOAT32_MAX = float(np.finfo(np.float32).max)  # about 3.4e38: larger values become infinite in float32


def finite_float32(values, what: str) -> np.ndarray:
    """``values`` (numbers of any shape) as float32; BadInput naming ``what`` for values that are not
    numbers, NaN or infinite, or finite but beyond float32's range (which the cast would make
    infinite)."""
    arr = np.asarray(values)
    if arr.dtype.kind not in "fiub":
        raise BadInput(f"{what} holds {arr.dtype} values; expected numbers")
    if arr.dtype.kind == "f" and arr.size:
        bad = ~np.isfinite(arr)
        if bad.any():
            i = int(np.flatnonzero(bad)[0])
            at = tuple(int(k) for k in np.unravel_index(i, arr.shape))
            where = f" at index {at[0] if len(at) == 1 else at}" if at else ""
            raise BadInput(f"{what} contains NaN or infinite values ({int(bad.sum())} of {arr.size}; the first: "
                           f"{float(arr.flat[i])}{where})")
        peak = float(np.abs(arr).max())
        if peak > FLOAT32_MAX:
            raise BadInput(f"{what} holds values up to {peak:.3g}, out of range: too large for float32 (at most "
                           f"{FLOAT32_MAX:.3g})")
    return arr.astype(np.float32)
