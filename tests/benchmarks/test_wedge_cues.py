"""The wedge-cue diagnostics' image measures against images whose answers are known."""

import numpy as np
import pytest

from benchmarks.bench_wedge_cues import region_widths, squeeze_across
from pressurepose.mat import MatSpec

MAT = MatSpec("test", 64, 27, 0.028, 0.028)


def _body(width_cols: int, rows=(4, 60), centre: float = 13.0, value: float = 20.0) -> np.ndarray:
    img = np.zeros((64, 27))
    lo = int(round(centre - width_cols / 2))
    img[rows[0]:rows[1], lo:lo + width_cols] = value
    return img


def test_squeezing_by_one_changes_nothing_and_keeps_the_load():
    rng = np.random.default_rng(0)
    x = rng.random((3, 64, 27)) * 30
    assert np.allclose(squeeze_across(x, 1.0), x)
    for f in (0.7, 1.3):
        y = squeeze_across(x, f)
        assert np.allclose(y.sum((1, 2)), x.sum((1, 2)))
        assert np.all(y >= 0)


def test_squeezing_narrows_a_band_about_its_centre():
    x = _body(12)[None]
    y = squeeze_across(x, 0.5)
    cols = np.arange(27)
    for img in (x[0], y[0]):
        assert (img.sum(0) @ cols) / img.sum() == pytest.approx(12.5, abs=0.3)  # the centroid stays
    assert (y[0, 30] > 1).sum() == pytest.approx(6, abs=1)  # half as wide
    assert y[0].max() == pytest.approx(2 * x[0].max(), rel=0.05)  # and twice as heavy per taxel


def test_region_widths_measure_the_run_through_the_body_axis():
    img = _body(10, centre=13.0)
    img[:, 1] = 20.0  # a separate strip (an arm away from the body) is not part of the run
    w = region_widths(img[None], MAT)
    assert w.shape == (1, 7)
    assert np.allclose(w[0, 1:6], 10 * 2.8)
    assert np.all(np.isnan(region_widths(np.zeros((1, 64, 27)), MAT)))
    faint = region_widths(_body(10, value=3.0)[None], MAT)  # under the 5 mmHg floor: no contact
    assert np.all(np.isnan(faint) | (faint == 0))


def test_squeezing_interpolates_each_row_as_np_interp_does():
    rng = np.random.default_rng(1)
    x = rng.random((2, 5, 27)) * 30
    cols = np.arange(27.0)
    for f in (0.6, 1.4):
        y = squeeze_across(x, f)
        for i, p in enumerate(x):
            axis = (p.sum(0) @ cols) / p.sum()
            ref = np.stack([np.interp(axis + (cols - axis) / f, cols, row, left=0.0, right=0.0) for row in p])
            assert np.allclose(y[i], ref * p.sum() / ref.sum())
