"""Calibration: loss terms, data files, CMA-ES recovering hidden constants, settle stiffness, CLI."""

import json

import numpy as np
import pytest
import trimesh

from pressurepose.calibrate.measurements import (
    CapsuleMeasurements,
    load_measurements,
    save_measurements,
)
from pressurepose.calibrate.objects import (
    PhysicalTargets,
    bed_params,
    calibrate,
    calibrate_targets,
    calibration_loss,
    loss_terms,
    measurement_heightfields,
    minimize_cma,
    readings,
    with_params,
)
from pressurepose.cli import main
from pressurepose.errors import BadInput
from pressurepose.sim import GRAVITY, get_bed, press
from pressurepose.sim.bed import load_bed
from pressurepose.sim.press import mesh_centroid
from pressurepose.sim.stiffness import (
    capsule_mesh,
    fit_settle_stiffness,
    press_objects,
    stiffness_from_penetration,
)

FAST_BED = get_bed(press_cell_m=0.0143)  # 2 x 2 cells per taxel: quick enough for CMA-ES in a test


def synthetic_measurements(bed, hidden: dict) -> CapsuleMeasurements:
    """Four capsules of the paper's kind (20 and 40 cm long) measured on a bed with hidden constants."""
    rad = np.array([0.05, 0.075, 0.05, 0.075])
    length = np.array([0.2, 0.4, 0.2, 0.4])
    mass = np.array([2.3, 4.5, 14.0, 18.0])
    centre = np.array([[0.2, 0.4], [0.38, 0.9], [0.55, 1.3], [0.4, 1.6]])
    yaw = np.array([0.0, 0.3, 1.57, 0.1])
    blank = CapsuleMeasurements(bed.mat, rad, length, mass, centre, yaw, np.zeros((4,) + bed.mat.shape), np.ones(4))
    truth = with_params(bed, hidden)
    force, sink = press_objects(truth, measurement_heightfields(blank, bed), mass)
    return CapsuleMeasurements(bed.mat, rad, length, mass, centre, yaw, readings(force, truth), sink)


# ------------------------------------------------------------------ loss
def test_loss_terms_follow_the_paper():
    real = np.zeros((1, 4, 4))
    real[0, :2, :2] = 10.0
    t = loss_terms(real, [0.02], real, [0.02])
    assert all(v[0] == 0 for v in t.values())
    shifted = np.zeros((1, 4, 4))
    shifted[0, 2:, 2:] = 10.0  # same total, disjoint contact
    t = loss_terms(shifted, [0.04], real, [0.02])
    assert t["force"][0] == pytest.approx(0.5) and t["contact"][0] == pytest.approx(0.5)
    assert t["sink"][0] == pytest.approx(0.02 / 0.06)
    t = loss_terms(2 * real, [0.02], real, [0.02])  # twice the pressure on the same taxels
    assert t["force"][0] == pytest.approx(0.5 * 40 / 120 + 0.5 * 40 / 120) and t["contact"][0] == 0
    assert calibration_loss(np.zeros((2, 3, 3)), [0.0, 0.0], np.zeros((2, 3, 3)), [0.0, 0.0]) == 0.0


def test_capsule_mesh_lies_on_the_bed_as_described():
    v, f = capsule_mesh(0.06, 0.3, [0.4, 0.9], np.pi / 6)
    assert v[:, 2].min() == pytest.approx(0, abs=1e-12)
    vol, com = mesh_centroid(v, f)
    assert vol == pytest.approx(np.pi * 0.06 ** 2 * (0.18 + 4 / 3 * 0.06), rel=0.02)
    np.testing.assert_allclose(com, [0.4, 0.9, 0.06], atol=1e-9)
    axis = np.linalg.svd(v - com)[2][0]
    assert abs(abs(axis @ [np.cos(np.pi / 6), np.sin(np.pi / 6), 0]) - 1) < 1e-6
    ends = (v - com) @ axis
    assert np.ptp(ends) == pytest.approx(0.3, rel=1e-6)


# ------------------------------------------------------------------ data files
def test_measurement_files_round_trip_and_refuse_damage(tmp_path):
    data = synthetic_measurements(FAST_BED, {"stiffness": 5e4})
    path = tmp_path / "cal.npz"
    save_measurements(path, data)
    again = load_measurements(path)
    assert again.mat == data.mat
    for name in ("radius_m", "length_m", "mass_kg", "center_xy_m", "yaw_rad", "pressure_mmhg", "sink_m"):
        np.testing.assert_array_equal(getattr(again, name), getattr(data, name))
    path.write_bytes(path.read_bytes()[:200])
    with pytest.raises(BadInput, match="calibration data .* is (not a readable|corrupt)"):
        load_measurements(path)
    with pytest.raises(BadInput, match="does not exist"):
        load_measurements(tmp_path / "missing.npz")
    again_path = tmp_path / "again.npz"
    save_measurements(again_path, data)
    arrays = dict(np.load(again_path))
    del arrays["sink_m"]
    np.savez(tmp_path / "partial.npz", **arrays)
    with pytest.raises(BadInput, match="sink_m"):
        load_measurements(tmp_path / "partial.npz")


@pytest.mark.parametrize("field, value", [("version", np.array("abc")), ("mat_shape", np.array(["a", "b"])),
                                          ("max_mmhg", np.array("x")), ("mat_shape", np.array([64.5, 27.0]))])
def test_measurement_file_header_fields_are_checked_by_name(tmp_path, field, value):
    path = tmp_path / "cal.npz"
    save_measurements(path, synthetic_measurements(FAST_BED, {"stiffness": 5e4}))
    arrays = dict(np.load(path))
    arrays[field] = value
    np.savez(path, **arrays)
    with pytest.raises(BadInput, match=field):
        load_measurements(path)


@pytest.mark.parametrize("change, match", [
    (dict(radius_m=np.array([0.05, -0.1, 0.05, 0.05])), "radius_m"),
    (dict(length_m=np.array([0.05, 0.4, 0.2, 0.4])), "2 radius_m"),
    (dict(sink_m=np.ones(3)), "sink_m has shape"),
    (dict(pressure_mmhg=-np.ones((4, 64, 27))), "negative"),
    (dict(mass_kg=np.array([1, 2, np.nan, 4.0])), "NaN"),
])
def test_bad_measurements_are_named(change, match):
    base = dict(mat=get_bed().mat, radius_m=np.full(4, 0.05), length_m=np.full(4, 0.2), mass_kg=np.ones(4),
                center_xy_m=np.zeros((4, 2)), yaw_rad=np.zeros(4), pressure_mmhg=np.zeros((4, 64, 27)),
                sink_m=np.ones(4))
    with pytest.raises(BadInput, match=match):
        CapsuleMeasurements(**{**base, **change})


# ------------------------------------------------------------------ CMA-ES
def test_cma_es_recovers_hidden_bed_constants():
    """Honesty test: measurements made with hidden constants; the fit starts elsewhere and finds them."""
    hidden = {"stiffness": 4.5e4, "spread": 0.03, "c1": 1.3}
    data = synthetic_measurements(FAST_BED, hidden)
    start = bed_params(FAST_BED)
    assert abs(start["stiffness"] / hidden["stiffness"] - 1) > 0.2 and abs(start["c1"] - 1.3) > 0.2
    res = calibrate(data, FAST_BED, fit=("stiffness", "spread", "c1"), popsize=8, seed=0, max_evals=300,
                    tolfun=1e-5)
    assert res.fitted["stiffness"] == pytest.approx(hidden["stiffness"], rel=0.02)
    assert res.fitted["spread"] == pytest.approx(hidden["spread"], rel=0.05)
    assert res.fitted["c1"] == pytest.approx(hidden["c1"], rel=0.02)
    assert res.loss < 0.01 and res.history[-1] < res.history[0]
    assert res.bed.coupling_n_m == pytest.approx(res.fitted["stiffness"] * res.fitted["spread"] ** 2)


def test_cma_es_recovers_a_quadratic_sensor():
    hidden = {"c0": 4.0, "c1": 0.8, "c2": 0.006}
    data = synthetic_measurements(FAST_BED, hidden)
    res = calibrate(data, FAST_BED, fit=("c0", "c1", "c2"), popsize=16, seed=3, max_evals=3000, tolfun=1e-7)
    assert res.fitted["c0"] == pytest.approx(4.0, abs=0.3)
    assert res.fitted["c1"] == pytest.approx(0.8, abs=0.03)
    assert res.fitted["c2"] == pytest.approx(0.006, abs=5e-4)
    assert res.fitted["stiffness"] == FAST_BED.stiffness_n_m3  # not fitted, not touched


def test_same_seed_same_fit_and_bad_requests():
    def bowl(p):
        return (np.log10(p["stiffness"]) - 4.3) ** 2 + (p["c1"] - 2.0) ** 2

    start = bed_params(get_bed())
    a = minimize_cma(bowl, ("stiffness", "c1"), start, popsize=6, seed=11, max_evals=120)
    b = minimize_cma(bowl, ("stiffness", "c1"), start, popsize=6, seed=11, max_evals=120)
    c = minimize_cma(bowl, ("stiffness", "c1"), start, popsize=6, seed=12, max_evals=120)
    assert a[0] == b[0] and a[5] == b[5] and a[0] != c[0]
    assert a[0]["c1"] == pytest.approx(2.0, abs=0.05)
    with pytest.raises(BadInput, match="cannot fit"):
        minimize_cma(bowl, ("stiffness", "damping"), start)
    with pytest.raises(BadInput, match="popsize"):
        minimize_cma(bowl, ("stiffness",), start, popsize=2)


def test_physical_targets_fix_the_stiffness():
    body = trimesh.creation.capsule(height=1.2, radius=0.15, count=[24, 24])
    body.apply_transform(trimesh.transformations.rotation_matrix(np.pi / 2, [1, 0, 0]))
    body.apply_translation([0.39, 0.9, 0.15])
    bed = get_bed(coupling_n_m=0.0, press_cell_m=0.0143)
    goal = PhysicalTargets(max_sink_m=0.05, peak_mmhg=1e9, mass_kg=50.0)  # only the sink can be met
    res = calibrate_targets(body.vertices, body.faces, goal, bed, fit=("stiffness",), popsize=6, seed=0,
                            max_evals=150, tolfun=1e-9)
    assert press(body.vertices, body.faces, 50.0, res.bed).sink_m == pytest.approx(0.05, rel=0.01)


# ------------------------------------------------------------------ settle stiffness (A.5)
def test_fit_settle_stiffness_finds_the_hidden_constant():
    areas = np.array([0.02, 0.05, 0.08])
    weights = np.array([30.0, 90.0, 150.0])
    hidden = 7.3e4
    measured = weights / (hidden * areas)  # flat boxes on a Winkler bed sink W / (k A)
    fit = fit_settle_stiffness(measured, lambda k: weights / (k * areas))
    assert fit.stiffness == pytest.approx(hidden, rel=1e-3)
    assert np.abs(fit.relative_error).max() < 1e-3
    # with the press as the model, from sinks measured on a bed with a hidden stiffness
    truth = get_bed(stiffness_n_m3=hidden, coupling_n_m=0.0)
    caps = [capsule_mesh(0.06, 0.3, [0.4, 0.6 + 0.4 * i], 0.0) for i in range(2)]
    masses = [5.0, 15.0]
    sinks = [press(v, f, m, truth).sink_m for (v, f), m in zip(caps, masses)]
    fit = fit_settle_stiffness(sinks, lambda k: [press(v, f, m, get_bed(stiffness_n_m3=k, coupling_n_m=0.0)).sink_m
                                                 for (v, f), m in zip(caps, masses)], bounds=(3e4, 3e5))
    assert fit.stiffness == pytest.approx(hidden, rel=5e-3)
    with pytest.raises(BadInput):
        fit_settle_stiffness([-0.01], lambda k: [0.01])
    with pytest.raises(BadInput, match="shape"):
        fit_settle_stiffness([0.01, 0.02], lambda k: [0.01])


def test_paper_average_stiffness():
    assert stiffness_from_penetration([10.0, 30.0], [0.01, 0.02]) == pytest.approx((1000 + 1500) / 2)
    with pytest.raises(BadInput):
        stiffness_from_penetration([10.0], [0.0])


# ------------------------------------------------------------------ CLI
def test_calibrate_verb_writes_a_loadable_bed(tmp_path, capsys):
    data = synthetic_measurements(FAST_BED, {"stiffness": 5e4, "spread": 0.02})
    path = tmp_path / "cal.npz"
    save_measurements(path, data)
    out, plot = tmp_path / "bed.json", tmp_path / "fit.png"
    code = main(["calibrate", "--data", str(path), "--fit", "stiffness,spread", "--popsize", "6",
                 "--max-evals", "12", "--seed", "1", "--out", str(out), "--plot", str(plot)])
    assert code == 0 and plot.stat().st_size > 1000
    record = json.loads(out.read_text())
    assert record["evaluations"] >= 12 and record["source"]["objects"] == 4
    bed = load_bed(out)
    assert bed.stiffness_n_m3 == pytest.approx(record["fitted"]["stiffness"])
    assert bed.mat == data.mat
    assert "wrote" in capsys.readouterr().out
    assert main(["calibrate", "--data", str(tmp_path / "none.npz")]) == 2
    (tmp_path / "junk.json").write_text("{")
    with pytest.raises(BadInput, match="JSON"):
        load_bed(tmp_path / "junk.json")


def test_total_force_of_calibration_objects_is_their_weight():
    data = synthetic_measurements(FAST_BED, {})
    force, sink = press_objects(FAST_BED, measurement_heightfields(data, FAST_BED), data.mass_kg)
    # all four objects lie inside the sensing area: the mat sees all their weight
    np.testing.assert_allclose(force.sum((1, 2)), data.mass_kg * GRAVITY, rtol=1e-6)
    assert np.all(sink > 0)


def test_supine_body_lies_head_first_face_up():
    from pressurepose.body import BodyModel
    from pressurepose.body.joints import JOINT_NAMES
    from pressurepose.body.toy import toy_body_arrays
    from pressurepose.calibrate.objects import supine_body_mesh

    body = BodyModel(toy_body_arrays())
    bed = get_bed()
    v, f, j = supine_body_mesh(body, bed, arm_drop_rad=0.0)
    assert v[:, 2].min() == pytest.approx(0.0, abs=1e-12)
    np.testing.assert_allclose((v.max(0) + v.min(0))[:2] / 2, [bed.mat.width_m / 2, bed.mat.length_m / 2])
    idx = {n: JOINT_NAMES.index(n) for n in ("head", "pelvis", "left_ankle", "left_wrist", "right_wrist", "neck")}
    assert j[idx["head"], 1] < j[idx["pelvis"], 1] < j[idx["left_ankle"], 1]  # head toward row 0
    assert j[idx["left_wrist"], 0] < j[idx["right_wrist"], 0]                 # body's left toward -x
    # face up: the toy's neck box leans forward (-y in its own frame), so the head sits above the neck
    _, joints = body.forward(np.zeros(body.num_betas), np.zeros(72))
    forward = joints[0, idx["head"]] - joints[0, idx["neck"]]
    assert np.sign(j[idx["head"], 2] - j[idx["neck"], 2]) == np.sign(-forward[1])
    lowered, _, _ = supine_body_mesh(body, bed)  # arms at the sides: narrower across the bed
    assert np.ptp(lowered[:, 0]) < 0.6 * np.ptp(v[:, 0])


def test_calibrate_verb_with_default_targets_runs(tmp_path):
    from pressurepose.body.smpl_io import save_body_arrays
    from pressurepose.body.toy import toy_body_arrays

    model = tmp_path / "toy.npz"
    save_body_arrays(model, toy_body_arrays())
    out = tmp_path / "bed.json"
    code = main(["calibrate", "--targets", "default", "--body", str(model), "--popsize", "4", "--max-evals", "4",
                 "--out", str(out)])
    assert code == 0
    record = json.loads(out.read_text())
    assert record["source"]["targets"]["max_sink_m"] == 0.065 and record["evaluations"] >= 4
    assert load_bed(out).mat == get_bed().mat
