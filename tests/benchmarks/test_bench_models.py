"""benchmarks/bench_models.py: models side by side, rows from the evaluate reports, kept reports reused."""

import argparse
import json

import pytest
import torch

import benchmarks.bench_models as bench
from pressurepose.net.checkpoint import gendered_body, save_model
from pressurepose.net.model import NetConfig, PressureNet
from pressurepose.net.outputs import OutputConfig
from tests.net.synth import BODITRAK, toy_body, write_toy_dataset


def _model(path, seed):
    torch.manual_seed(seed)
    body = toy_body()
    net = PressureNet(NetConfig(grid=BODITRAK, outputs=OutputConfig.default((0.4, 0.9, 0.1), (0.3, 0.3, 0.1))),
                      gendered_body(body, body))
    return save_model(path, net, (body, body))


def test_rows_come_from_the_reports_and_are_reused(tmp_path, capsys, monkeypatch):
    write_toy_dataset(tmp_path / "data", n=4)
    a, b = _model(tmp_path / "a.safetensors", 0), _model(tmp_path / "b.safetensors", 1)
    out = tmp_path / "out"
    argv = ["--model", f"a={a}", "--model", f"b={b}", "--test", str(tmp_path / "data"), "--out", str(out)]
    assert bench.main(argv) == 0
    lines = [ln for ln in capsys.readouterr().out.splitlines() if ln.startswith("| a |") or ln.startswith("| b |")]
    assert len(lines) == 2
    for line, name in zip(lines, "ab"):
        s = json.loads((out / name / "test" / "report.json").read_text())["summary"]
        cells = [c.strip() for c in line.strip("|").split("|")]
        assert cells[1] == f"{s['all']['mod2']['mpjpe_cm']:.2f}" and cells[4:] == ["-"] * 8
        assert len(cells) == bench.HEADER.count(" | ") + 1
    # a second run reads the kept reports: evaluate is not called again
    monkeypatch.setattr(bench, "_cli", lambda *a: pytest.fail(f"evaluated again: {a}"))
    assert bench.main(argv) == 0


def test_model_arguments_are_checked():
    assert bench.parse_model("x=path/m.json") == ("x", "path/m.json")
    for bad in ("path/m.json", "=m.json", "x="):
        with pytest.raises(argparse.ArgumentTypeError):
            bench.parse_model(bad)
    with pytest.raises(SystemExit):
        bench.main(["--model", "a=x", "--model", "a=y", "--test", "t"])


def test_real_columns_count_the_wedge_postures():
    test = {"all": {"mod2": {"mpjpe_cm": 10.0}, "posture_accuracy": 0.9},
            "partition:general": {"mod2": {"mpjpe_cm": 12.0}, "baseline": {"mpjpe_cm": 30.0}}}
    detail = {k: {"n": 26, "posture_accuracy": 0.5} for k in bench.WEDGE}
    detail.update({"left side": {"n": 26, "posture_accuracy": 0.92}, "right side": {"n": 26, "posture_accuracy": 1.0}})
    real = {"per_detail": detail, "posture_accuracy": 0.8, "stature_mae_m": 0.077, "stature_bias_m": -0.03,
            "stature_r": -0.2}
    cells = [c.strip() for c in bench.row("m", test, None, real).strip("|").split("|")]
    assert cells == ["m", "10.00", "0.40", "0.90", "-", "-", "-", "0.80", "52 / 104", "0.92 / 1.00", "7.7 (-3.0)",
                     "-0.20"]
    extra = {"partition:general_lateral": {"mod2": {"mpjpe_cm": 15.0}, "posture_accuracy": 0.8, "turn_bias_deg": -7.2},
             "partition:propped_lateral": {"mod2": {"mpjpe_cm": 16.0}, "posture_accuracy": 0.7, "turn_bias_deg": -8.34}}
    cells = [c.strip() for c in bench.row("m", test, extra, real).strip("|").split("|")]
    assert cells[4:7] == ["15.00 / 0.80", "16.00 / 0.70", "-7.2 / -8.3"]
    assert len(cells) == bench.HEADER.count("|") - 1


def _rows(correct, err):
    details = ["supine", "left 30 deg (wedge)", "left side", "right 60 deg (wedge)"]
    return [{"image": i, "body_model": "f", "subject": str(i % 3), "detail": details[i % 4], "scored": True,
             "correct": bool(c), "stature_err_m": e} for i, (c, e) in enumerate(zip(correct, err))]


def test_paired_differences_resample_whole_subjects():
    base = _rows([1, 0, 1, 0, 1, 0], [0.05] * 6)
    same = bench.paired_differences(base, base, draws=200)
    assert all(v == (0.0, 0.0, 0.0) for v in same.values())
    # the other model reads two of the three wedge images right (1 and 3, not 5) and is 1 cm closer everywhere
    other = _rows([1, 1, 1, 1, 1, 0], [0.04] * 6)
    d = bench.paired_differences(base, other, draws=500)
    assert d["posture"][0] == pytest.approx(2 / 6) and d["wedge"][0] == pytest.approx(2 / 3)
    assert d["stature_m"] == pytest.approx((-0.01, -0.01, -0.01))
    lo, hi = d["posture"][1:]
    assert 0 <= lo <= 2 / 6 <= hi <= 1  # resampling 3 subjects moves the share, never below no gain
    with pytest.raises(SystemExit):
        bench.paired_differences(base, other[:5])
