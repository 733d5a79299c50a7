"""The realism-goals benchmark: it judges the sets it finds (none made here) and names bad arguments."""

import numpy as np
import pytest

from benchmarks.bench_realism_goals import main
from benchmarks.bench_spine import PARTITIONS
from tests.data.realfolders import write_labelled
from tests.eval.test_realism import MAT, SUPINE_ROOT, body


def test_judges_the_sets_it_finds(tmp_path, capsys):
    rng = np.random.default_rng(0)
    real = np.stack([body() * rng.uniform(0.9, 1.1) for _ in range(6)])
    write_labelled(tmp_path / "real", real, ["supine"] * 6, {"preset": "boditrak_bt3510", "units": "mmHg"})
    sim = np.stack([body(), body(head=False), body()])  # head imprint 2 / 3: under the goal's 0.8
    force = sim * MAT.taxel_area_m2 * 133.322
    pose = np.zeros((3, 72))
    pose[:, :3] = SUPINE_ROOT
    folder = tmp_path / "sets" / "paper" / "s5"
    folder.mkdir(parents=True)
    for partition in PARTITIONS:  # present, so nothing is settled
        for g in "fm":
            np.savez(folder / f"{partition}_{g}.npz", pressure=sim, force=force, pose=pose,
                     mass=force.sum((1, 2)) / 9.81, height=np.full(3, 1.75), attempts=3, cpu_s=1.0)
    assert main(["--real", str(tmp_path / "real"), "--seeds", "5", "--count", "3", "--out", str(tmp_path / "sets"),
                 "--no-write"]) == 0
    out = capsys.readouterr().out
    assert "| supine | head imprint rate | 0.67 | >= 0.8 | no |" in out
    assert out.count("| supine | contact area ratio |") == 2  # as drawn and like postures


@pytest.mark.parametrize("argv, match", [(["--seeds", "a"], "--seeds 'a'"), (["--count", "0"], "--count"),
                                         (["--real", "/no/such/folder"], "--real: .*does not exist")])
def test_bad_arguments_are_named(argv, match, tmp_path):
    with pytest.raises(SystemExit, match=match):
        main(argv + ["--no-write", "--out", str(tmp_path)])
