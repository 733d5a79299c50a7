"""The relaxed-limbs benchmark's own arithmetic, on files whose answers are known."""

import numpy as np
import pytest

from benchmarks.bench_relaxed_limbs import (
    FEET,
    HANDS,
    air_and_cost,
    damping_of,
    label,
    main,
)


def _set(path, wrist_z, ankle_z, attempts, cpu_s):
    n = len(wrist_z)
    joints = np.zeros((n, 24, 3))
    joints[:, HANDS, 2] = np.asarray(wrist_z, float)[:, None]
    joints[:, FEET, 2] = np.asarray(ankle_z, float)[:, None]
    np.savez(path, joints=joints, mass=np.full(n, 60.0), attempts=attempts, cpu_s=cpu_s)
    return path


def test_hands_in_the_air_and_cost_per_accepted_body(tmp_path):
    a = _set(tmp_path / "a.npz", [0.0, 0.3, 0.05], [0.0, 0.0, 0.2], attempts=6, cpu_s=3.0)
    b = _set(tmp_path / "b.npz", [0.15], [0.0], attempts=2, cpu_s=1.0)
    out = air_and_cost([a, b])
    assert out["hands"] == pytest.approx(2 / 4)    # 0.3 and 0.15 of 0, 0.3, 0.05, 0.15 (both wrists alike)
    assert out["feet"] == pytest.approx(1 / 4)
    assert out["hand_z"] == pytest.approx(0.1)     # median of 0, 0.05, 0.15, 0.3
    assert out["attempts"] == pytest.approx(8 / 4)
    assert out["cpu"] == pytest.approx(4.0 / 4)


def test_damping_names():
    assert damping_of("paper") is None and damping_of("3") == 3.0
    assert label("paper") == "15 s (paper)" and label("3.0") == "3 s"


@pytest.mark.parametrize("argv, match", [(["--damping", "paper,soft"], "--damping 'soft'"),
                                         (["--damping", "-1"], "--damping '-1'"),
                                         (["--seeds", "a"], "--seeds 'a'")])
def test_bad_arguments_are_named(argv, match):
    with pytest.raises(SystemExit, match=match):
        main(argv + ["--no-write"])
