"""benchmarks/bench_realism.py: it judges the simulated images it is given (none made here), skips
without real data, and names bad arguments."""

import numpy as np
import pytest

from benchmarks.bench_realism import main
from tests.data.realfolders import write_labelled
from tests.eval.test_realism import MAT, SUPINE_ROOT, body


def _sets(tmp_path):
    rng = np.random.default_rng(0)
    real = np.stack([body() * rng.uniform(0.9, 1.1) for _ in range(6)])
    write_labelled(tmp_path / "real", real, ["supine"] * 6, {"preset": "boditrak_bt3510", "units": "mmHg"})
    sim = np.stack([body(), body(head=False), body()])  # head imprint 2 / 3: under the goal's 0.8
    force = sim * MAT.taxel_area_m2 * 133.322
    pose = np.zeros((3, 72))
    pose[:, :3] = SUPINE_ROOT
    np.savez(tmp_path / "sim.npz", pressure=sim, force=force, pose=pose, mass=force.sum((1, 2)) / 9.81,
             height=np.full(3, 1.75))
    return tmp_path / "real", tmp_path / "sim.npz"


def test_judges_the_images_it_is_given(tmp_path, capsys):
    real, sim = _sets(tmp_path)
    assert main(["--real", str(real), "--synthetic", str(sim), "--out", str(tmp_path / "out"), "--no-write"]) == 0
    out = capsys.readouterr().out
    assert "| supine | head imprint rate | 0.67 | >= 0.8 | no |" in out
    assert out.count("| supine | contact area ratio |") == 2  # as drawn and like postures
    assert "issue" not in out.lower()
    assert not (tmp_path / "out").exists()  # nothing generated


def test_without_real_data_it_skips_and_succeeds(tmp_path, capsys, monkeypatch):
    monkeypatch.delenv("PRESSUREPOSE_PMD", raising=False)
    assert main(["--out", str(tmp_path), "--no-write"]) == 0
    assert "skipped" in capsys.readouterr().out
    assert main(["--real", str(tmp_path / "absent"), "--out", str(tmp_path), "--no-write"]) == 0
    assert "is not a folder" in capsys.readouterr().out


@pytest.mark.parametrize("argv, match", [(["--seeds", "a"], "--seeds 'a'"), (["--count", "0"], "--count"),
                                         (["--synthetic", "/no/such/set"], "bench_realism: .*does not exist")])
def test_bad_arguments_are_named(argv, match, tmp_path):
    real, _ = _sets(tmp_path)
    with pytest.raises(SystemExit, match=match):
        main(argv + ["--real", str(real), "--no-write", "--out", str(tmp_path / "out")])
