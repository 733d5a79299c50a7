"""Real-image evaluation: posture class of estimated bodies, stature and mass, contact IoU, and the
`evaluate-real` verb end to end on a labelled folder the test writes."""

import json

import numpy as np
import pytest

from pressurepose.body import BodyModel
from pressurepose.body.joints import JOINT_NAMES
from pressurepose.body.toy import toy_body_arrays
from pressurepose.errors import BadInput
from pressurepose.eval import posture as ps
from pressurepose.pose.root import root_axis_angle, world_rotation

TOY = BodyModel(toy_body_arrays())


def _poses(rolls, yaw=0.3):
    pose = np.zeros((len(rolls), 72))
    pose[:, :3] = root_axis_angle(world_rotation(np.asarray(rolls), np.full(len(rolls), yaw)))
    return pose


def test_posture_class_from_known_roll_and_the_side_it_lies_on():
    deg = np.deg2rad([0, 30, -30, 90, 60, -90, -60, 180, -170])
    assert ps.posture_of(_poses(deg)).tolist() == ["supine", "supine", "supine", "left", "left", "right", "right",
                                                   "prone", "prone"]
    # 'left' means lying on the left side: the left shoulder is the lower one
    _, joints = TOY.forward(np.zeros((2, 10)), _poses(np.deg2rad([90, -90])))
    l, r = JOINT_NAMES.index("left_shoulder"), JOINT_NAMES.index("right_shoulder")
    assert joints[0, l, 2] < joints[0, r, 2] and joints[1, r, 2] < joints[1, l, 2]
    correct = ps.posture_correct(["lateral", "lateral", "left", "supine"], ["left", "right", "right", "supine"])
    assert correct.tolist() == [True, True, False, True]
    conf = ps.confusion(["left", "left", "supine"], ["supine", "left", "supine"])
    assert conf == {"left": {"supine": 1, "left": 1, "right": 0, "prone": 0},
                    "supine": {"supine": 1, "left": 0, "right": 0, "prone": 0}}


def test_stature_and_mass_of_the_zero_pose_body_match_the_body_model():
    betas = np.array([[0.0] * 10, [1.5] + [0.0] * 9, [-1.5, 0.5] + [0.0] * 8])
    layer = TOY.torch_layer()
    v = ps.zero_pose_vertices(layer, betas)
    np.testing.assert_allclose(ps.stature(v), TOY.height(betas), rtol=1e-5)
    np.testing.assert_allclose(ps.mass(v, TOY.faces), TOY.mass(betas), rtol=1e-4)
    # a box 2 m tall: stature 2, volume 0.5 x 0.25 x 2 = 0.25 m^3 -> 250 kg
    import trimesh

    box = trimesh.creation.box(extents=(0.5, 0.25, 2.0))
    assert ps.stature(box.vertices[None])[0] == pytest.approx(2.0)
    assert ps.mass(box.vertices[None], box.faces)[0] == pytest.approx(250.0)


def test_contact_iou():
    a = np.zeros((2, 4, 4), bool)
    b = np.zeros((2, 4, 4), bool)
    a[0, :2], b[0, 1:3] = True, True  # 4 shared of 12
    np.testing.assert_allclose(ps.contact_iou(a, b), [1 / 3, 1.0])


def test_evaluate_real_verb_on_a_labelled_folder(tmp_path, capsys):
    from pressurepose.cli import main
    from pressurepose.net.infer import DEFAULT_MODEL
    from tests.data.realfolders import body_image, write_labelled

    if not DEFAULT_MODEL.is_file():
        pytest.skip("no shipped model")
    imgs = np.stack([body_image(64, 27, seed=i, scale=20) for i in range(4)])
    folder = write_labelled(tmp_path / "lab", imgs, ["supine", "lateral", "supine", "left"],
                            {"preset": "boditrak_bt3510", "units": "mmHg"}, heights=[1.6, 1.7, 1.8, 1.9],
                            weights=[60, 70, 80, 90], genders=["f", "m", "f", "m"])
    out = tmp_path / "out"
    assert main(["evaluate-real", str(folder), "--out", str(out)]) == 0
    err = capsys.readouterr().err
    assert "batch" in err  # a progress bar while the network reads the images, then a line while the gallery is drawn
    assert f"drawing {out / 'gallery.png'} (2 best and 2 worst estimates) ..." in err.splitlines()
    m = json.loads((out / "metrics.json").read_text())
    assert m["n_images"] == 4 and m["n_estimates"] == 4 and m["layout"] == "labelled"
    rows = json.loads((out / "estimates.json").read_text())["rows"]
    acc = np.mean([r["correct"] for r in rows])
    assert m["posture_accuracy"] == pytest.approx(acc)
    assert m["stature_mae_m"] == pytest.approx(np.mean([abs(r["stature_m"] - r["height_m"]) for r in rows]))
    assert [r["body_model"] for r in rows] == ["f", "m", "f", "m"]
    assert set(m["per_subject"]) == {"s0", "s1"}
    assert sum(c for row in m["confusion"].values() for c in row.values()) == 4
    assert 0 <= m["contact_iou"] <= 1 and (out / "gallery.png").stat().st_size > 0
    report = (out / "report.md").read_text()
    assert "| supine |" in report and "## By subject" in report
    for subject in ("s0", "s1"):  # each subject's measured size beside the mean estimate
        mine = [r for r in rows if r["subject"] == subject]
        ps_ = m["per_subject"][subject]
        assert ps_["height_m"] == pytest.approx(np.mean([r["height_m"] for r in mine]))
        assert ps_["weight_kg"] == pytest.approx(np.mean([r["weight_kg"] for r in mine]))
        assert ps_["stature_mean_m"] == pytest.approx(np.mean([r["stature_m"] for r in mine]))
        assert f"| {subject} | {ps_['n']} | {ps_['height_m']:.2f} |" in report
    # without a gender both body models estimate each image
    folder2 = write_labelled(tmp_path / "lab2", imgs[:2], ["supine", "right"], {"preset": "boditrak_bt3510",
                                                                                 "units": "mmHg"})
    assert main(["evaluate-real", str(folder2), "--out", str(tmp_path / "out2")]) == 0
    m2 = json.loads((tmp_path / "out2" / "metrics.json").read_text())
    assert m2["n_images"] == 2 and m2["n_estimates"] == 4 and set(m2["by_body_model"]) == {"f", "m"}
    assert main(["evaluate-real", str(folder2), "--out", str(tmp_path / "out3"), "--mirror"]) == 0
    m3 = json.loads((tmp_path / "out3" / "metrics.json").read_text())
    assert m3["mirror"] is True and m2["mirror"] is False and m3["n_estimates"] == 4
    assert main(["evaluate-real", str(folder2), "--out", str(tmp_path / "out4"), "--fit"]) == 0
    m4 = json.loads((tmp_path / "out4" / "metrics.json").read_text())
    assert m4["fit"] is True and m2["fit"] is False and m4["n_estimates"] == 4


def test_evaluate_real_bad_inputs(tmp_path, capsys):
    from pressurepose.cli import main

    (tmp_path / "empty").mkdir()
    assert main(["evaluate-real", str(tmp_path / "empty"), "--out", str(tmp_path / "o")]) == 2
    assert "neither a PMD experiment folder" in capsys.readouterr().err
    (tmp_path / "file").write_text("x")
    assert main(["evaluate-real", str(tmp_path / "empty"), "--out", str(tmp_path / "file")]) == 2
    assert "is a file" in capsys.readouterr().err


def test_raw_images_reach_the_model_carrying_the_body_weight(tmp_path):
    from pressurepose.data.readers.real import read_real
    from pressurepose.data.resample import MMHG_PA
    from pressurepose.eval.real import RealEvalConfig, evaluate_real
    from pressurepose.net.infer import DEFAULT_MODEL, resolve_model
    from tests.data.realfolders import body_image, write_labelled

    if not DEFAULT_MODEL.is_file():
        pytest.skip("no shipped model")
    imgs = np.stack([body_image(64, 27, seed=i, scale=400) for i in range(2)])
    folder = write_labelled(tmp_path / "raw", imgs, ["supine", "right"], {"preset": "boditrak_bt3510", "units": "raw"},
                            weights=[60, 90], genders=["f", "m"])
    real = read_real(folder)
    res = evaluate_real(real, resolve_model(None), RealEvalConfig())
    force = res.input.sum((1, 2)) * MMHG_PA * 0.0286 ** 2
    np.testing.assert_allclose(force, np.array([60, 90]) * 9.80665, rtol=1e-4)
    assert res.summary["n_estimates"] == 2 and res.skipped == {"inclined_bed": 0, "weak_recording": 0}


def test_evaluate_real_takes_the_model_as_estimate_does(tmp_path):
    """None (the shipped model) or a model file, as estimate()'s model: no loading by hand first."""
    from pressurepose.data.readers.real import read_real
    from pressurepose.eval.real import evaluate_real
    from pressurepose.net.infer import DEFAULT_MODEL, resolve_model
    from tests.data.realfolders import body_image, write_labelled

    if not DEFAULT_MODEL.is_file():
        pytest.skip("no shipped model")
    imgs = np.stack([body_image(64, 27, seed=i, scale=400) for i in range(2)])
    real = read_real(write_labelled(tmp_path / "raw", imgs, ["supine", "right"],
                                    {"preset": "boditrak_bt3510", "units": "raw"}, weights=[60, 90], genders=["f", "m"]))
    loaded = evaluate_real(real, resolve_model(None))
    for net in (None, DEFAULT_MODEL):
        np.testing.assert_array_equal(evaluate_real(real, net).estimate.joints, loaded.estimate.joints)


def test_wedge_postures_are_summarised_apart_as_well():
    """summarise() keeps every image in its headline and adds the scores without the wedge postures."""
    from pressurepose.eval.real import format_real_table, is_wedge, summarise

    detail = np.array(["supine", "left side", "left 30 deg (wedge)", "right 60 deg (wedge)"])
    posture = np.array(["supine", "left", "left", "right"])
    predicted = np.array(["supine", "left", "supine", "supine"])
    n = len(detail)
    rows = {"image": np.arange(n), "subject": np.array(["S1"] * n), "posture": posture, "detail": detail,
            "source": np.array(["pmd"] * n), "body_model": np.array(["f"] * n), "predicted": predicted,
            "scored": np.ones(n, bool), "correct": ps.posture_correct(posture, predicted),
            "roll_deg": np.array([2.0, 80.0, 20.0, -30.0]), "stature_m": np.full(n, 1.7), "height_m": np.full(n, 1.75), "stature_err_m": np.full(n, -0.05),
            "mass_kg": np.full(n, 60.0), "weight_kg": np.full(n, 62.0), "mass_err_kg": np.full(n, -2.0),
            "contact_iou": np.full(n, 0.5)}
    assert is_wedge(detail).tolist() == [False, False, True, True]
    s = summarise(rows)
    assert s["posture_accuracy"] == 0.5 and s["without_wedge"]["posture_accuracy"] == 1.0
    assert s["without_wedge"]["n"] == 2
    assert s["abs_roll_median_deg"] == 25.0 and s["without_wedge"]["abs_roll_median_deg"] == 41.0
    assert "all but the wedge postures" in format_real_table(s)
    no_wedge = summarise({k: v[:2] for k, v in rows.items()})
    assert no_wedge["without_wedge"] is None and "wedge" not in format_real_table(no_wedge)


def test_wedge_postures_are_scored_by_the_direction_of_the_turn():
    """A body propped toward its left is read right when the estimate turns at least 15 degrees to its
    left (positive roll), whatever posture class that makes; 'lateral' takes either side."""
    from pressurepose.eval.real import summarise, turn_toward_label, wedge_angle

    detail = np.array(["left 30 deg (wedge)", "left 30 deg (wedge)", "right 60 deg (wedge)",
                       "right 60 deg (wedge)", "turned part-way (wedge)", "supine"])
    posture = np.array(["left", "left", "right", "right", "lateral", "supine"])
    roll = np.array([20.0, -5.0, -50.0, 10.0, -16.0, 3.0])
    n = len(detail)
    assert turn_toward_label(posture, roll)[:5].tolist() == [20.0, -5.0, 50.0, -10.0, 16.0]
    assert np.isnan(turn_toward_label(posture, roll)[5])
    assert [wedge_angle(d) for d in detail] == ["30", "30", "60", "60", "", ""]
    rows = {"image": np.arange(n), "subject": np.array(["S1", "S1", "S2", "S2", "S2", "S1"]), "posture": posture,
            "detail": detail, "source": np.array(["pmd"] * n), "body_model": np.array(["f"] * n),
            "predicted": np.array(["supine"] * n), "scored": np.ones(n, bool),
            "correct": ps.posture_correct(posture, np.array(["supine"] * n)), "roll_deg": roll,
            "stature_m": np.full(n, 1.7), "height_m": np.array([1.75, 1.75, 1.95, 1.95, 1.95, 1.75]),
            "stature_err_m": np.full(n, -0.05), "mass_kg": np.full(n, 60.0), "weight_kg": np.full(n, 62.0),
            "mass_err_kg": np.full(n, -2.0), "contact_iou": np.full(n, 0.5), "load_kg": np.full(n, 61.0),
            "mat_length_m": np.full(n, 1.8)}
    s = summarise(rows)
    assert s["wedge"]["n"] == 5 and s["wedge"]["turned_right_way"] == 3 / 5
    assert s["wedge"]["median_turn_deg"] == {"unknown": 16.0, "30": 7.5, "60": 20.0}
    assert s["per_subject"]["S1"]["wedge_turned_right_way"] == 0.5
    assert s["per_subject"]["S2"]["wedge_turned_right_way"] == 2 / 3
    assert s["per_subject"]["S1"]["flat_bed_posture_accuracy"] == 1.0
    assert s["per_subject"]["S2"]["flat_bed_posture_accuracy"] is None
    assert s["taller_than_mat"] == 0.5 and s["mat_length_m"] == 1.8 and s["load_kg_mean"] == 61.0
    assert s["flat_bed_by_posture"] == {"supine": 1.0}  # the wedge postures are not flat-bed side-lying


def test_contact_iou_threshold_defaults_to_the_models_contact_floor():
    """The IoU's input contact means what the model's contact channel means: its floor (5 mmHg for the
    shipped model), 2 mmHg for a model without one, or the value asked for."""
    import types

    from pressurepose.errors import BadInput
    from pressurepose.eval.real import RealEvalConfig, contact_threshold

    def net(floor):
        return types.SimpleNamespace(config=types.SimpleNamespace(inputs=types.SimpleNamespace(contact_floor_mmhg=floor)))

    assert contact_threshold(net(5.0), RealEvalConfig()) == 5.0
    assert contact_threshold(net(0.0), RealEvalConfig()) == 2.0
    assert contact_threshold(net(5.0), RealEvalConfig(contact_mmhg=1.0)) == 1.0
    with pytest.raises(BadInput):
        RealEvalConfig(contact_mmhg=-1.0)


def test_a_frame_gets_the_same_estimate_from_evaluate_real_estimate_and_infer(tmp_path):
    """One road: a PMD-I frame scored by evaluate-real, given to estimate() as a recording, and given
    to `infer --mat` gives one body, to float tolerance."""
    from pressurepose.cli import main
    from pressurepose.data.readers.real import read_real
    from pressurepose.eval.real import RealEvalConfig, evaluate_real
    from pressurepose.net.infer import DEFAULT_MODEL, estimate, resolve_model
    from tests.data.realfolders import write_pmd_i

    if not DEFAULT_MODEL.is_file():
        pytest.skip("no shipped model")
    root = write_pmd_i(tmp_path / "pmd", subjects=(1,), postures=(1, 2), frames=5)  # subject 1 weighs 71 kg
    net = resolve_model(None)
    res = evaluate_real(read_real(root, frames="all"), net, RealEvalConfig(gender="m"))
    path = root / "S1" / "2.txt"
    mine = res.rows["source"] == str(path)
    assert res.rows["frame"][mine].tolist() == [2, 3, 4]
    est = estimate(path, "m", model=net, mat="fsa_softflex_2048", units="raw", weight_kg=71)
    assert est.frame.tolist() == [2, 3, 4]
    np.testing.assert_allclose(est.pressure, res.input[mine], atol=1e-5)
    np.testing.assert_allclose(est.joints, res.estimate.joints[mine], atol=1e-4)
    np.testing.assert_allclose(est.betas, res.estimate.betas[mine], atol=1e-4)
    assert main(["infer", str(path), "--mat", "fsa_softflex_2048", "--units", "raw", "--weight-kg", "71",
                 "--gender", "m", "--out", str(tmp_path / "est"), "--max-figures", "0"]) == 0
    saved = json.loads((tmp_path / "est" / "estimate.json").read_text())["estimates"]
    assert [r["frame"] for r in saved] == [2, 3, 4]
    np.testing.assert_allclose([r["joints"] for r in saved], res.estimate.joints[mine], atol=1e-4)
    # another weight is another input: the road does use it
    heavy = estimate(path, "m", model=net, mat="fsa_softflex_2048", units="raw", weight_kg=142)
    np.testing.assert_allclose(heavy.pressure.sum((1, 2)), 2 * est.pressure.sum((1, 2)), rtol=0.05)


def test_metrics_json_is_strict_json(tmp_path):
    """NaN (a subject without a measured height, a correlation over no spread) is written as null."""
    import dataclasses

    from pressurepose.eval.real import RealEvaluation
    from pressurepose.mat import get_mat

    ev = RealEvaluation(rows={}, estimate=None, input=np.zeros((0, 64, 27)),
                        summary={"stature_mae_m": float("nan"), "per_subject": {"1": {"height_m": np.float32("nan"),
                                                                                      "n": np.int64(3)}}},
                        skipped={"inclined_bed": 0, "weak_recording": 0}, n_images=3, contact_mmhg=5.0,
                        layout="pmd-ii", mat=get_mat("boditrak_bt3510"), units="raw", gain=None)
    assert dataclasses.is_dataclass(ev)
    text = ev.write_metrics(tmp_path / "metrics.json", data="x", mirror=False).read_text()
    assert "NaN" not in text
    m = json.loads(text, parse_constant=lambda c: pytest.fail(f"non-strict JSON constant {c}"))
    assert m["stature_mae_m"] is None and m["per_subject"]["1"] == {"height_m": None, "n": 3}
    assert m["data"] == "x" and m["mat"] == "boditrak_bt3510" and m["n_images"] == 3 and m["gain"] is None


def test_evaluate_real_refuses_what_is_not_real_images_or_its_config(tmp_path):
    """A folder path, an array or None where RealImages go, and a dict as the config, were an
    AttributeError; RealEvalConfig's numbers and flags of the wrong type a TypeError or silently true."""
    from pressurepose.eval.real import RealEvalConfig, evaluate_real
    from tests.data.realfolders import body_image, write_labelled

    folder = write_labelled(tmp_path / "raw", body_image(64, 27, seed=1, scale=400)[None], ["supine"],
                            {"preset": "boditrak_bt3510", "units": "raw"}, weights=[60], genders=["f"])
    for real in (str(folder), folder, np.zeros((1, 64, 27)), None):
        with pytest.raises(BadInput, match=r"^real is \w+; expected RealImages, as read_real\(folder\)"):
            evaluate_real(real)
    from pressurepose.data.readers.real import read_real

    with pytest.raises(BadInput, match="config is dict; expected a RealEvalConfig"):
        evaluate_real(read_real(folder), config={})
    for field, value, message in (("contact_mmhg", "1", r"contact_mmhg \(--contact-mmhg\) is '1'"),
                                  ("weak_fraction", "0.1", "weak_fraction is '0.1'; expected a share"),
                                  ("weak_fraction", None, "weak_fraction is None"),
                                  ("batch_size", 0, r"batch_size \(--batch-size\) is 0"),
                                  ("mirror", "no", "mirror is 'no'; expected True or False"),
                                  ("force_gender", 1, "force_gender is 1")):
        with pytest.raises(BadInput, match=message):
            RealEvalConfig(**{field: value})
