"""Resample pressure images from one mat's taxel grid to another's, keeping the total force.

Each source taxel's force is spread evenly over its cell; a destination taxel receives the force of
the part of every source cell it overlaps (area weighting). The weights separate into a row factor
and a column factor, so a batch is two small matrix products. The total force is kept exactly when
the destination covers the source; force falling outside the destination is lost, as it would be
on a smaller real mat. Grids are :class:`pressurepose.mat.MatSpec` (``custom_mat`` for any grid)
or preset names (``"fsa_softflex_2048"``, :data:`pressurepose.mat.MATS`).
"""

from __future__ import annotations

import numpy as np

from pressurepose.errors import BadInput
from pressurepose.mat import MatSpec, as_mat

MMHG_PA = 133.322  # pascals per mmHg


def _overlap_weights(n_src: int, pitch_src: float, off_src: float,
                     n_dst: int, pitch_dst: float, off_dst: float) -> np.ndarray:
    """(n_dst, n_src): fraction of each source cell's length lying in each destination cell."""
    s0 = off_src + pitch_src * np.arange(n_src)
    d0 = off_dst + pitch_dst * np.arange(n_dst)
    lo = np.maximum(d0[:, None], s0[None, :])
    hi = np.minimum(d0[:, None] + pitch_dst, s0[None, :] + pitch_src)
    return np.clip(hi - lo, 0.0, None) / pitch_src


def resample_weights(src: MatSpec | str, dst: MatSpec | str, align: str = "center") -> tuple[np.ndarray, np.ndarray]:
    """Row weights (dst.rows, src.rows) and column weights (dst.cols, src.cols).

    align: ``"center"`` puts both mats' centres together (two mats on the same bed), ``"corner"``
    puts their head-end corners together.
    """
    src, dst = as_mat(src, "src (the source mat)"), as_mat(dst, "dst (the destination mat)")
    if align == "center":
        oy, ox = (dst.length_m - src.length_m) / 2, (dst.width_m - src.width_m) / 2
    elif align == "corner":
        oy = ox = 0.0
    else:
        raise BadInput(f"align {align!r} is not known; expected 'center' or 'corner'")
    wr = _overlap_weights(src.rows, src.pitch_row_m, oy, dst.rows, dst.pitch_row_m, 0.0)
    wc = _overlap_weights(src.cols, src.pitch_col_m, ox, dst.cols, dst.pitch_col_m, 0.0)
    return wr, wc


def _check_images(images: np.ndarray, grid: MatSpec, what: str) -> np.ndarray:
    arr = np.asarray(images, dtype=np.float64)
    if arr.ndim < 2 or arr.shape[-2:] != grid.shape:
        raise BadInput(f"{what} has shape {arr.shape}; the {grid.name or 'source'} mat is "
                       f"{grid.rows} x {grid.cols} (expected (..., {grid.rows}, {grid.cols}))")
    if not np.all(np.isfinite(arr)):
        raise BadInput(f"{what} contains NaN or infinite values")
    if np.any(arr < 0):
        raise BadInput(f"{what} has negative values; expected >= 0")
    return arr


def resample_force(force: np.ndarray, src: MatSpec | str, dst: MatSpec | str, align: str = "center") -> np.ndarray:
    """Per-taxel forces (..., src.rows, src.cols) N -> (..., dst.rows, dst.cols) N, area-weighted.

    The sum over the destination equals the source sum minus the force outside the destination.
    """
    src = as_mat(src, "src (the source mat)")
    f = _check_images(force, src, "force image")
    wr, wc = resample_weights(src, dst, align)
    return np.einsum("rs,...sc,dc->...rd", wr, f, wc)


def resample_pressure(pressure: np.ndarray, src: MatSpec | str, dst: MatSpec | str,
                      align: str = "center") -> np.ndarray:
    """Pressure images (..., src.rows, src.cols) -> (..., dst.rows, dst.cols) in the same unit,
    resampled as forces so that the total force (pressure x taxel area) is kept."""
    src, dst = as_mat(src, "src (the source mat)"), as_mat(dst, "dst (the destination mat)")
    p = _check_images(pressure, src, "pressure image")
    return resample_force(p * src.taxel_area_m2, src, dst, align) / dst.taxel_area_m2


