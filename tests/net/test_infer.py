import dataclasses
import json

import h5py
import numpy as np
import pytest
import torch

from pressurepose.body.model import BodyModel
from pressurepose.body.smpl_io import save_body_arrays
from pressurepose.body.toy import toy_body_arrays
from pressurepose.cli import main
from pressurepose.errors import BadInput
from pressurepose.mat import custom_mat
from pressurepose.net.checkpoint import gendered_body, load_model, save_model
from pressurepose.net.infer import estimate, load_pressure
from pressurepose.net.model import NetConfig, PressureNet
from pressurepose.net.outputs import OutputConfig
from tests.net.synth import toy_body, toy_dataset

torch.set_num_threads(1)
GRID = custom_mat(rows=16, cols=16, pitch_row_m=0.125, pitch_col_m=0.0625)


@pytest.fixture(scope="module")
def model_path(tmp_path_factory):
    torch.manual_seed(0)
    body = toy_body()
    cfg = NetConfig(grid=GRID, outputs=OutputConfig.default((0.5, 1.0, 0.2), (0.3, 0.3, 0.1)))
    net = PressureNet(cfg, gendered_body(body, body))
    return save_model(tmp_path_factory.mktemp("model") / "m.safetensors", net, (body, body))


def test_estimate_one_image_and_a_batch(model_path):
    data = toy_dataset(3, grid=GRID)
    one = estimate(data["pressure"][0].numpy(), "f", model=model_path)
    assert one.betas.shape == (1, 10) and one.pose.shape == (1, 72) and one.joints.shape == (1, 24, 3)
    assert one.vertices.shape == (1, 192, 3) and one.q.shape == (1, 16, 16) and one.gender == ["f"]
    batch = estimate(data["pressure"], ["f", "male", "m"], model=model_path)
    assert len(batch) == 3 and batch.gender == ["f", "m", "m"]
    np.testing.assert_allclose(batch.joints[0], one.joints[0], atol=1e-5)


def test_estimate_reads_a_file_of_images_on_the_models_mat(model_path, tmp_path):
    """A path without a mat is read as infer reads it without --mat (.npy, .csv, .npz, .h5), not refused
    as text."""
    data = toy_dataset(2, grid=GRID)
    np.save(tmp_path / "images.npy", data["pressure"].numpy())
    from_file = estimate(tmp_path / "images.npy", "f", model=model_path)
    np.testing.assert_array_equal(from_file.joints, estimate(data["pressure"], "f", model=model_path).joints)
    assert len(estimate(str(tmp_path / "images.npy"), "m", model=model_path)) == 2
    with pytest.raises(BadInput, match="missing.npy"):
        estimate(tmp_path / "missing.npy", "f", model=model_path)


def test_estimate_splits_each_image_over_the_body_sites_under_its_body(model_path, tmp_path):
    from pressurepose.body.sites import NO_SITE, SITES, site_loads, vertex_sites

    data = toy_dataset(3, grid=GRID)
    est = estimate(data["pressure"], ["f", "m", "f"], model=model_path)
    p = est.pressure
    np.testing.assert_array_equal(est.sites.taxel_site != NO_SITE, p > 0)  # every loaded taxel, and only those
    np.testing.assert_allclose(est.sites.share.sum(1), 1.0)
    again = site_loads(p, est.vertices, est.faces, vertex_sites(toy_body()), GRID)  # the body's own sites, recomputed
    np.testing.assert_allclose(est.sites.share, again.share)
    np.testing.assert_allclose(est.sites.peak_mmhg.max(1), p.reshape(3, -1).max(1))
    assert est.vertex_pressure.shape == (3, 192) and est.vertex_pressure.max() <= p.max()
    assert dataclasses.replace(est, vertex_site=None).sites is None
    est.save(tmp_path)
    rec = json.loads((tmp_path / "sites.json").read_text())
    assert rec["sites"] == list(SITES) and len(rec["images"]) == 3
    assert rec["images"][1]["most_loaded"] == est.sites.most_loaded()[1]
    assert set(rec["images"][0]["sites"]) == set(SITES)
    assert sum(v["share"] for v in rec["images"][2]["sites"].values()) == pytest.approx(1.0, abs=1e-3)
    npz = np.load(tmp_path / "estimate.npz")
    np.testing.assert_allclose(npz["vertex_pressure"], est.vertex_pressure, rtol=1e-6)
    np.testing.assert_array_equal(npz["taxel_site"], est.sites.taxel_site)


def test_bad_inputs_are_refused(model_path, tmp_path):
    good = np.zeros((16, 16), np.float32)
    for bad, match in [(np.zeros((15, 16)), "shape"), (np.zeros((2, 3, 16, 16)), "shape"),
                       (np.full((16, 16), np.nan), "NaN"), (-np.ones((16, 16)), "negative"),
                       (np.array([["a"] * 16] * 16), "dtype")]:
        with pytest.raises(BadInput, match=match):
            estimate(bad, "f", model=model_path)
    with pytest.raises(BadInput, match="gender"):
        estimate(good, "x", model=model_path)
    with pytest.raises(BadInput, match="genders for"):
        estimate(np.zeros((2, 16, 16)), ["f"], model=model_path)
    with pytest.raises(BadInput, match="does not exist"):
        estimate(good, "f", model=tmp_path / "missing.safetensors")
    (tmp_path / "p.txt").write_text("1,2")
    with pytest.raises(BadInput, match="expected .npy"):
        load_pressure(tmp_path / "p.txt")
    (tmp_path / "p.csv").write_text("1,2\n3,oops\n")
    with pytest.raises(BadInput, match="could not be read"):
        load_pressure(tmp_path / "p.csv")


def _virtual(f, other, shape):
    layout = h5py.VirtualLayout(shape=shape, dtype="f4")
    layout[:] = h5py.VirtualSource(str(other), "pressure", shape=shape)
    f.create_virtual_dataset("pressure", layout)


# (case, how the file's 'pressure' is made given (file, the other file, image), what the refusal says)
BAD_HDF5 = [
    ("dangling-soft-link", lambda f, o, img: f.__setitem__("pressure", h5py.SoftLink("/nowhere")),
     r"'pressure' is a soft link to '/nowhere' \(a missing object\)"),
    ("soft-link", lambda f, o, img: (f.__setitem__("real", img), f.__setitem__("pressure", h5py.SoftLink("/real"))),
     "'pressure' is a soft link to '/real'"),
    ("external-link", lambda f, o, img: f.__setitem__("pressure", h5py.ExternalLink(str(o), "/pressure")),
     "'pressure' is an external link to '/pressure' in .*other.h5"),
    ("virtual-dataset", lambda f, o, img: _virtual(f, o, img.shape), "virtual dataset mapped from other files"),
    ("external-storage", lambda f, o, img: f.create_dataset("pressure", shape=img.shape, dtype="f4",
                                                            external=[(str(o.with_suffix(".bin")), 0, img.nbytes)]),
     "a dataset whose data lies in other files"),
    ("group", lambda f, o, img: f.create_group("pressure"), "'pressure' is a group"),
]


@pytest.mark.parametrize("case,build,message", BAD_HDF5, ids=[c[0] for c in BAD_HDF5])
def test_hdf5_pressure_must_be_stored_in_the_file(tmp_path, case, build, message):
    """Only data stored in the given file is read: links and virtual or external datasets, which
    reach into other files (or nowhere), are refused by name."""
    img = np.ones((2, 16, 16), np.float32)
    other = tmp_path / "other.h5"
    with h5py.File(other, "w") as f:
        f["pressure"] = img
    other.with_suffix(".bin").write_bytes(img.tobytes())
    with h5py.File(tmp_path / "x.h5", "w") as f:
        build(f, other, img)
    with pytest.raises(BadInput, match=message):
        load_pressure(tmp_path / "x.h5")


def test_infer_verb_on_npy_csv_and_hdf5(model_path, tmp_path, capsys):
    data = toy_dataset(2, grid=GRID)
    img = data["pressure"].numpy()
    np.save(tmp_path / "batch.npy", img)
    np.savetxt(tmp_path / "one.csv", img[0], delimiter=",")
    with h5py.File(tmp_path / "d.h5", "w") as f:
        f["images"] = img
        f["gender"] = np.array([b"m", b"f"])
    assert main(["infer", str(tmp_path / "batch.npy"), "--gender", "f,m", "--model", str(model_path),
                 "--out", str(tmp_path / "a")]) == 0
    rec = json.loads((tmp_path / "a" / "estimate.json").read_text())["estimates"]
    assert len(rec) == 2 and rec[1]["gender"] == "m" and len(rec[0]["pose"]) == 72
    assert len(rec[0]["joints"]) == 24
    npz = np.load(tmp_path / "a" / "estimate.npz")
    assert npz["vertices"].shape == (2, 192, 3)
    for name in ("mesh_000.ply", "mesh_001.ply", "estimate_000.png", "estimate_001.png"):
        assert (tmp_path / "a" / name).stat().st_size > 0
    err = capsys.readouterr().err  # pictures take about a second each: a progress bar over them
    assert "pictures: 100%" in err and "2/2" in err
    assert main(["infer", str(tmp_path / "one.csv"), "--gender", "m", "--model", str(model_path),
                 "--out", str(tmp_path / "b"), "--mesh-format", "obj", "--max-figures", "0"]) == 0
    assert "pictures" not in capsys.readouterr().err  # none drawn, no bar
    assert main(["infer", str(tmp_path / "batch.npy"), "--gender", "f,m", "--model", str(model_path),
                 "--out", str(tmp_path / "quiet"), "--no-progress"]) == 0
    err = capsys.readouterr().err  # the toy images' warnings, and no bar
    assert "pictures" not in err and "%|" not in err and (tmp_path / "quiet" / "estimate_001.png").exists()
    assert (tmp_path / "b" / "mesh_000.obj").exists() and not (tmp_path / "b" / "estimate_000.png").exists()
    b = json.loads((tmp_path / "b" / "estimate.json").read_text())["estimates"][0]
    np.testing.assert_allclose(b["joints"], rec[0]["joints"], atol=1e-4)  # same image; both genders are the toy body here
    assert main(["infer", str(tmp_path / "d.h5"), "--key", "images", "--model", str(model_path),
                 "--out", str(tmp_path / "c")]) == 0  # genders from the file
    # a `simulate` .npz (one gender for the file) and a training pack (gender codes) carry their genders
    np.savez(tmp_path / "sim.npz", pressure=img, gender=np.array("m"))
    np.savez(tmp_path / "pack.npz", pressure=img, gender=np.array([1, 0]))
    for name, genders in (("sim.npz", ["m", "m"]), ("pack.npz", ["m", "f"])):
        assert main(["infer", str(tmp_path / name), "--model", str(model_path), "--out", str(tmp_path / name[:-4]),
                     "--max-figures", "0"]) == 0
        got = json.loads((tmp_path / name[:-4] / "estimate.json").read_text())["estimates"]
        assert [r["gender"] for r in got] == genders
        if name == "sim.npz":  # image 1 read as "m", as in the .npy run
            np.testing.assert_allclose(got[1]["joints"], rec[1]["joints"], atol=1e-5)
    with pytest.raises(BadInput, match="is a folder; expected a file"):
        load_pressure(tmp_path / "a")
    assert [r["gender"] for r in json.loads((tmp_path / "c" / "estimate.json").read_text())["estimates"]] == ["m", "f"]
    # one image into the folder of two: the second image's mesh and picture do not stay behind
    (tmp_path / "a" / "notes.txt").write_text("mine")
    assert main(["infer", str(tmp_path / "one.csv"), "--gender", "m", "--model", str(model_path),
                 "--out", str(tmp_path / "a")]) == 0
    left = sorted(p.name for p in (tmp_path / "a").iterdir())
    assert left == ["estimate.json", "estimate.npz", "estimate_000.png", "mesh_000.ply", "notes.txt", "sites.json",
                    "sites_000.png"]
    for name in ("mesh_1000.ply", "estimate_1000.png", "sites_1000.png"):  # over 1000 images number with 4 digits
        (tmp_path / "a" / name).write_text("an earlier run's")
    assert main(["infer", str(tmp_path / "one.csv"), "--gender", "m", "--model", str(model_path),
                 "--out", str(tmp_path / "a")]) == 0
    assert sorted(p.name for p in (tmp_path / "a").iterdir()) == left
    assert main(["infer", str(tmp_path / "one.csv"), "--model", str(model_path), "--out", str(tmp_path / "d")]) == 2
    # bad input: a clear error and exit status 2
    np.save(tmp_path / "nan.npy", np.full((16, 16), np.nan))
    assert main(["infer", str(tmp_path / "nan.npy"), "--gender", "f", "--model", str(model_path),
                 "--out", str(tmp_path / "d")]) == 2
    assert main(["infer", str(tmp_path / "d.h5"), "--gender", "f", "--model", str(model_path),
                 "--out", str(tmp_path / "d")]) == 2  # no 'pressure' dataset in it
    assert main(["infer", str(tmp_path / "one.csv"), "--gender", "f", "--model", str(tmp_path / "nope.pt"),
                 "--out", str(tmp_path / "d")]) == 2
    # the body models can be named on the command line; they must be the ones trained with
    assert main(["infer", str(tmp_path / "one.csv"), "--gender", "f", "--model", str(model_path), "--out",
                 str(tmp_path / "e"), "--female", "toy", "--male", "toy"]) == 0
    assert main(["infer", str(tmp_path / "one.csv"), "--gender", "f", "--model", str(model_path), "--out",
                 str(tmp_path / "e"), "--female", "toy"]) == 2
    other = BodyModel(dataclasses.replace(toy_body_arrays(), v_template=1.1 * toy_body_arrays().v_template))
    save_body_arrays(tmp_path / "other.npz", other.arrays)
    assert main(["infer", str(tmp_path / "one.csv"), "--gender", "f", "--model", str(model_path), "--out",
                 str(tmp_path / "e"), "--female", str(tmp_path / "other.npz"), "--male", "toy"]) == 2
    err = capsys.readouterr().err
    assert "both --female and --male" in err and "not the one this model was trained with" in err
    assert "NaN" in err and "no dataset 'pressure'" in err and "does not exist" in err and "--gender is needed" in err


def test_estimate_warns_as_the_cli_does(model_path):
    data = toy_dataset(2, grid=GRID)
    img = data["pressure"].numpy().copy()
    img[1] *= 150.0 / img[1].max()  # peak 150 mmHg: above the sensor's 100
    with pytest.warns(UserWarning, match=r"pressure: image\(s\) 1 read above the sensor's range \(peak 150"):
        estimate(img, "f", model=model_path)
    img[0] = 0
    with pytest.warns(UserWarning) as caught:
        estimate(img, "f", model=model_path)
    said = sorted(str(w.message).split(";")[0] for w in caught)
    assert said == ["pressure: image(s) 0 are empty (every reading 0)",
                    "pressure: image(s) 1 read above the sensor's range (peak 150 > 100 mmHg)"]
    with pytest.raises(BadInput, match="far outside the sensor's range"):
        estimate(img * 20, "f", model=model_path)
    with pytest.raises(BadInput, match="give its mat"):
        estimate(img, "f", model=model_path, units="raw", weight_kg=70)


def test_images_at_or_below_the_contact_floor_are_warned_about(tmp_path, capsys):
    """A model with a contact floor drops readings at or below it: an image reading nothing above it
    is an empty mat to the model, which estimate() and infer say (only all-zero mats are refused)."""
    from pressurepose.net.transforms import InputConfig

    torch.manual_seed(0)
    body = toy_body()
    cfg = NetConfig(grid=GRID, outputs=OutputConfig.default((0.5, 1.0, 0.2), (0.3, 0.3, 0.1)),
                    inputs=InputConfig(contact_floor_mmhg=5.0))
    path = save_model(tmp_path / "floor.safetensors", PressureNet(cfg, gendered_body(body, body)), (body, body))
    img = toy_dataset(2, grid=GRID)["pressure"].numpy().copy()
    img[1] = np.where(img[1] > 0, 1.0, 0.0)  # the body's outline at 1 mmHg
    with pytest.warns(UserWarning, match=r"image\(s\) 1 read at most 1 mmHg, not above the model's contact floor "
                                         r"\(5 mmHg\).*sees an empty mat"):
        estimate(img, "f", model=path)
    np.save(tmp_path / "faint.npy", img[1:])
    assert main(["infer", str(tmp_path / "faint.npy"), "--gender", "f", "--model", str(path),
                 "--out", str(tmp_path / "o"), "--max-figures", "0"]) == 0
    assert "warning: " in capsys.readouterr().err and (tmp_path / "o" / "estimate.json").exists()
    import warnings

    with warnings.catch_warnings():  # images above the floor: no such warning
        warnings.simplefilter("error")
        estimate(img[:1] * (20 / img[0].max()), "f", model=path)


def test_estimate_and_infer_take_a_raw_recording_on_another_mat(model_path, tmp_path, capsys):
    """A recording on the BodiTrak mat in raw units, weight-normalised and resampled onto the model's
    16 x 16 mat; the model input carries the weight, and infer writes every frame and says so."""
    from pressurepose.data.resample import MMHG_PA
    from tests.data.realfolders import body_image

    frames = np.stack([body_image(64, 27, seed=s, scale=2.0) for s in range(7)])
    est = estimate(frames, "m", model=model_path, mat="boditrak_bt3510", units="raw", weight_kg=70)
    assert len(est) == 7 and est.frame.tolist() == list(range(7)) and est.pressure.shape == (7, 16, 16)
    force = est.pressure.sum((1, 2)) * MMHG_PA * GRID.taxel_area_m2  # the model's mat covers the BodiTrak's
    np.testing.assert_allclose(force, 70 * 9.80665, rtol=1e-4)
    flipped = estimate(frames[:, ::-1], "m", model=model_path, mat="boditrak_bt3510", units="raw", weight_kg=70,
                       head_row="last")
    np.testing.assert_allclose(flipped.joints, est.joints, atol=1e-5)
    np.save(tmp_path / "rec.npy", frames)
    out = tmp_path / "est"
    assert main(["infer", str(tmp_path / "rec.npy"), "--mat", "boditrak_bt3510", "--units", "raw", "--weight-kg",
                 "70", "--gender", "m", "--model", str(model_path), "--out", str(out), "--max-figures", "2"]) == 0
    printed = capsys.readouterr().out
    assert "7 estimate(s)" in printed and f"... and 2 more (all in {out / 'estimate.json'})" in printed
    assert (f"frames 0-6 of {tmp_path / 'rec.npy'} (counted from 0), on the boditrak_bt3510 mat, resampled onto the "
            f"model's 16 x 16") in printed
    saved = json.loads((out / "estimate.json").read_text())["estimates"]
    assert [r["frame"] for r in saved] == list(range(7))
    np.testing.assert_allclose([r["joints"] for r in saved], est.joints, atol=1e-5)
    assert sorted(p.name for p in out.glob("*.png")) == ["estimate_000.png", "estimate_001.png", "sites_000.png",
                                                         "sites_001.png"]
    # a recording on the model's own mat (a mat.json of its grid) is said to be on it, not resampled
    (tmp_path / "mat.json").write_text(json.dumps({"rows": 16, "cols": 16, "pitch_m": 0.125, "pitch_col_m": 0.0625}))
    np.save(tmp_path / "own.npy", np.stack([body_image(16, 16, seed=1, scale=2.0)]))
    assert main(["infer", str(tmp_path / "own.npy"), "--mat", str(tmp_path / "mat.json"), "--units", "mmHg",
                 "--gender", "m", "--model", str(model_path), "--out", str(tmp_path / "own"), "--max-figures", "0"]) == 0
    printed = capsys.readouterr().out
    assert "mat.json mat, the model's own" in printed and "resampled" not in printed
    # without a weight or a gain, with --units but no --mat, or --mat without --units: a clear error
    for extra, said in ((["--mat", "boditrak_bt3510", "--units", "raw"], "weight in kg (--weight-kg"),
                        (["--units", "raw", "--weight-kg", "70"], "give --mat too"),
                        (["--mat", "boditrak_bt3510"], "--mat needs --units")):
        assert main(["infer", str(tmp_path / "rec.npy"), "--gender", "m", "--model", str(model_path),
                     "--out", str(tmp_path / "bad"), *extra]) == 2
        assert said in capsys.readouterr().err


def test_the_estimates_maps_read_the_bodys_lower_surface(model_path):
    from pressurepose.net.pmr import SURFACE_CELL_M, lower_surface_map

    est = estimate(toy_dataset(3, grid=GRID)["pressure"], "f", model=model_path)
    low, _ = lower_surface_map(torch.tensor(est.vertices), torch.tensor(est.faces), est.grid, SURFACE_CELL_M, 1.0)
    low = low.numpy()
    assert (low < 0).any() and (low > 0).any()
    np.testing.assert_array_equal(est.contact, low < 0)  # no taxel under the sunk surface is left out
    np.testing.assert_allclose(est.q, 1000 * np.maximum(-low, 0), atol=1e-3)


def test_a_gender_or_model_of_the_wrong_type_is_refused_by_name(model_path):
    """None, a float or a dict as the gender, and a number or a dict as the model, are BadInput naming
    what was expected, not a TypeError (a dict's keys were read as genders)."""
    good = toy_dataset(1, grid=GRID)["pressure"][0].numpy()
    for gender in (None, 0.5, {"f": 1}, b"f", True):
        with pytest.raises(BadInput, match="expected f or m for all images, or a list of one per image"):
            estimate(good, gender, model=model_path)
    for model in (3, {}, ["m.json"]):
        with pytest.raises(BadInput, match=r"^model is \w+; expected a model file"):
            estimate(good, "f", model=model)
    # what load_model returns, passed whole: the message says which item to pass
    with pytest.raises(BadInput, match=r"^model is tuple; .*load_model returns \(network, record\): pass "
                                       r"load_model\(path\)\[0\], or the path itself"):
        estimate(good, "f", model=load_model(model_path))


def test_genders_stored_in_a_file_are_checked_naming_the_file(model_path, tmp_path, capsys):
    """infer without --gender reads the file's genders: codes of another shape, or names that are not
    genders, are refused naming the file (not a TypeError, nor a message that does not say where
    the gender came from)."""
    from pressurepose.net.infer import load_genders

    images = toy_dataset(2, grid=GRID)["pressure"].numpy()
    np.savez(tmp_path / "codes2d.npz", pressure=images, gender=np.array([[0, 1]]))
    np.savez(tmp_path / "names.npz", pressure=images, gender=np.array(["f", "x"]))
    with h5py.File(tmp_path / "shard.h5", "w") as f:
        f["pressure"] = images
        f["gender"] = np.array([b"f", b"q"])
    for name, message in (("codes2d.npz", r"'.*codes2d.npz': its genders have shape \(1, 2\); expected one, or one "
                                          r"per image"),
                          ("names.npz", r"'.*names.npz': gender 'x' is not known; expected f or m"),
                          ("shard.h5", r"HDF5 file '.*shard.h5': gender 'q' is not known; expected f or m")):
        with pytest.raises(BadInput, match=message):
            load_genders(tmp_path / name)
        assert main(["infer", str(tmp_path / name), "--model", str(model_path), "--out", str(tmp_path / "out")]) == 2
        assert "Traceback" not in capsys.readouterr().err
    assert not (tmp_path / "out").exists()
    np.savez(tmp_path / "good.npz", pressure=images, gender=np.array([1, 0]))
    assert load_genders(tmp_path / "good.npz") == ["m", "f"]
    np.savez(tmp_path / "one.npz", pressure=images, gender=np.array("f"))
    assert load_genders(tmp_path / "one.npz") == "f"


def test_save_mirror_and_bodies_of_the_wrong_kind_are_refused_by_name(model_path, tmp_path):
    """Estimate.save into a file or None was FileExistsError / TypeError; mirror='no' was true (the
    estimate mirror-averaged); bodies='female' was read letter by letter ("body model 'e'")."""
    good = toy_dataset(1, grid=GRID)["pressure"][0].numpy()
    est = estimate(good, "f", model=model_path)
    (tmp_path / "afile").write_text("x")
    with pytest.raises(BadInput, match="output folder .*afile is a file; expected a folder"):
        est.save(tmp_path / "afile")
    with pytest.raises(BadInput, match="output folder is None; expected a path"):
        est.save(None)
    with pytest.raises(BadInput, match="mirror is 'no'; expected True or False"):
        estimate(good, "f", model=model_path, mirror="no")
    with pytest.raises(BadInput, match=r"bodies is 'female'; expected \(female, male\) body model specs"):
        estimate(good, "f", model=model_path, bodies="female")


def test_an_image_is_named_by_its_frame_else_its_index():
    from types import SimpleNamespace

    from pressurepose.net.infer import Estimate

    assert Estimate.image_name(SimpleNamespace(frame=np.array([12, 40])), 1) == "frame 40"
    assert Estimate.image_name(SimpleNamespace(frame=None), 3) == "image 3"


def test_infer_without_pictures_does_not_load_matplotlib(tmp_path):
    """Pictures alone need matplotlib: `infer --max-figures 0` (either mesh format) does not import
    it, over half a second of start-up."""
    import subprocess
    import sys

    from pressurepose.net.infer import DEFAULT_MODEL

    if not DEFAULT_MODEL.is_file():
        pytest.skip("no shipped model")
    np.save(tmp_path / "one.npy", np.full((64, 27), 10, np.float32))
    code = ("import sys\nfrom pressurepose.cli import main\n"
            f"assert main(['infer', {str(tmp_path / 'one.npy')!r}, '--gender', 'f', '--max-figures', '0', '--out', "
            f"{str(tmp_path / 'out')!r}, '--mesh-format', sys.argv[1]]) == 0\n"
            "print('matplotlib' in sys.modules)\n")
    for fmt in ("ply", "obj"):
        out = subprocess.run([sys.executable, "-c", code, fmt], capture_output=True, text=True, check=True)
        assert out.stdout.strip().splitlines()[-1] == "False" and (tmp_path / "out" / f"mesh_000.{fmt}").is_file()
