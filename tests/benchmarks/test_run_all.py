"""The maintained set: ``make bench`` runs every benchmarks/bench_*.py, each parses --help, and no
benchmark imports another (only the shared helpers common.py and results.py)."""

import ast
import importlib
from pathlib import Path

import pytest

from benchmarks.run_all import BENCHMARKS

FOLDER = Path(__file__).resolve().parents[2] / "benchmarks"
FILES = sorted(p.stem for p in FOLDER.glob("bench_*.py"))


def test_run_all_runs_every_benchmark_file():
    assert FILES and sorted({name for name, _ in BENCHMARKS}) == FILES


@pytest.mark.parametrize("name", FILES)
def test_each_benchmark_parses_help(name, capsys):
    module = importlib.import_module(f"benchmarks.{name}")
    with pytest.raises(SystemExit) as exc:
        module.main(["--help"])
    assert exc.value.code == 0
    assert "usage:" in capsys.readouterr().out


@pytest.mark.parametrize("name", FILES + ["common", "run_all"])
def test_benchmarks_import_only_the_shared_helpers(name):
    tree = ast.parse((FOLDER / f"{name}.py").read_text())
    imported = {node.module for node in ast.walk(tree) if isinstance(node, ast.ImportFrom) and node.module}
    imported |= {a.name for node in ast.walk(tree) if isinstance(node, ast.Import) for a in node.names}
    own = {m for m in imported if m.split(".")[0] == "benchmarks"}
    assert own <= {"benchmarks.common", "benchmarks.results"}, own


def test_sampler_fidelity_skips_without_the_public_file(monkeypatch, capsys):
    bench = importlib.import_module("benchmarks.bench_sampler_fidelity")
    monkeypatch.setattr(bench, "official_path", lambda given=None: None)
    assert bench.main(["--no-write"]) == 0
    assert "bench_sampler_fidelity: skipped" in capsys.readouterr().out
