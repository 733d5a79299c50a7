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



SUBJECT_HEAD = "Subject-Number,Age,Height/cm,Weight/kg\n"
# (case, subject-info-i.csv rows after the header, what the refusal must say)
BAD_SUBJECT_INFO = [
    ("height-nan", "1,30,nan,70\n2,30,170,70\n", r"line 2, subject 1: height nan m .* expected 0.5-2.6 m"),
    ("height-inf", "1,30,inf,70\n2,30,170,70\n", r"subject 1: height inf m"),
    ("height-negative", "1,30,-175,70\n2,30,170,70\n", r"subject 1: height -1.75 m \(read as -175 cm\)"),
    ("height-in-mm-under-a-cm-header", "1,30,1750,70\n2,30,170,70\n", r"subject 1: height 17.5 m \(read as 1750 cm\)"),
    ("weight-huge", "1,30,175,1e300\n2,30,170,70\n", r"subject 1: weight 1e\+300 kg .* expected 2-400 kg"),
    ("weight-nan", "1,30,175,70\n2,30,170,nan\n", r"subject-info-i.csv line 3, subject 2: weight nan kg"),
    ("subject-twice", "1,30,175,70\n2,30,170,70\n1,30,180,80\n",
     r"line 4: subject 1 is listed again \(first on line 2\)"),
    ("subject-not-whole", "1.5,30,175,70\n2,30,170,70\n", r"line 2: subject '1.5' is not a whole number"),
]


@pytest.mark.parametrize("case,rows,message", BAD_SUBJECT_INFO, ids=[c[0] for c in BAD_SUBJECT_INFO])
def test_pmd_subject_info_refuses_what_is_not_a_person(tmp_path, case, rows, message):
    root = write_pmd_i(tmp_path / "pmd", subjects=(1, 2), postures=(1,))
    (root / "subject-info-i.csv").write_text(SUBJECT_HEAD + rows)
    with pytest.raises(BadInput, match=message):
        read_real(root)


def test_pmd_heights_follow_the_unit_the_header_names(tmp_path):
    root = write_pmd_i(tmp_path / "pmd", subjects=(1, 2), postures=(1,))
    (root / "subject-info-i.csv").write_text("Subject,Height (mm),Weight (kg)\n1,1750,70\n2,1620,55\n")
    assert read_real(root).height_m.tolist() == pytest.approx([1.75, 1.62])
    (root / "subject-info-i.csv").write_text("Subject,Height,Weight\n1,1.75,70\n2,162,55\n")  # no unit: > 3 is cm
    assert read_real(root).height_m.tolist() == pytest.approx([1.75, 1.62])


def test_one_subject_in_two_folders_is_refused(tmp_path):
    import shutil

    root = write_pmd_i(tmp_path / "pmd", subjects=(1, 2), postures=(1,))
    shutil.copytree(root / "S1", root / "S01")
    with pytest.raises(BadInput, match="folders S01 and S1 are both subject 1"):
        read_real(root)


def test_a_non_finite_reading_names_the_file_line_and_reading(tmp_path):
    root = write_pmd_i(tmp_path / "pmd", subjects=(1,), postures=(1,))
    path = root / "S1" / "1.txt"
    lines = path.read_text().splitlines()
    lines[2] = lines[2].replace("\t", "\tnan\t", 1).split("\t", 1)[1]  # reading 1 is the frame's first, now nan
    path.write_text("\n".join(lines) + "\n")
    with pytest.raises(BadInput, match=r"S1/1.txt line 3: reading 1 is 'nan', not a finite number"):
        read_real(root)
    root = write_pmd_ii(tmp_path / "q")
    bad = next((root / "S1" / "Air_Mat").glob("*.txt"))
    rows = bad.read_text().splitlines()
    rows[4] = " ".join(["0"] * 26 + ["1e39"])
    bad.write_text("\n".join(rows) + "\n")
    with pytest.raises(BadInput, match=rf"{bad.name} line 5: reading 27 is '1e39', out of range \(too large for float32"):
        read_real(root)


def test_labelled_folder_edge_cases(tmp_path):
    """Excel's "CSV UTF-8" labels (with a byte-order mark) read; a boolean gain, values beyond
    float32 and a labels.csv row out of range are refused by name."""
    imgs = np.stack([body_image(64, 27, seed=i) for i in range(2)])
    mat = {"preset": "boditrak_bt3510", "units": "raw"}
    root = write_labelled(tmp_path / "bom", imgs, ["supine", "left"], mat, weights=[70, 80])
    (root / "labels.csv").write_bytes(b"\xef\xbb\xbf" + (root / "labels.csv").read_bytes())
    assert read_real(root).posture.tolist() == ["supine", "left"]
    root = write_labelled(tmp_path / "gain", imgs, ["supine", "left"], {**mat, "gain": True})
    with pytest.raises(BadInput, match="mat.json: gain is True; expected a positive number"):
        read_real(root)
    huge = imgs.copy()
    huge[1, 3, 4] = 1e39  # finite in float64, infinite in float32
    root = write_labelled(tmp_path / "huge", huge, ["supine", "left"], mat)
    with pytest.raises(BadInput, match=r"images.npy holds values up to 1e\+39, out of range: too large for float32"):
        read_real(root)
    root = write_labelled(tmp_path / "tall", imgs, ["supine", "left"], mat, heights=[1.7, 175])
    with pytest.raises(BadInput, match=r"labels.csv line 3: height 175 m is not a person's stature"):
        read_real(root)
    npz = write_labelled(tmp_path / "npz", imgs, ["supine", "left"], mat)
    with open(npz / "images.npy", "wb") as fh:
        np.savez(fh, images=imgs)
    with pytest.raises(BadInput, match="npz archive under another name"):
        read_real(npz)


def test_a_folder_that_is_not_a_path_is_refused_by_name():
    """read_real(None) or (3) was a TypeError from pathlib."""
    for folder in (None, 3, ["S1"]):
        with pytest.raises(BadInput, match=r"^real-data folder is .*; expected a path"):
            read_real(folder)


def test_a_negative_reading_names_the_file_line_and_reading(tmp_path):
    """PMD text files were read with negative readings kept (the bare-recording and labelled readers
    refuse them): now refused naming the file, the line and the reading, in experiments I and II
    and in a text recording read by infer or monitor."""
    from pressurepose.data.readers.recording import read_frames, read_recording

    root = write_pmd_i(tmp_path / "pmd", subjects=(1,), postures=(1,))
    path = root / "S1" / "1.txt"
    lines = path.read_text().splitlines()
    lines[2] = "-3\t" + lines[2].split("\t", 1)[1]
    path.write_text("\n".join(lines) + "\n")
    with pytest.raises(BadInput, match=r"S1/1.txt line 3: reading 1 is '-3', negative; a pressure mat's readings are >= 0"):
        read_real(root)
    with pytest.raises(BadInput, match=r"1.txt line 3: reading 1 is '-3', negative"):
        read_recording(path, "fsa_softflex_2048", "raw", weight_kg=70)
    with pytest.raises(BadInput, match=r"1.txt line 3: reading 1 is '-3', negative"):
        read_frames(path, (64, 32))
    root = write_pmd_ii(tmp_path / "q")
    bad = next((root / "S1" / "Air_Mat").glob("*.txt"))
    rows = bad.read_text().splitlines()
    rows[4] = " ".join(["0"] * 26 + ["-0.5"])
    bad.write_text("\n".join(rows) + "\n")
    with pytest.raises(BadInput, match=rf"{bad.name} line 5: reading 27 is '-0.5', negative"):
        read_real(root)


def test_a_missing_subject_file_is_said_to_be_missing(tmp_path):
    root = write_pmd_i(tmp_path / "p", subjects=(1,), postures=(1,))
    (root / "subject-info-i.csv").unlink()
    with pytest.raises(BadInput, match=r"subject-info-i.csv is missing; expected a text file"):
        read_real(root)
    (root / "subject-info-i.csv").mkdir()
    with pytest.raises(BadInput, match=r"subject-info-i.csv is a folder; expected a text file"):
        read_real(root)
