"""Official PressurePose pickles (built here in their format), SLP arrays, and mat-to-mat resampling."""

import os
import pickle

import numpy as np
import pytest

from pressurepose.body import BodyModel
from pressurepose.body.lbs_numpy import Y_UP_TO_Z_UP
from pressurepose.body.toy import toy_body_arrays
from pressurepose.data.dataset import DatasetReader
from pressurepose.data.readers import pressurepose_pickle as pp
from pressurepose.data.readers.slp import read_slp, slp_to_mat
from pressurepose.data.resample import resample_force, resample_pressure
from pressurepose.errors import BadInput
from pressurepose.mat import custom_mat, get_mat

BODY = BodyModel(toy_body_arrays())


def _release_file(path, n=3, seed=0):
    """A synthetic file in the release format: bodies posed by an SMPL-format model in THEIR frame."""
    rng = np.random.default_rng(seed)
    betas = rng.uniform(-1, 1, (n, 10))
    pose = rng.normal(0, 0.3, (n, 72))
    _, joints_z_up = BODY.forward(betas, pose)
    markers = joints_z_up @ Y_UP_TO_Z_UP + np.array([0.65, 1.35, 0.12])  # SMPL's native frame, shifted
    raw = {"images": [rng.uniform(0, 60, 1728) for _ in range(n)], "markers_xyz_m": list(markers.reshape(n, 72)),
           "root_xyz_shift": list(markers[:, 0]), "joint_angles": list(pose), "body_shape": list(betas),
           "body_mass": list(rng.uniform(50, 90, n)), "body_height": list(rng.uniform(1.5, 1.9, n)),
           "bed_angle_deg": [0.0] * n, "mesh_depth": [rng.integers(-60, 80, (64, 27)) for _ in range(n)],
           "mesh_contact": [rng.integers(0, 2, (64, 27)) for _ in range(n)]}
    with open(path, "wb") as fh:
        pickle.dump(raw, fh, protocol=2)
    return raw, markers


def test_release_pickle_converts_to_our_frame_consistently(tmp_path):
    path = tmp_path / "train_roll0_plo_hbh_m_lay_set1_3.p"
    raw, markers = _release_file(path)
    manifest = pp.convert_synthetic(path, tmp_path / "out", body=BODY, shard_size=2)
    c = manifest.config
    assert (c.partition, c.gender, c.limbs_on_bed, c.count) == ("hands_behind_head", "m", True, 3)
    samples = list(DatasetReader(tmp_path / "out"))
    s = samples[1]
    # the image is theirs mirrored left-right; joints are rotated 180 deg about the vertical
    assert np.allclose(s.pressure, raw["images"][1].reshape(64, 27)[:, ::-1], atol=1e-4)
    p = pp.PITCH
    expect = np.stack([37 * p - markers[1, :, 0], 74 * p - markers[1, :, 1], markers[1, :, 2]], axis=1)
    np.testing.assert_allclose(s.joints, expect, atol=1e-5)
    np.testing.assert_allclose(s.depth, raw["mesh_depth"][1][:, ::-1] / 1000.0, atol=1e-6)
    np.testing.assert_allclose(s.force.sum(), s.pressure.sum() * 133.322 * p * p, rtol=1e-4)
    # our body model, fed the converted parameters, puts every joint where the label says
    _, j = BODY.forward(np.stack([x.betas for x in samples]).astype(float), np.stack([x.pose for x in samples]).astype(float),
                        np.stack([x.transl for x in samples]).astype(float))
    np.testing.assert_allclose(j, np.stack([x.joints for x in samples]), atol=1e-5)
    # the mapping keeps handedness: a rotation, not a reflection
    a, b, d = s.joints[1] - s.joints[0], s.joints[2] - s.joints[0], s.joints[3] - s.joints[0]
    a0, b0, d0 = (markers[1, k] - markers[1, 0] for k in (1, 2, 3))
    assert np.sign(np.dot(np.cross(a, b), d)) == np.sign(np.dot(np.cross(a0, b0), d0))


def test_export_to_release_format_round_trips(tmp_path):
    path = tmp_path / "test_rollpi_f_lay_set23to24_3.p"
    raw, markers = _release_file(path, seed=1)
    pp.convert_synthetic(path, tmp_path / "ours", body=BODY)
    samples = list(DatasetReader(tmp_path / "ours"))
    pp.export_synthetic(samples, tmp_path / "back.p")
    back = pp.load_pickle(tmp_path / "back.p")
    assert set(back) == set(pp.SYNTHETIC_KEYS)
    np.testing.assert_allclose(np.array(back["images"]), np.array(raw["images"]), atol=1e-4)
    np.testing.assert_allclose(np.array(back["markers_xyz_m"]), markers.reshape(3, 72), atol=1e-5)
    np.testing.assert_allclose(np.array(back["joint_angles"]), np.array(raw["joint_angles"]), atol=1e-5)
    assert np.array_equal(np.array(back["mesh_depth"]), np.array(raw["mesh_depth"]))


class _Evil:
    def __reduce__(self):
        return (os.system, ("echo pwned > /dev/null",))


def test_malicious_pickle_is_refused(tmp_path):
    path = tmp_path / "evil.p"
    with open(path, "wb") as fh:
        pickle.dump({"images": [_Evil()]}, fh, protocol=2)
    with pytest.raises(BadInput, match="refusing to load global (posix|os).system"):
        pp.read_synthetic(path)
    path.write_bytes(pickle.dumps({"x": np.zeros(3)}, protocol=2)[:-10])
    with pytest.raises(BadInput, match="corrupt or truncated"):
        pp.load_pickle(path)


def test_names_and_shapes_are_checked(tmp_path):
    path = tmp_path / "mystery.p"
    _release_file(path)
    with pytest.raises(BadInput, match="cannot tell the partition"):
        pp.convert_synthetic(path, tmp_path / "o", body=BODY)
    raw = pp.load_pickle(path)
    raw["images"] = [np.zeros(100)] * 3
    with open(tmp_path / "bad_rollpi_f.p", "wb") as fh:
        pickle.dump(raw, fh, protocol=2)
    with pytest.raises(BadInput, match="images has shape"):
        pp.read_synthetic(tmp_path / "bad_rollpi_f.p")


def test_real_participant_folder(tmp_path):
    folder = tmp_path / "S103"
    folder.mkdir()
    with open(folder / "participant_info_red.p", "wb") as fh:
        pickle.dump({"gender": "f", "height_in": 65.0, "weight_lbs": 130.0}, fh, protocol=2)
    rng = np.random.default_rng(2)
    images = [rng.uniform(0, 40, 1728) for _ in range(2)]
    with open(folder / "p_select.p", "wb") as fh:
        pickle.dump({"images": images, "pc": [rng.random((50, 3)), rng.random((40, 3))],
                     "pmat_corners": [np.zeros((4, 2))] * 2}, fh, protocol=2)
    part = pp.read_real_participant(folder)
    assert part.gender == "f" and abs(part.mass - 58.967) < 1e-3 and abs(part.height - 1.651) < 1e-9
    rec = part.recordings["p_select"]
    assert rec.pressure.shape == (2, 64, 27) and np.allclose(rec.pressure[1], images[1].reshape(64, 27)[:, ::-1])
    out = pp.save_real_hdf5(part, tmp_path / "S103.h5")
    import h5py
    with h5py.File(out) as f:
        assert f["p_select/pc_points"].shape == (90, 3) and list(f["p_select/pc_offsets"]) == [0, 50, 90]


def _slp_tree(root, subjects=(1, 2), frames=3):
    rng = np.random.default_rng(3)
    np.save(root / "physiqueData.npy", np.array([[0, 165.0, 60.0, 90], [1, 180.0, 82.0, 95]]))
    for s in subjects:
        sub = root / f"{s:05d}"
        (sub / "PMarray" / "uncover").mkdir(parents=True)
        np.save(sub / "PMcali.npy", np.full((3, 45), 0.5 * s))
        for f in range(1, frames + 1):
            np.save(sub / "PMarray" / "uncover" / f"{f:06d}.npy", rng.integers(0, 200, (192, 84)).astype(np.uint16))


def test_slp_reader_calibrates_and_resamples(tmp_path):
    _slp_tree(tmp_path)
    raw = read_slp(tmp_path, calibrated=False)
    cal = read_slp(tmp_path, subjects=[2], frames=[2])
    assert raw.images.shape == (6, 192, 84) and list(raw.subject) == [1, 1, 1, 2, 2, 2]
    np.testing.assert_allclose(cal.images[0], raw.images[4] * 1.0 * 1000 / 133.322, rtol=1e-6)
    assert cal.gender[0] == "m" and cal.mass[0] == 82.0 and cal.height[0] == 1.8
    small = slp_to_mat(cal.images)  # 1.92 x 0.84 m onto the 1.83 x 0.77 m BodiTrak: only the overlap is kept
    assert small.shape == (1, 64, 27)
    with pytest.raises(BadInput, match="covers"):
        read_slp(tmp_path, covers=["blanket"])
    np.save(tmp_path / "00001" / "PMarray" / "uncover" / "000001.npy", np.zeros((64, 27)))
    with pytest.raises(BadInput, match=r"shape \(64, 27\); the SLP mat is 192 x 84"):
        read_slp(tmp_path, subjects=[1], frames=[1])


def test_resample_keeps_total_force_when_the_destination_covers_the_source():
    rng = np.random.default_rng(4)
    src, dst = get_mat("boditrak_bt3510"), get_mat("slp")  # 1.83 x 0.77 m inside 1.92 x 0.84 m
    f = rng.uniform(0, 5, (3, 64, 27))
    g = resample_force(f, src, dst)
    assert g.shape == (3, 192, 84)
    np.testing.assert_allclose(g.sum((1, 2)), f.sum((1, 2)), rtol=1e-12)
    tip = get_mat("tip")  # non-square 31.1 x 19.5 mm taxels, 1.74 x 0.78 m, also inside the SLP mat
    p = rng.uniform(0, 50, (56, 40))
    q = resample_pressure(p, tip, dst, align="corner")
    np.testing.assert_allclose((q * dst.taxel_area_m2).sum(), (p * tip.taxel_area_m2).sum(), rtol=1e-12)


def test_resample_identity_known_values_and_loss_outside():
    m = get_mat("tip")
    x = np.random.default_rng(5).uniform(0, 9, (56, 40))
    np.testing.assert_allclose(resample_pressure(x, m, m), x, rtol=1e-9, atol=1e-12)
    fine, coarse = custom_mat(2, 2, 0.01), custom_mat(1, 1, 0.02)
    assert resample_force(np.array([[1.0, 2.0], [3.0, 4.0]]), fine, coarse)[0, 0] == pytest.approx(10.0)
    # a half-taxel shift splits each force evenly between two destination taxels
    shifted = custom_mat(1, 3, 0.01, 0.01)
    out = resample_force(np.array([[2.0, 4.0]]), custom_mat(1, 2, 0.01), shifted)
    np.testing.assert_allclose(out, [[1.0, 3.0, 2.0]])
    # a smaller destination keeps only the force over it
    half = custom_mat(1, 1, 0.01)
    assert resample_force(np.array([[2.0, 4.0]]), custom_mat(1, 2, 0.01), half, align="corner")[0, 0] == 2.0
    with pytest.raises(BadInput, match=r"shape \(5, 5\); the tip mat is 56 x 40"):
        resample_pressure(np.zeros((5, 5)), m, m)
    with pytest.raises(BadInput, match="negative"):
        resample_pressure(-np.ones((56, 40)), m, m)


def test_resample_takes_mats_by_preset_name():
    """As docs/data.md writes it: resample_pressure(images, src_mat, dst_mat) with preset names or MatSpecs."""
    x = np.random.default_rng(0).uniform(0, 50, (2, 64, 32))
    by_name = resample_pressure(x, "fsa_softflex_2048", "boditrak_bt3510")
    np.testing.assert_array_equal(by_name, resample_pressure(x, get_mat("fsa_softflex_2048"), get_mat("boditrak_bt3510")))
    assert resample_force(x, "fsa_softflex_2048", "tip").shape == (2, 56, 40)
    with pytest.raises(BadInput, match="bodytrak"):
        resample_pressure(x, "fsa_softflex_2048", "bodytrak")
    with pytest.raises(BadInput, match=r"src \(the source mat\) is a tuple; expected a MatSpec or a preset name"):
        resample_pressure(x, (64, 32), "boditrak_bt3510")


def test_convert_verb_both_ways(tmp_path, capsys):
    from pressurepose.body.smpl_io import save_body_arrays
    from pressurepose.cli import main

    save_body_arrays(tmp_path / "toy.npz", toy_body_arrays())
    src = tmp_path / "release"
    src.mkdir()
    _release_file(src / "train_roll0_xl_f_lay_set2both_3.p", seed=6)
    _release_file(src / "train_roll0_sl_m_lay_set2pa1_3.p", seed=7)
    assert main(["convert", str(src), "--out", str(tmp_path / "ours"), "--body", str(tmp_path / "toy.npz")]) == 0
    r = DatasetReader(tmp_path / "ours")
    assert len(r) == 6 and {d.config.partition for d in r.datasets} == {"supine_crossed_legs", "supine_straight_limbs"}
    assert main(["convert", str(tmp_path / "ours" / "train_roll0_xl_f_lay_set2both_3"), "--to-pressurepose",
                 "--out", str(tmp_path / "back.p")]) == 0
    assert len(pp.load_pickle(tmp_path / "back.p")["images"]) == 3
    assert main(["convert", str(src / "train_roll0_xl_f_lay_set2both_3.p"), "--out", str(tmp_path / "ours"),
                 "--body", str(tmp_path / "toy.npz")]) == 2
    assert "not empty" in capsys.readouterr().err
