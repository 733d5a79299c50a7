"""A bare recording (no labels) read as RealImages, and the one road from RealImages to a model's input."""

import json

import numpy as np
import pytest

from pressurepose.data.readers.recording import read_recording
from pressurepose.data.readers.real import read_real
from pressurepose.data.resample import MMHG_PA
from pressurepose.errors import BadInput
from pressurepose.mat import custom_mat, get_mat
from tests.data.realfolders import body_image, write_pmd_i, write_pmd_ii

FSA, BT = get_mat("fsa_softflex_2048"), get_mat("boditrak_bt3510")
G = 9.80665


def test_a_pmd_i_text_file_gives_the_frames_evaluate_real_reads(tmp_path):
    root = write_pmd_i(tmp_path / "pmd", subjects=(1,), postures=(1, 2), frames=5)
    folder = read_real(root, frames="all")
    rec = read_recording(root / "S1" / "2.txt", "fsa_softflex_2048", "raw", weight_kg=71)
    mine = folder.source == str(root / "S1" / "2.txt")
    assert rec.frame.tolist() == folder.frame[mine].tolist() == [2, 3, 4]  # blank and start-up frames out
    np.testing.assert_array_equal(rec.images, folder.images[mine])
    assert rec.images.dtype == np.float32 and rec.mat == FSA and rec.units == "raw" and rec.layout == "recording"
    assert rec.weight_kg.tolist() == [71.0] * 3 and rec.gain is None and set(rec.posture) == {""}
    # and through the one road both give the same model input
    np.testing.assert_array_equal(rec.model_input(BT), folder.select(mine).model_input(BT))


def test_a_pmd_ii_text_file_with_the_feet_at_row_0(tmp_path):
    root = write_pmd_ii(tmp_path / "pmd2", subjects=(1,), files=("B1",))
    path = root / "S1" / "Air_Mat" / "Matrix_Air_B1.txt"
    as_is = read_recording(path, "boditrak_bt3510", "raw", gain=0.2)
    flipped = read_recording(path, "boditrak_bt3510", "raw", gain=0.2, head_row="last")
    folder = read_real(root)
    assert len(flipped) == 1 and flipped.frame.tolist() == [0]
    np.testing.assert_array_equal(flipped.images[0], folder.images[folder.source == str(path)][0])
    np.testing.assert_array_equal(as_is.images[0], flipped.images[0][::-1])
    assert flipped.images[0, :5].sum() < flipped.images[0, -10:].sum()  # head blob at row 0, legs at the far end


def test_npy_csv_and_arrays_keep_every_frame(tmp_path):
    frames = np.stack([body_image(64, 27, seed=s, scale=10) for s in range(3)])
    np.save(tmp_path / "one.npy", frames[0])
    np.save(tmp_path / "three.npy", frames)
    np.savetxt(tmp_path / "one.csv", frames[1], delimiter=",")
    assert len(read_recording(tmp_path / "one.npy", BT, "mmHg")) == 1
    three = read_recording(str(tmp_path / "three.npy"), "boditrak_bt3510", "mmHg")
    assert three.frame.tolist() == [0, 1, 2] and three.source[0] == str(tmp_path / "three.npy")
    np.testing.assert_allclose(three.images, frames.astype(np.float32))
    np.testing.assert_allclose(read_recording(tmp_path / "one.csv", BT, "mmHg").images[0], frames[1], rtol=1e-6)
    arr = read_recording(frames, BT, "mmHg", head_row="last")
    np.testing.assert_allclose(arr.images, frames[:, ::-1].astype(np.float32))
    # in mmHg on the model's mat the road only cleans: an image with no baseline or faulty taxels passes unchanged
    clean = np.zeros((64, 27))
    clean[10:50, 8:19] = 20.0
    np.testing.assert_allclose(read_recording(clean, BT, "mmHg").model_input(BT)[0], clean)


def test_mat_json_presets_custom_mats_and_gains(tmp_path):
    (tmp_path / "preset.json").write_text(json.dumps({"preset": "fsa_softflex_2048"}))
    (tmp_path / "custom.json").write_text(json.dumps({"rows": 20, "cols": 10, "pitch_m": 0.05, "units": "raw",
                                                      "gain": 0.5}))
    img = body_image(20, 10, seed=1)
    assert read_recording(body_image(64, 32), tmp_path / "preset.json", "mmHg").mat == FSA
    custom = read_recording(img, str(tmp_path / "custom.json"), "raw")
    assert custom.mat.shape == (20, 10) and custom.mat.pitch_col_m == 0.05 and custom.gain == 0.5
    assert read_recording(img, tmp_path / "custom.json", "raw", weight_kg=60).gain is None  # the weight asked for
    with pytest.raises(BadInput, match="mat.json says 'raw'"):
        read_recording(img, tmp_path / "custom.json", "mmHg")


def test_raw_readings_become_the_body_weight_or_the_gain():
    img = body_image(64, 27, seed=2, scale=3.0)  # small raw readings: no taxel reaches the range's top
    rec = read_recording(img, BT, "raw", weight_kg=80)
    x = rec.model_input(BT)
    assert x.shape == (1, 64, 27) and x.dtype == np.float32 and x.max() < BT.max_mmhg
    np.testing.assert_allclose(x.sum() * MMHG_PA * BT.taxel_area_m2, 80 * G, rtol=1e-5)
    # the same load on the FSA mat (wider, coarser) keeps its force where the mats overlap
    on_fsa = np.zeros((64, 32))
    on_fsa[:, 2:29] = img
    y = read_recording(on_fsa, FSA, "raw", weight_kg=80).model_input(BT)
    assert y.sum() * MMHG_PA * BT.taxel_area_m2 == pytest.approx(80 * G, rel=0.05)
    g = read_recording(img, BT, "raw", gain=0.25).model_input(BT)
    clean = read_recording(img, BT, "mmHg").model_input(BT)
    np.testing.assert_allclose(g, 0.25 * clean, rtol=1e-5)


def test_bad_recordings_say_what_is_wrong(tmp_path):
    img = body_image(64, 27)
    with pytest.raises(BadInput, match=r"weight in kg \(--weight-kg.* or your mat.s calibration gain in mmHg per "
                                       r"raw unit \(--gain"):
        read_recording(img, BT, "raw")
    with pytest.raises(BadInput, match="not both"):
        read_recording(img, BT, "raw", weight_kg=70, gain=0.1)
    with pytest.raises(BadInput, match="in mmHg already"):
        read_recording(img, BT, "mmHg", weight_kg=70)
    with pytest.raises(BadInput, match="units 'kPa'"):
        read_recording(img, BT, "kPa")
    with pytest.raises(BadInput, match="head row 'top'"):
        read_recording(img, BT, "mmHg", head_row="top")
    with pytest.raises(BadInput, match="neither a preset"):
        read_recording(img, "xsensor", "mmHg")
    with pytest.raises(BadInput, match=r"rows and columns swapped"):
        read_recording(img.T, BT, "mmHg")
    np.save(tmp_path / "one.npy", img)  # one frame of another mat: its own shape, not (1, 64, 27)
    with pytest.raises(BadInput, match=r"one.npy has frames of 64 x 27; the fsa_softflex_2048 mat is 64 x 32"):
        read_recording(tmp_path / "one.npy", FSA, "mmHg")
    with pytest.raises(BadInput, match="finite and >= 0"):
        read_recording(-img, BT, "mmHg")
    with pytest.raises(BadInput, match=r"values up to 1e\+39, out of range: too large for float32"):
        read_recording(np.where(img > 0, 1e39, 0.0), BT, "mmHg")  # finite in float64, not in float32
    with pytest.raises(BadInput, match=r"is a folder; expected a file \(.npy, .csv, .txt\)"):
        read_recording(tmp_path, BT, "mmHg")
    for weight in (-3, 0.5, 70_000):  # not a weight; one in g
        with pytest.raises(BadInput, match=r"is not a person's weight in kg; expected 2 to 400 kg"):
            read_recording(img, BT, "raw", weight_kg=weight)
    assert read_recording(np.stack([img, img]), BT, "raw", weight_kg=[2, 400]).weight_kg.tolist() == [2, 400]
    with pytest.raises(BadInput, match="gain is"):
        read_recording(img, BT, "raw", gain=0)
    (tmp_path / "short.txt").write_text("1 2 3\n")
    with pytest.raises(BadInput, match=r"first line has 3 readings.*2048 readings"):
        read_recording(tmp_path / "short.txt", FSA, "raw", weight_kg=70)
    (tmp_path / "blank.txt").write_text(("\t".join(["0"] * 2048) + "\n") * 3)
    with pytest.raises(BadInput, match="none of its 3 frames carries a body"):
        read_recording(tmp_path / "blank.txt", FSA, "raw", weight_kg=70)
    (tmp_path / "x.png").write_text("")
    with pytest.raises(BadInput, match="expected .npy, .csv, .txt"):
        read_recording(tmp_path / "x.png", BT, "mmHg")
    with pytest.raises(BadInput, match="does not exist"):
        read_recording(tmp_path / "missing.txt", BT, "mmHg")
    # a raw image with no weight reaching the road by another reader: told why a weight is needed
    rec = read_recording(img, custom_mat(64, 27, 0.0286), "raw", gain=1.0)
    no_weight = rec.__class__(**{**rec.__dict__, "gain": None})
    with pytest.raises(BadInput, match="no body weight and there is no calibration gain"):
        no_weight.model_input(BT)


def test_read_frames_keeps_every_frame_in_float32_and_reads_files_as_read_recording_does(tmp_path):
    """read_frames (a recording over time) keeps the blank and start-up frames read_recording leaves
    out, reads each kind of file by the same reader, and holds float32 frames."""
    from pressurepose.data.readers.recording import read_frames

    root = write_pmd_i(tmp_path / "pmd", subjects=(1,), postures=(2,), frames=5)
    text = root / "S1" / "2.txt"
    every = read_frames(text, FSA.shape)
    assert every.dtype == np.float32 and every.shape == (5, 64, 32)
    assert every[0].sum() == 0 and np.all(every[1] == 3000.0)  # blank and start-up frames kept
    rec = read_recording(text, FSA, "mmHg")
    np.testing.assert_array_equal(every[rec.frame], rec.images)
    frames = np.stack([body_image(64, 27, seed=s, scale=10) for s in range(3)])
    np.save(tmp_path / "night.npy", frames)
    got = read_frames(tmp_path / "night.npy", BT.shape)
    assert got.dtype == np.float32
    np.testing.assert_array_equal(got, frames.astype(np.float32))
    # one frame as rows lines (PMD experiment II's layout) and a .csv: one frame each, alone or in a folder
    pmd2 = write_pmd_ii(tmp_path / "pmd2", subjects=(1,), files=("B1",)) / "S1" / "Air_Mat" / "Matrix_Air_B1.txt"
    np.testing.assert_array_equal(read_frames(pmd2, BT.shape), read_recording(pmd2, BT, "mmHg").images)
    folder = tmp_path / "frames"
    folder.mkdir()
    np.savetxt(folder / "frame_10.csv", frames[2], delimiter=",")
    np.save(folder / "frame_2.npy", frames[1])
    (folder / "frame_1.txt").write_text(pmd2.read_text())
    got = read_frames(folder, BT.shape)
    assert got.dtype == np.float32 and got.shape == (3, 64, 27)
    np.testing.assert_array_equal(got[0], read_frames(pmd2, BT.shape)[0])
    np.testing.assert_allclose(got[1:], frames[1:].astype(np.float32), rtol=1e-6)
    np.save(folder / "frame_3.npy", frames)
    with pytest.raises(BadInput, match="frame_3.npy.*expected one 64 x 27 frame"):
        read_frames(folder, BT.shape)
    with pytest.raises(BadInput, match=r"night.npy.*\(T, 64, 32\)"):
        read_frames(tmp_path / "night.npy", FSA.shape)
    (tmp_path / "nan.txt").write_text("\t".join(["1"] * 2047 + ["nan"]) + "\n")
    with pytest.raises(BadInput, match="nan.txt line 1: reading 2048"):
        read_frames(tmp_path / "nan.txt", FSA.shape)
    np.save(tmp_path / "neg.npy", -frames)  # the file is named, as for every other bad reading
    with pytest.raises(BadInput, match=r"recording '.*neg.npy' has negative readings \(min -"):
        read_frames(tmp_path / "neg.npy", BT.shape)
    with pytest.raises(BadInput, match=r"^recording '.*neg.npy' has negative readings"):
        read_recording(tmp_path / "neg.npy", BT, "mmHg")
    (folder / "frame_3.npy").write_bytes(b"not a frame")
    with pytest.raises(BadInput, match=r"^frame file '.*frame_3.npy' is not a readable .npy file"):
        read_frames(folder, BT.shape)


def test_a_long_text_recording_is_read_without_copies_of_the_night():
    """A text recording of one frame a line is held once, as float32 frames: not as text, nor as
    float64 (a night of 28,800 PMD-I frames is 236 MB as float32, four times that in text)."""
    import tempfile
    import tracemalloc
    from pathlib import Path

    from pressurepose.data.readers.recording import read_frames

    with tempfile.TemporaryDirectory() as d:
        path = Path(d) / "night.txt"
        img = body_image(64, 32, seed=3).ravel()
        path.write_text("".join("\t".join(f"{v + k % 5:.0f}" for v in img) + "\n" for k in range(400)))
        tracemalloc.start()
        try:
            frames = read_frames(path, FSA.shape)
            peak = tracemalloc.get_traced_memory()[1]
        finally:
            tracemalloc.stop()
    assert frames.shape == (400, 64, 32) and frames.dtype == np.float32
    assert peak < 1.3 * frames.nbytes, (peak, frames.nbytes)


def test_a_weight_or_gain_of_the_wrong_type_is_refused_and_a_numpy_integer_gain_is_taken():
    """weight_kg=True was read as 1 kg and '70' as 70 kg (while a text gain was refused), a dict was a
    TypeError; a gain of numpy's integer type (np.int64(2)) was refused as not a positive number."""
    img = body_image(64, 27, seed=2, scale=3.0)
    for weight in (True, "70", "70kg", {}, [70, [80]]):
        with pytest.raises(BadInput, match=r"^weight_kg is .*; expected a positive number of kg, or one per frame"):
            read_recording(img, BT, "raw", weight_kg=weight)
    np.testing.assert_array_equal(read_recording(img, BT, "raw", gain=np.int64(2)).model_input(BT),
                                  read_recording(img, BT, "raw", gain=2.0).model_input(BT))
    assert read_recording(img, BT, "raw", weight_kg=np.float32(70)).weight_kg.tolist() == [70.0]
