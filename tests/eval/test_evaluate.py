import json

import numpy as np
import pytest
import torch

from pressurepose.cli import main
from pressurepose.errors import BadInput
from pressurepose.eval.metrics import baseline_body, mpjpe
from pressurepose.eval.report import evaluate, format_table, roll_errors
from pressurepose.net.checkpoint import gendered_body, save_model
from pressurepose.net.data import load_dataset
from pressurepose.net.infer import estimate
from pressurepose.net.model import NetConfig, PressureNet
from pressurepose.net.outputs import OutputConfig
from tests.net.synth import BODITRAK, toy_body, write_toy_dataset

torch.set_num_threads(1)


@pytest.fixture(scope="module")
def setup(tmp_path_factory):
    root = tmp_path_factory.mktemp("eval")
    data = write_toy_dataset(root / "data", n=4)
    torch.manual_seed(0)
    body = toy_body()
    net = PressureNet(NetConfig(grid=BODITRAK, outputs=OutputConfig.default((0.4, 0.9, 0.1), (0.3, 0.3, 0.1))),
                      gendered_body(body, body))
    path = save_model(root / "model.safetensors", net, (body, body))
    return root, data, path


def test_dataset_adapter(setup):
    root, data, _ = setup
    loaded = load_dataset(root / "data")
    assert len(loaded) == 4 and loaded.grid == BODITRAK and loaded.mat == "boditrak_bt3510"
    assert torch.equal(loaded.tensors["gender"], data["gender"])
    assert torch.allclose(loaded.tensors["joints"], data["joints"])
    assert [loaded.partition_names[i] for i in loaded.tensors["partition"]] == [
        "general_supine", "supine_straight_limbs"] * 2
    with pytest.raises(BadInput):
        load_dataset(root / "nothing")


def test_evaluate_matches_direct_computation(setup):
    root, data, path = setup
    est = estimate(data["pressure"], ["fm"[int(g)] for g in data["gender"]], model=path)
    from pressurepose.net.infer import resolve_model

    result = evaluate(load_dataset(root / "data"), resolve_model(path), batch_size=3)
    np.testing.assert_allclose(result["errors"]["mod2_mpjpe"], mpjpe(est.joints, data["joints"].numpy()), atol=1e-6)
    body = toy_body()
    b, p, t = baseline_body(body.forward, BODITRAK)
    _, bj = body.forward(b, p, t)
    np.testing.assert_allclose(result["errors"]["baseline_mpjpe"], mpjpe(np.repeat(bj, 4, 0), data["joints"].numpy()),
                               atol=1e-5)
    from pressurepose.eval.posture import posture_of

    correct = posture_of(est.pose) == posture_of(data["pose"].numpy())
    np.testing.assert_array_equal(result["errors"]["posture_correct"], correct)
    np.testing.assert_allclose(result["errors"]["stature_err"],
                               body.height(est.betas) - body.height(data["betas"].numpy()), atol=1e-5)
    s = result["summary"]
    assert s["all"]["posture_accuracy"] == pytest.approx(correct.mean())
    assert s["all"]["stature_bias_cm"] == pytest.approx(100 * result["errors"]["stature_err"].mean())
    roll_err, turn_err = roll_errors(est.pose, data["pose"].numpy())
    np.testing.assert_allclose(result["errors"]["roll_err"], roll_err, atol=1e-3)
    assert s["all"]["roll_mae_deg"] == pytest.approx(np.abs(roll_err).mean(), abs=1e-3)
    assert s["all"]["turn_bias_deg"] == pytest.approx(turn_err.mean(), abs=1e-3)
    assert s["all"]["count"] == 4 and s["gender:f"]["count"] + s["gender:m"]["count"] == 4
    assert s["partition:general_supine"]["count"] == 2
    table = format_table(s)
    assert "mean-pose baseline" in table and "supine_straight_limbs" in table and "posture acc." in table
    assert "turn bias (deg)" in table


def test_evaluate_takes_a_model_path_and_a_dataset_path(setup):
    """As estimate() does: a model file or the shipped model, and a dataset folder, not only loaded ones."""
    root, _, path = setup
    from pressurepose.net.infer import resolve_model

    by_path = evaluate(root / "data", path)
    loaded = evaluate(load_dataset(root / "data"), resolve_model(path))
    np.testing.assert_array_equal(by_path["errors"]["mod2_mpjpe"], loaded["errors"]["mod2_mpjpe"])
    assert evaluate(root / "data")["summary"]["all"]["count"] == 4  # the shipped model


def test_evaluate_refuses_a_dataset_of_another_mat(setup):
    from pressurepose.mat import custom_mat
    from pressurepose.net.data import LoadedData
    from pressurepose.net.infer import resolve_model

    root, data, path = setup
    other = custom_mat(rows=64, cols=32, pitch_row_m=0.028)
    tensors = dict(data, pressure=torch.zeros(4, 64, 32), partition=torch.zeros(4, dtype=torch.long))
    with pytest.raises(BadInput, match=r"dataset's mat \(fsa, 64 x 32 taxels at 28 x 28 mm\) is not the model's "
                                        r"\(boditrak_bt3510, 64 x 27 taxels at 28.6 x 28.6 mm\)"):
        evaluate(LoadedData(tensors, other, "fsa", ("general_supine",)), path)
    # a mat of the model's rows and cols at another pitch: its images show bodies at another scale
    finer = custom_mat(rows=64, cols=27, pitch_row_m=0.02)
    with pytest.raises(BadInput, match=r"\(custom, 64 x 27 taxels at 20 x 20 mm\) is not the model's "
                                        r"\(boditrak_bt3510, 64 x 27 taxels at 28.6 x 28.6 mm\): evaluate a model"):
        evaluate(LoadedData(dict(data, partition=torch.zeros(4, dtype=torch.long)), finer, "custom",
                            ("general_supine",)), path)
    with pytest.raises(BadInput, match="data come first"):
        evaluate(resolve_model(path), root / "data")


def _rolled(deg: float) -> np.ndarray:
    """(72,) a zero pose with the root rolled by ``deg`` about the body's long axis."""
    from pressurepose.pose.root import root_axis_angle, world_rotation

    pose = np.zeros(72)
    pose[:3] = root_axis_angle(world_rotation(np.radians(deg), 0.0))[0]
    return pose


def test_roll_errors_wrap_and_tell_a_flatter_reading():
    est = np.stack([_rolled(50.0), _rolled(-170.0), _rolled(-10.0)])
    true = np.stack([_rolled(70.0), _rolled(175.0), _rolled(0.0)])
    roll_err, turn_err = roll_errors(est, true)
    np.testing.assert_allclose(roll_err, [-20.0, 15.0, -10.0], atol=1e-6)  # -170 is 15 past 175, not -345
    np.testing.assert_allclose(turn_err, [-20.0, -5.0, 10.0], atol=1e-6)   # 50 for 70: read flatter


def test_evaluate_verb_shows_a_bar_unless_told_not_to(setup, capsys):
    root, _, path = setup
    args = ["evaluate", "--model", str(path), "--data", str(root / "data")]
    assert main(args) == 0
    assert "evaluate: 100%" in capsys.readouterr().err
    assert main([*args, "--no-progress"]) == 0
    assert capsys.readouterr().err == ""


def test_evaluate_verb(setup, capsys):
    root, _, path = setup
    assert main(["evaluate", "--model", str(path), "--data", str(root / "data"), "--out", str(root / "rep")]) == 0
    rep = json.loads((root / "rep" / "report.json").read_text())
    assert rep["summary"]["all"]["count"] == 4
    report = (root / "rep" / "report.md").read_text()
    assert "| PressureNet (Mod1 + Mod2) |" in report and "reading: the network\n" in report
    assert "turn bias: |estimated roll| less |true roll|" in report  # every column is said in words
    assert "MPJPE" in capsys.readouterr().out
    assert main(["evaluate", "--model", str(root / "missing.pt"), "--data", str(root / "data")]) == 2
    assert main(["evaluate", "--model", str(path), "--data", str(root / "data"), "--out", str(root / "rep_m"),
                 "--mirror"]) == 0
    rep_m = json.loads((root / "rep_m" / "report.json").read_text())
    assert rep_m["mirror"] is True and rep["mirror"] is False and rep_m["summary"]["all"]["count"] == 4
    assert "reading: the network, mirror-averaged (--mirror)\n" in (root / "rep_m" / "report.md").read_text()
    assert rep_m["summary"]["all"]["mod2"] != rep["summary"]["all"]["mod2"]  # an untrained net is not symmetric
    assert main(["evaluate", "--model", str(path), "--data", str(root / "data"), "--out", str(root / "rep_f"),
                 "--fit"]) == 0
    rep_f = json.loads((root / "rep_f" / "report.json").read_text())
    assert rep_f["fit"] is True and rep["fit"] is False and rep_f["summary"]["all"]["count"] == 4
    assert rep_f["summary"]["all"]["mod2"] != rep["summary"]["all"]["mod2"]  # Mod2's bodies moved
    assert rep_f["summary"]["all"]["mod1"] == rep["summary"]["all"]["mod1"]  # Mod1's did not


def test_evaluate_refuses_a_mirror_flag_that_is_not_true_or_false(tmp_path):
    """mirror='no' was true: the errors of mirror-averaged estimates, silently."""
    import pytest

    from pressurepose.errors import BadInput
    from pressurepose.eval.report import evaluate
    from pressurepose.net.data import load_dataset
    from tests.net.synth import write_toy_dataset

    write_toy_dataset(tmp_path / "data", n=2)
    data = load_dataset(tmp_path / "data")
    with pytest.raises(BadInput, match="mirror is 'no'; expected True or False"):
        evaluate(data, mirror="no")


def test_evaluate_checks_a_loaded_data_built_by_hand(setup):
    """A hand-built LoadedData was trusted: NaN labels or negative pressure gave NaN or wrong errors,
    a gender of 2 or a partition past its names an IndexError, a missing field a KeyError, images of
    the wrong size a RuntimeError. Each is refused naming the field, as a training pack is; float64
    and int32 tensors are read as load_dataset's float32 and int64."""
    from pressurepose.net.data import LoadedData, check_loaded

    root, _, path = setup
    good = load_dataset(root / "data")
    t, names = good.tensors, good.partition_names

    def changed(**fields):
        return LoadedData({k: v for k, v in {**t, **fields}.items() if v is not None}, good.grid, good.mat, names)

    nan_pose = t["pose"].clone()
    nan_pose[1, 5] = float("nan")
    negative = t["pressure"].clone()
    negative[0, 3, 4] = -1.0
    for data, message in ((changed(pose=nan_pose), "LoadedData: pose holds NaN or infinite values"),
                          (changed(pressure=negative), "LoadedData: pressure holds negative values"),
                          (changed(gender=torch.tensor([0, 1, 2, 0])),
                           r"gender must be 0 or 1 \(female, male\); it holds \[2\]"),
                          (changed(partition=torch.tensor([0, 1, 999, 0])), "partition must be an index of its"),
                          (changed(joints=None), "LoadedData: tensors lack joints"),
                          (changed(betas=t["betas"][:3]), r"betas has shape \(3, 10\); expected \(4, 10\)"),
                          (changed(pressure=t["pressure"][:, :60]), r"pressure has shape \(4, 60, 27\); expected "
                                                                    r"\(4, 64, 27\)"),
                          (changed(transl=[[0.0] * 3] * 4), r"tensors\['transl'\] is list; expected a torch tensor")):
        with pytest.raises(BadInput, match=message):
            evaluate(data, path)
    with pytest.raises(BadInput, match="partition_names is 'general'"):
        evaluate(LoadedData(t, good.grid, good.mat, "general"), path)
    cast = check_loaded(changed(pressure=t["pressure"].double(), gender=t["gender"].int()))
    assert cast.tensors["pressure"].dtype == torch.float32 and cast.tensors["gender"].dtype == torch.int64
    np.testing.assert_array_equal(evaluate(cast, path)["errors"]["mod2_mpjpe"],
                                  evaluate(good, path)["errors"]["mod2_mpjpe"])


def _bar(err: str, desc: str) -> bool:
    """Whether ``err`` holds a tqdm bar labelled ``desc``."""
    import re

    return re.search(rf"{desc}: +\d+%\|", err) is not None


def test_the_functions_that_run_over_a_dataset_or_recording_show_a_bar_and_estimate_does_not(setup, capsys):
    """evaluate, evaluate_real and monitor show a progress bar on stderr by default, none with
    progress=False; estimate (called per image or frame) shows none by default."""
    from pressurepose.data.readers.recording import read_recording
    from pressurepose.eval.monitor import frame_times, monitor
    from pressurepose.eval.real import RealEvalConfig, evaluate_real

    root, data, path = setup
    frames = data["pressure"].numpy()
    genders = ["fm"[int(g)] for g in data["gender"]]
    calls = {"evaluate": lambda **kw: evaluate(root / "data", path, **kw),
             "monitor": lambda **kw: monitor(frames, frame_times(len(frames), fps=1.0), "f", path, **kw),
             "infer": lambda **kw: evaluate_real(read_recording(frames, "boditrak_bt3510", "mmHg"), path,
                                                 RealEvalConfig(gender="f"), **kw)}
    for desc, call in calls.items():
        capsys.readouterr()
        call()
        assert _bar(capsys.readouterr().err, desc), desc
        call(progress=False)
        assert capsys.readouterr().err == "", desc
    estimate(frames, genders, model=path)
    assert capsys.readouterr().err == ""
