"""The plausibility check: images unlike a person lying on the mat are flagged, with a reason;
real (PMD experiment I) and simulated bodies are not."""

import os
from pathlib import Path

import numpy as np
import pytest

from pressurepose.errors import BadInput
from pressurepose.mat import custom_mat, get_mat
from pressurepose.net.plausibility import (
    MAX_LOADED_SHARE,
    MIN_LENGTH_M,
    Doubt,
    check_plausible,
    image_stats,
)

GRID = get_mat("boditrak_bt3510")  # the shipped model's mat, 64 x 27
R, C = GRID.shape
PMD = Path(os.environ.get("PRESSUREPOSE_PMD", "/work/shared/data/pmd-experiment-i"))


def block(rows: int, cols: int, mmhg: float = 40.0) -> np.ndarray:
    im = np.zeros((R, C))
    im[(R - rows) // 2:(R - rows) // 2 + rows, (C - cols) // 2:(C - cols) // 2 + cols] = mmhg
    return im


def test_noise_an_empty_mat_a_box_and_a_few_taxels_are_flagged_with_their_reason():
    rng = np.random.default_rng(3)
    few = np.zeros((R, C))
    few.flat[rng.choice(R * C, 8, replace=False)] = 80.0
    cases = {Doubt.TOO_SPREAD: [rng.uniform(0, 20, (R, C)), rng.uniform(0, 100, (R, C)), np.full((R, C), 30.0)],
             Doubt.EMPTY: [np.zeros((R, C)), np.full((R, C), 4.0)],  # 4 mmHg: under the model's contact floor
             Doubt.TOO_LITTLE: [few, block(5, 5)],
             Doubt.TOO_SHORT: [block(15, 12)],       # a box of 0.43 x 0.34 m
             Doubt.TOO_EVEN: [block(30, 18)]}        # a box of 0.86 x 0.51 m: long enough, but even
    images = np.stack([im for ims in cases.values() for im in ims])
    verdict = check_plausible(images, GRID)
    expected = [d for d, ims in cases.items() for _ in ims]
    assert list(verdict.doubt) == expected
    assert not verdict.ok.any() and list(verdict.doubtful) == list(range(len(images)))
    assert all(r and "_" not in r for r in verdict.reason)  # words, not a state's name
    assert "noise" in verdict.reason[0] and "nobody" in verdict.reason[3] and "sitting" in verdict.reason[7]
    assert verdict.record(0) == {"plausible": False, "doubt": verdict.reason[0]}


@pytest.mark.parametrize("mat", ["boditrak_bt3510", "fsa_softflex_2048"])
def test_noise_read_as_a_raw_recording_is_flagged_as_noise(mat):
    """Raw noise set to a 70 kg load on reading loads as few taxels as a body does (about 35 %); its
    taxels' readings are unrelated, also after resampling from another mat (which smooths them)."""
    from pressurepose.data.readers.recording import read_recording

    raw = np.random.default_rng(2).uniform(0, 1000, (4, *get_mat(mat).shape)).astype(np.float32)
    x = read_recording(raw, mat, "raw", weight_kg=70).model_input(GRID)
    verdict = check_plausible(x, GRID)
    assert verdict.doubt == (Doubt.NOISY,) * 4 and "noise" in verdict.reason[0]
    assert (verdict.stats.loaded_share < MAX_LOADED_SHARE).all()  # not caught by the share alone


def test_the_statistics_are_in_the_mats_units():
    stats = image_stats(block(20, 10), GRID)  # one image (R, C) is a batch of one
    assert stats.loaded_share[0] == pytest.approx(200 / (R * C))
    assert stats.length_m[0] == pytest.approx(20 * GRID.pitch_row_m)
    assert stats.peak_over_mean[0] == pytest.approx(1.0) and stats.loaded[0] == 200
    assert 0.9 < stats.smoothness[0] < 1.0
    assert image_stats(np.full((R, C), 4.0), GRID).smoothness[0] == 0  # under the floor: nothing varies
    stretched = image_stats(block(20, 10), custom_mat(rows=R, cols=C, pitch_row_m=2 * GRID.pitch_row_m,
                                                       pitch_col_m=GRID.pitch_col_m))
    assert stretched.length_m[0] == pytest.approx(2 * stats.length_m[0])
    stray = block(40, 10)
    stray[0, 0] = stray[-1, -1] = 6.0  # a few stray taxels do not stretch the body
    assert image_stats(stray, GRID).length_m[0] == pytest.approx(40 * GRID.pitch_row_m)
    assert MIN_LENGTH_M < 40 * GRID.pitch_row_m and MAX_LOADED_SHARE < 1


def test_bad_arguments_are_refused():
    for bad in (np.zeros((R, C + 1)), np.zeros((2, 2, R, C)), np.full((R, C), np.nan), -np.ones((R, C))):
        with pytest.raises(BadInput):
            check_plausible(bad, GRID)


@pytest.fixture(scope="module")
def simulated():
    """(3, 64, 27) mmHg: three simulated bodies (general f and m, general_lateral f) on the model's mat."""
    from pressurepose.body import BodyModel
    from pressurepose.sim.bed import get_bed
    from pressurepose.sim.simulate import Rejected, simulate_one

    bed = get_bed()
    assert bed.mat.shape == GRID.shape
    images = []
    for partition, gender, seed in (("general", "f", 7), ("general", "m", 8), ("general_lateral", "f", 9)):
        body, rng = BodyModel(gender), np.random.default_rng(seed)
        for _ in range(20):
            sim = simulate_one(body, bed, partition, gender, rng)
            if not isinstance(sim, Rejected):
                images.append(sim.image.pressure)
                break
    assert len(images) == 3
    return np.stack(images)


def test_simulated_bodies_are_not_flagged_and_a_body_under_noise_is(simulated):
    verdict = check_plausible(simulated, GRID)
    assert verdict.ok.all(), verdict.reason
    assert verdict.reason == ("", "", "") and verdict.record(1) == {"plausible": True}
    noisy = simulated[0] + np.random.default_rng(0).uniform(0, 20, (R, C))
    assert check_plausible(noisy, GRID).doubt == (Doubt.TOO_SPREAD,)


@pytest.mark.skipif(not (PMD / "S1" / "1.txt").is_file(),
                    reason="PRESSUREPOSE_PMD does not name PhysioNet PMD experiment I")
@pytest.mark.parametrize("frames", ["one", "all"])
def test_every_pmd_i_image_evaluate_real_scores_is_not_flagged(frames):
    from pressurepose.data.readers.real import read_real
    from pressurepose.eval.real import model_inputs
    from pressurepose.net.infer import resolve_model

    net = resolve_model()
    _, x, _, _, _ = model_inputs(read_real(PMD, frames=frames), net)
    verdict = check_plausible(x, net.config.grid)
    assert len(x) >= 180
    assert verdict.ok.all(), [verdict.reason[i] for i in verdict.doubtful[:3]]


def test_infer_warns_about_each_doubtful_image_and_still_writes_its_estimate(simulated, tmp_path, capsys):
    """The shipped model on uniform noise, a body and a box (mmHg on its mat), then on a raw
    recording on the same mat whose last frame is noise: one warning line per doubtful image, naming
    the image or frame and the reason; the estimates are written, with "plausible" and "doubt"."""
    import json

    from pressurepose.cli import main

    noise = np.random.default_rng(5).uniform(0, 20, (R, C))
    np.save(tmp_path / "three.npy", np.stack([noise, simulated[0], block(15, 12)]).astype(np.float32))
    assert main(["infer", str(tmp_path / "three.npy"), "--gender", "f", "--out", str(tmp_path / "a"),
                 "--max-figures", "0"]) == 0
    captured = capsys.readouterr()
    lines = [x for x in captured.err.splitlines() if "does not look like a person lying on the mat" in x]
    assert len(lines) == 2 and lines[0].startswith(f"warning: image 0 of {tmp_path / 'three.npy'} ")
    assert "sensor noise" in lines[0] and lines[1].startswith("warning: image 2 ") and "sitting" in lines[1]
    assert "image 1: " in captured.out and "3 estimate(s) written" in captured.out
    saved = json.loads((tmp_path / "a" / "estimate.json").read_text())["estimates"]
    assert [r["plausible"] for r in saved] == [False, True, False]
    assert "doubt" not in saved[1] and "%" in saved[0]["doubt"] and "0.43 m" in saved[2]["doubt"]

    frames = np.stack([simulated[0], simulated[1], noise]) * 3.0  # raw readings, weight-normalised on reading
    np.save(tmp_path / "rec.npy", frames.astype(np.float32))
    assert main(["infer", str(tmp_path / "rec.npy"), "--mat", "boditrak_bt3510", "--units", "raw", "--weight-kg",
                 "70", "--gender", "m", "--out", str(tmp_path / "b"), "--max-figures", "0"]) == 0
    lines = [x for x in capsys.readouterr().err.splitlines() if "does not look like a person" in x]
    assert len(lines) == 1 and lines[0].startswith(f"warning: frame 2 of {tmp_path / 'rec.npy'} ")
