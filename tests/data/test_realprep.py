"""Preprocessing of real pressure images: known answers for each step."""

import numpy as np
import pytest

from pressurepose.data import realprep as rp
from pressurepose.data.resample import MMHG_PA
from pressurepose.errors import BadInput
from pressurepose.mat import custom_mat, get_mat
from tests.data.realfolders import body_image

FSA, BT = get_mat("fsa_softflex_2048"), get_mat("boditrak_bt3510")


def test_blank_and_startup_frames_are_not_valid():
    body = body_image(64, 32)
    frames = np.stack([np.zeros_like(body), np.full_like(body, 3000.0), body, body * 1.02, body * 0.01, body])
    np.testing.assert_array_equal(rp.valid_frames(frames), [False, False, True, True, False, True])
    np.testing.assert_allclose(rp.combine_frames(frames), body)
    with pytest.raises(BadInput, match="no frame"):
        rp.combine_frames(np.zeros((3, 4, 4)))


def test_baseline_removal_recovers_the_load():
    body = body_image(64, 32)
    zero_load = np.random.default_rng(1).uniform(0, 5, body.shape)
    streaks = np.random.default_rng(2).uniform(0, 8, (64, 1))  # per-row offsets
    np.testing.assert_allclose(rp.remove_baseline(body + zero_load, zero_load), body)
    np.testing.assert_allclose(rp.remove_baseline(body + streaks), body, atol=1e-9)
    assert rp.remove_baseline(-np.ones((3, 3)), row_quantile=None).min() == 0


def test_stuck_and_dead_taxels_are_repaired():
    body = body_image(64, 32, scale=50)
    broken = body.copy()
    broken[40, 2] = 3841.0          # stuck high on the unloaded margin
    broken[20, 16] = 3841.0         # stuck high inside the trunk
    broken[30, 15] = 0.0            # dead inside the trunk
    fixed = rp.repair_taxels(broken)
    assert fixed[40, 2] == 0 and fixed[20, 16] < 1.2 * body[19:22, 15:18].max()
    assert 0.8 * body[29:32, 14:17].min() < fixed[30, 15] < 1.2 * body[29:32, 14:17].max()
    untouched = np.ones(body.shape, bool)
    untouched[[40, 20, 30], [2, 16, 15]] = False
    np.testing.assert_array_equal(fixed[untouched], body[untouched])


def test_orientation_flips():
    img = np.arange(12.0).reshape(4, 3)
    np.testing.assert_array_equal(rp.orient(img, head_row0=False), img[::-1])
    np.testing.assert_array_equal(rp.orient(img, mirror_cols=True), img[:, ::-1])
    np.testing.assert_array_equal(rp.orient(img), img)


def test_weight_normalisation_gives_the_body_weight_as_total_force():
    imgs = np.stack([body_image(64, 32, seed=s) for s in range(2)])
    p = rp.to_mmhg(imgs, FSA, weight_kg=[60.0, 90.0])
    force = p.sum((1, 2)) * MMHG_PA * FSA.taxel_area_m2
    np.testing.assert_allclose(force, np.array([60.0, 90.0]) * rp.G)
    np.testing.assert_allclose(rp.to_mmhg(imgs, FSA, gain=0.5), imgs * 0.5)
    with pytest.raises(BadInput, match="weights"):
        rp.to_mmhg(imgs, FSA)


def test_blank_images_refused_by_weight_normalisation_are_named_with_a_way_out():
    """A recording array with blank frames (nobody on the mat) cannot be weight-normalised: the message
    names them all and says what to do."""
    imgs = np.stack([np.zeros((64, 32)), body_image(64, 32), np.zeros((64, 32))])
    with pytest.raises(BadInput, match=r"2 of 3 images carry no load \(0, 2, counted from 0.*leave them out, or "
                                       r"give the mat's calibration gain"):
        rp.to_mmhg(imgs, FSA, weight_kg=70.0)
    assert rp.to_mmhg(imgs, FSA, gain=0.5)[0].max() == 0  # a gain reads them as empty


def test_resampling_onto_the_model_mat_keeps_the_force_and_centres():
    src = custom_mat(64, 32, 0.025)  # a smaller mat: it lies wholly inside the BodiTrak's
    img = body_image(64, 32)[None]
    out = rp.to_model_mat(img, src, BT)
    assert out.shape == (1, 64, 27)
    np.testing.assert_allclose((out * BT.taxel_area_m2).sum(), (img * src.taxel_area_m2).sum())
    cols = (out[0] * np.arange(27)).sum() / out.sum()
    assert cols == pytest.approx(13.0, abs=0.2)  # the body's centre line stays across the bed's middle
    full = rp.prepare(img * 10, src, "raw", BT, weight_kg=70.0)
    assert full.shape == (1, 64, 27) and full.dtype == np.float32 and full.max() <= BT.max_mmhg


def test_pitch_fit_recovers_a_known_pitch():
    heights = np.array([1.6, 1.7, 1.8, 1.9])
    extents = (heights - 0.06) / 0.028
    pitch, rms = rp.fit_pitch(extents, heights, 0.06)
    assert pitch == pytest.approx(0.028) and rms == pytest.approx(0, abs=1e-12)
    img = np.zeros((64, 32))
    img[3:58, 10:20] = 50
    assert rp.contact_extent_rows(img) == (3, 57)
