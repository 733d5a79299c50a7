"""Readers of real pressure images: PMD experiments I and II and the generic labelled folder."""


import numpy as np
import pytest

from pressurepose.data.readers.real import detect_layout, read_real
from pressurepose.errors import BadInput
from tests.data.realfolders import body_image, write_labelled, write_pmd_i, write_pmd_ii

SHARED = "/work/shared/data/pmd-experiment-i"


def test_pmd_i_reads_labels_skips_blank_and_startup_frames(tmp_path):
    root = write_pmd_i(tmp_path / "pmd", subjects=(1, 2), postures=(1, 2, 15), frames=5)
    assert detect_layout(root) == "pmd-i"
    one = read_real(root)
    assert len(one) == 6 and one.images.shape == (6, 64, 32) and one.mat.name == "fsa_softflex_2048"
    assert one.units == "raw" and set(one.frame) == {-1}
    assert list(one.posture[:3]) == ["supine", "right", "inclined"]
    assert one.height_m[0] == pytest.approx(1.71) and one.weight_kg[3] == pytest.approx(72)
    assert list(one.subject) == ["1"] * 3 + ["2"] * 3 and set(one.gender) == {""}
    # the median of the three body frames (x1, x1.01, x1.02) is the middle one; blank and start-up frames out
    np.testing.assert_allclose(one.images[0], np.round(body_image(64, 32, seed=11).ravel() * 1.01).reshape(64, 32),
                               atol=0.6)
    every = read_real(root, frames="all")
    assert len(every) == 18 and sorted(set(every.frame)) == [2, 3, 4]


def test_pmd_ii_flips_feet_to_head_and_reads_utf16_subjects(tmp_path):
    root = write_pmd_ii(tmp_path / "pmd2", subjects=(3,), files=("B1", "C2", "X1"))
    assert detect_layout(root) == "pmd-ii"
    with pytest.warns(UserWarning, match="2 image"):  # X1 on both mattresses: no such letter in the dataset
        r = read_real(root)
    assert len(r) == 6 and r.images.shape == (6, 64, 27) and r.mat.name == "boditrak_bt3510"
    assert sorted(set(r.posture)) == ["", "lateral", "supine"]
    assert r.height_m[0] == pytest.approx(1.83) and r.weight_kg[0] == pytest.approx(83)
    np.testing.assert_allclose(r.images[0], np.round(body_image(64, 27, seed=3)), atol=0.6)  # head at row 0 again
    assert r.images[0, :5].sum() < r.images[0, -10:].sum()  # head blob small, legs at the far end


def test_pmd_ii_posture_letters_b_to_g(tmp_path):
    """The dataset's letters: B and F supine (F7 on a raised bed head: not scored), C and D on one side
    and the other (either side), E turned part-way onto a side on a support (either side, summarised
    apart with the wedge postures), G unlabelled; another letter warns how many images go unscored."""
    from pressurepose.eval.posture import posture_correct
    from pressurepose.eval.real import is_wedge

    codes = ("B1", "B10", "C2", "D3", "E1", "E6", "F2", "F7", "G1", "Q4")
    root = write_pmd_ii(tmp_path / "pmd2", subjects=(1,), files=codes)
    with pytest.warns(UserWarning, match=r"2 image\(s\) have a posture letter .* \(Q \(2\); known: B-G\)"):
        r = read_real(root)
    air = r.source.astype(str)
    got = {c: (r.posture[i], r.detail[i]) for c in codes for i in range(len(r))
           if air[i].endswith(f"Matrix_Air_{c}.txt")}
    assert {c: p for c, (p, _) in got.items()} == {
        "B1": "supine", "B10": "supine", "C2": "lateral", "D3": "lateral", "E1": "lateral", "E6": "lateral",
        "F2": "supine", "F7": "inclined", "G1": "", "Q4": ""}
    assert got["E6"][1].startswith("air mattress, E6: turned part-way")
    wedge = is_wedge(r.detail)
    assert sorted({d.split(",")[1].split(":")[0].strip() for d in r.detail[wedge]}) == ["E1", "E6"]
    # a side-lying or turned body read on either side counts right, on its back not
    e = r.posture[np.flatnonzero(wedge)[:3]]
    assert posture_correct(e, ["left", "right", "supine"]).tolist() == [True, True, False]
    import warnings

    with warnings.catch_warnings():  # the dataset's own letters read without a warning
        warnings.simplefilter("error")
        read_real(write_pmd_ii(tmp_path / "known", files=("B2", "E3", "G3")))


def test_labelled_folder_round_trip_and_custom_mat(tmp_path):
    imgs = np.stack([body_image(20, 10, seed=i) for i in range(3)])
    root = write_labelled(tmp_path / "lab", imgs, ["supine", "lateral", "prone"],
                          {"rows": 20, "cols": 10, "pitch_m": 0.05, "units": "raw"}, genders=["f", "m", "f"])
    assert detect_layout(root) == "labelled"
    r = read_real(root)
    assert r.mat.shape == (20, 10) and r.mat.pitch_col_m == 0.05 and r.units == "raw" and r.gain is None
    assert list(r.posture) == ["supine", "lateral", "prone"] and list(r.gender) == ["f", "m", "f"]
    np.testing.assert_allclose(r.images, imgs.astype(np.float32))
    assert r.select([0, 2]).posture.tolist() == ["supine", "prone"]


def test_bad_inputs_name_the_file(tmp_path):
    (tmp_path / "empty").mkdir()
    with pytest.raises(BadInput, match="neither a PMD experiment folder"):
        read_real(tmp_path / "empty")
    imgs = np.stack([body_image(64, 27, seed=i) for i in range(2)])
    mat = {"preset": "boditrak_bt3510", "units": "mmHg"}
    root = write_labelled(tmp_path / "a", imgs, ["supine", "left"], mat)
    (root / "labels.csv").write_text("posture,height_m\nsupine,1.7\nleft,1.8\n")
    with pytest.raises(BadInput, match=r"labels.csv is missing column\(s\) weight_kg"):
        read_real(root)
    root = write_labelled(tmp_path / "b", imgs, ["supine", "left"], {"preset": "xsensor", "units": "raw"})
    with pytest.raises(BadInput, match=r"mat.json: unknown mat"):
        read_real(root)
    root = write_labelled(tmp_path / "c", imgs[:, :60], ["supine", "left"], mat)
    with pytest.raises(BadInput, match=r"images.npy has shape \(2, 60, 27\)"):
        read_real(root)
    root = write_labelled(tmp_path / "d", imgs, ["supine", "sitting"], mat)
    with pytest.raises(BadInput, match=r"labels.csv line 3: posture 'sitting'"):
        read_real(root)
    root = write_labelled(tmp_path / "e", imgs, ["supine", "left"], {"preset": "boditrak_bt3510", "units": "kPa"})
    with pytest.raises(BadInput, match=r"mat.json: units is 'kPa'"):
        read_real(root)
    root = write_pmd_i(tmp_path / "p", subjects=(1,), postures=(1,))
    (root / "S1" / "1.txt").write_text("1\t2\t3\n")
    with pytest.raises(BadInput, match=r"1.txt line 1 has 3 readings; expected 2048"):
        read_real(root)
    root = write_pmd_ii(tmp_path / "q")
    bad = next((root / "S1" / "Air_Mat").glob("*.txt"))
    bad.write_text("1 2 3\n" * 64)
    with pytest.raises(BadInput, match="expected 64 lines of 27"):
        read_real(root)
    with pytest.raises(BadInput, match="frames 'some'"):
        read_real(root, frames="some")


@pytest.mark.skipif(not __import__("os").path.isdir(SHARED), reason="shared PMD data not present")
def test_one_real_pmd_i_file_has_a_startup_frame_and_a_body(tmp_path):
    from pressurepose.data.readers.pmd import read_pmd_i_file
    from pressurepose.data.realprep import valid_frames

    stack = read_pmd_i_file(f"{SHARED}/S1/1.txt")
    assert stack.shape[1:] == (64, 32) and len(stack) >= 3
    ok = valid_frames(stack)
    assert not ok[:2].any() and ok[2:].all()  # near-blank first frame, saturated start-up second

