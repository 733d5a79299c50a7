"""The image perturbations and statistics of benchmarks/bench_sim_to_real.py, on images whose answer is
known by construction."""

import numpy as np
import pytest

from benchmarks.bench_sim_to_real import (
    MMHG_PA,
    G,
    blur,
    gamma,
    halo,
    image_stats,
    round_trip,
    shift_rows,
    stretch_rows,
    threshold,
    weight_scaled,
)
from pressurepose.mat import get_mat

PITCH = (0.0286, 0.0286)


def block(rows=(10, 40), cols=(8, 19), value=20.0):
    """(1, 64, 27) image: a uniform rectangle of pressure."""
    x = np.zeros((1, 64, 27), np.float32)
    x[0, rows[0]:rows[1], cols[0]:cols[1]] = value
    return x


def test_halo_grows_contact_by_a_ring_and_keeps_the_pressure():
    x = block()
    y = halo(x, 1, level=0.01)
    assert (y > 0).sum() == 32 * 13 - 4  # 30 x 11 grown by one taxel to each side (4-neighbour: no corners)
    np.testing.assert_array_equal(y[x > 0], x[x > 0])
    assert np.allclose(y[(y > 0) & (x == 0)], 0.01)
    assert (halo(x, 0) > 0).all()


def test_shift_rows_moves_the_load_and_keeps_it_when_nothing_leaves():
    x = block()
    for k in (4, -4):
        y = shift_rows(x, k)
        assert y.sum() == pytest.approx(x.sum())
        rows = np.nonzero(y[0].sum(1))[0]
        assert (rows[0], rows[-1]) == (10 + k, 39 + k)
    assert shift_rows(block(rows=(60, 64)), 4).sum() == 0  # pushed off the mat's end


def test_stretch_rows_lengthens_about_the_centroid_and_keeps_the_total():
    x = block(rows=(20, 40))
    np.testing.assert_allclose(stretch_rows(x, 1.0), x, atol=1e-5)
    y = stretch_rows(x, 1.2)
    assert y.sum() == pytest.approx(x.sum(), rel=0.02)
    rows = np.nonzero(y[0].sum(1) > 1e-6)[0]
    assert 24 <= rows[-1] - rows[0] + 1 <= 26  # 20 rows x 1.2, plus linear interpolation's edge rows


def test_threshold_gamma_and_blur_keep_what_they_promise():
    x = block()
    x[0, 20, 10] = 3.0
    assert (threshold(x, 5.0) > 0).sum() == (x > 5).sum()
    for y in (gamma(x, 1.5), blur(x, 1.0, keep_contact=True)):
        np.testing.assert_array_equal(y > 0, x > 0)
        assert y.sum() == pytest.approx(x.sum(), rel=1e-5)
    grown = blur(x, 1.0, keep_contact=False)
    assert (grown > 0).sum() > (x > 0).sum()
    assert grown.sum() == pytest.approx(x.sum(), rel=1e-4)


def test_round_trip_keeps_force_and_grows_contact_at_most_two_taxels():
    x = block()
    bt = get_mat("boditrak_bt3510")
    y = round_trip(x, np.array([70.0]), bt, full=False)
    assert y.sum() == pytest.approx(x.sum(), rel=1e-5)
    assert (y > 0).sum() > (x > 0).sum()
    assert not (y[0, :7] > 0).any() and not (y[0, 43:] > 0).any()
    full = round_trip(x, np.array([70.0]), bt, full=True)  # weight-normalised: carries 70 kg
    assert full.sum() * bt.taxel_area_m2 * MMHG_PA == pytest.approx(70 * G, rel=1e-4)


def test_image_stats_of_a_rectangle():
    x = block(rows=(10, 40), cols=(8, 19))
    w = np.array([60.0])
    scaled = weight_scaled(x, w, PITCH)
    assert scaled.sum() * PITCH[0] * PITCH[1] * MMHG_PA == pytest.approx(60 * G)
    st = image_stats(x, w, np.array([1.0]), PITCH)
    assert st["contact_any"][0] == 30 * 11
    assert (st["first_row"][0], st["last_row"][0], st["width_cols"][0]) == (10, 39, 11)
    assert st["centroid_row"][0] == pytest.approx(24.5)
    assert st["height_minus_extent_cm"][0] == pytest.approx(100 * (1.0 - 30 * PITCH[0]))
    assert st["bottom_share"][0] == 0 and st["peak_to_mean"][0] == pytest.approx(1.0)
