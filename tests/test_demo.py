"""`pressurepose demo` (the README's main job) runs the whole pipeline with the shipped model."""

import re

from pressurepose.cli import main
from pressurepose.net.infer import DEFAULT_MODEL


def test_demo_runs_the_whole_pipeline(tmp_path, capsys):
    assert DEFAULT_MODEL.is_file(), "the shipped PressureNet is missing: run tools/train_shipped_model.py"
    assert main(["demo", "--out", str(tmp_path), "--seed", "1"]) == 0
    out = capsys.readouterr().out
    for stage in ("sample + settle", "+ press", "estimate pose and shape"):
        assert stage in out
    mpjpe = float(re.search(r"MPJPE ([0-9.]+) cm", out).group(1))
    assert 0 < mpjpe < 100  # a real, finite error in cm (accuracy is measured in benchmarks/)
    assert (tmp_path / "demo.png").stat().st_size > 20_000



def test_demo_refuses_a_body_model_its_network_cannot_read(capsys):
    for gender in ("n", "x"):
        assert main(["demo", "--out", "unused", "--gender", gender]) == 2
        assert "expected f or m" in capsys.readouterr().err
