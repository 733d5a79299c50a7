"""The real-pose benchmark without the SLP fits: it says so and succeeds, writing nothing."""

from benchmarks import bench_real_poses


def test_absent_fits_are_a_clear_skip(tmp_path, capsys, monkeypatch):
    monkeypatch.delenv("PRESSUREPOSE_SLP_FITS", raising=False)
    assert bench_real_poses.main(["--fits", str(tmp_path / "none.npz")]) == 0
    assert "skipped" in capsys.readouterr().out
    assert bench_real_poses.main([]) == 0
    assert "give --fits" in capsys.readouterr().out


def test_floor_at_full_size_is_the_whole_sets_distance():
    import numpy as np

    from pressurepose.pose.fidelity import end_joint_distances

    rng = np.random.default_rng(0)
    fit, held = (np.concatenate([np.zeros((n, 3)), rng.normal(0, 0.2, (n, 69))], 1) for n in (12, 9))
    whole = end_joint_distances(fit, held)
    floor = bench_real_poses.floor_at(fit, held, len(fit), seed=3)
    assert np.isclose(floor.mean, whole.mean) and np.allclose(floor.by_axis, whole.by_axis)
    few = bench_real_poses.floor_at(fit, held, 3, seed=3)
    assert few.by_axis.shape == whole.by_axis.shape and not np.isclose(few.mean, whole.mean)
