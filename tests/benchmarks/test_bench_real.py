"""benchmarks/bench_real.py: the section comes from evaluate-real's report; without real data the
benchmark skips and succeeds."""

import torch

from benchmarks.bench_real import main
from pressurepose.net.checkpoint import gendered_body, save_model
from pressurepose.net.model import NetConfig, PressureNet
from pressurepose.net.outputs import OutputConfig
from tests.data.realfolders import write_pmd_i
from tests.net.synth import BODITRAK, toy_body


def _model(path):
    torch.manual_seed(0)
    body = toy_body()
    net = PressureNet(NetConfig(grid=BODITRAK, outputs=OutputConfig.default((0.4, 0.9, 0.1), (0.3, 0.3, 0.1))),
                      gendered_body(body, body))
    return save_model(path, net, (body, body))


def test_without_real_data_it_skips_and_succeeds(tmp_path, capsys, monkeypatch):
    monkeypatch.delenv("PRESSUREPOSE_PMD", raising=False)
    assert main(["--out", str(tmp_path), "--no-write"]) == 0
    assert "bench_real: skipped" in capsys.readouterr().out
    assert not any(tmp_path.iterdir())


def test_section_from_the_real_report(tmp_path, capsys, monkeypatch):
    real = write_pmd_i(tmp_path / "pmd")
    monkeypatch.setenv("PRESSUREPOSE_PMD", str(real))  # the default of --real
    model = _model(tmp_path / "m.safetensors")
    assert main(["--model", str(model), "--synthetic", "0", "--out", str(tmp_path / "out"), "--no-write"]) == 0
    out = capsys.readouterr().out
    assert (tmp_path / "out" / "real" / "metrics.json").is_file()
    assert "## PressureNet on real images" in out and "| posture | n | posture acc." in out
    assert "Posture confusion" in out and "By subject" in out
    assert "skipped 2 inclined-bed recordings" in out  # posture 15 of both subjects
