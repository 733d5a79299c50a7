"""The real-pose benchmark without the SLP fits: it says so and succeeds, writing nothing."""

from benchmarks import bench_real_poses


def test_absent_fits_are_a_clear_skip(tmp_path, capsys, monkeypatch):
    monkeypatch.delenv("PRESSUREPOSE_SLP_FITS", raising=False)
    assert bench_real_poses.main(["--fits", str(tmp_path / "none.npz")]) == 0
    assert "skipped" in capsys.readouterr().out
    assert bench_real_poses.main([]) == 0
    assert "give --fits" in capsys.readouterr().out
