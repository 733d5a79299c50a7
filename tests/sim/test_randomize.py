"""Domain randomisation: draws within their ranges, the moved mat's frame, the sensor threshold,
and randomised samples stored with their conditions."""

import math

import numpy as np
import pytest
import trimesh

from pressurepose.errors import BadInput
from pressurepose.sim import get_bed, press
from pressurepose.sim.randomize import (
    CONDITION_NAMES,
    Conditions,
    RandomizationRanges,
    draw_conditions,
)
from pressurepose.sim.sensor import read_sensor


def test_draws_lie_in_their_ranges_and_follow_the_generator():
    bed = get_bed()
    draws = np.array([draw_conditions(np.random.default_rng(i), bed).as_array() for i in range(300)])
    k, e, gain, thr, dx, dy, turn = draws.T
    assert np.all((k >= 0.6 * bed.stiffness_n_m3) & (k <= 1.6 * bed.stiffness_n_m3))
    assert np.all((e >= 1.5e3) & (e <= 6e3)) and np.all((gain >= 0.75) & (gain <= 1.25))
    assert np.all((thr >= 0) & (thr <= 4)) and np.abs(draws[:, 4:6]).max() <= 0.05
    assert np.abs(turn).max() <= math.radians(3) and np.ptp(turn) > math.radians(4)
    assert abs(np.median(np.log(k / bed.stiffness_n_m3)) - np.log(0.6 * 1.6) / 2) < 0.1  # log-uniform
    again = draw_conditions(np.random.default_rng(7), bed).as_array()
    np.testing.assert_array_equal(again, draws[7])
    assert len(CONDITION_NAMES) == draws.shape[1]
    with pytest.raises(BadInput, match="sensor_gain"):
        RandomizationRanges(sensor_gain=(1.2, 0.8))


def test_draws_about_a_fitted_bed_keep_its_tissue_and_threshold():
    """On a bed of its own (``generate --bed``) the tissue modulus is drawn about the bed's and the
    threshold above the bed's; the same generator draws the same factors as on the default bed."""
    bed = get_bed(tissue_modulus_pa=900.0, sensor_threshold_mmhg=1.0)
    for i in range(50):
        a = draw_conditions(np.random.default_rng(i), get_bed())
        b = draw_conditions(np.random.default_rng(i), bed)
        assert 450.0 <= b.tissue_modulus_pa <= 1800.0 and 1.0 <= b.sensor_threshold_mmhg <= 5.0
        assert b.tissue_modulus_pa == pytest.approx(a.tissue_modulus_pa * 0.3)
        assert b.sensor_threshold_mmhg == pytest.approx(a.sensor_threshold_mmhg + 1.0)
        assert b.sensor_gain == a.sensor_gain and b.mat_rotation_rad == a.mat_rotation_rad


def test_a_mat_moved_one_taxel_sees_the_body_one_taxel_over():
    """Shifting the mat by one taxel pitch under a body (no other change) shifts the image by one
    column and one row; the body's labels move the other way in the mat's frame."""
    bed = get_bed()
    pitch = bed.mat.pitch_col_m
    box = trimesh.creation.box(extents=[0.2, 0.4, 0.1])
    box.apply_translation([0.3 + 0.5 * pitch, 0.8 + 0.5 * pitch, 0.05])
    v, f = np.asarray(box.vertices), np.asarray(box.faces)
    cond = Conditions(bed.stiffness_n_m3, bed.tissue_modulus_pa, 1.0, 0.0, pitch, pitch, 0.0)
    moved = cond.body_motion(bed)
    v2 = v @ moved[:3, :3].T + moved[:3, 3]
    np.testing.assert_allclose(v2 - v, np.tile([-pitch, -pitch, 0.0], (len(v), 1)), atol=1e-12)
    a = press(v, f, 20.0, bed)
    b = press(v2, f, 20.0, cond.bed(bed))
    np.testing.assert_allclose(b.pressure[:-1, :-1], a.pressure[1:, 1:], atol=1e-6 * a.pressure.max())
    # a quarter turn of the mat turns the body the other way about the sensing area's centre
    turn = Conditions(1, 1, 1, 0, 0, 0, math.pi / 2).body_motion(bed)
    centre = np.array([bed.mat.width_m / 2, bed.mat.length_m / 2, 0.0])
    np.testing.assert_allclose(turn[:3, :3] @ centre + turn[:3, 3], centre, atol=1e-12)
    np.testing.assert_allclose(turn[:3, :3] @ [1.0, 0, 0], [0, -1.0, 0], atol=1e-12)


def test_gain_and_threshold_of_the_sensor():
    bed = get_bed()
    area = bed.mat.taxel_area_m2
    force = np.zeros(bed.mat.shape)
    force[0, :3] = np.array([2.0, 10.0, 30.0]) * 133.322 * area  # 2, 10 and 30 mmHg
    cond = Conditions(bed.stiffness_n_m3, bed.tissue_modulus_pa, 1.2, 3.0, 0.0, 0.0, 0.0)
    read = read_sensor(force, cond.bed(bed))
    np.testing.assert_allclose(read[0, :3], [0.0, 12.0, 36.0])  # 2.4 mmHg is under the 3 mmHg threshold
    assert read_sensor(force, bed)[0, 0] == pytest.approx(2.0)


def test_randomised_samples_carry_their_conditions(tmp_path):
    from pressurepose.data.generate import generate
    from pressurepose.data.schema import GenerationConfig
    from pressurepose.data.store import read_shard_arrays

    cfg = GenerationConfig(partition="general_supine", gender="f", count=2, seed=1, randomize=True, shard_size=2)
    generate(cfg, tmp_path / "d", progress=False)
    shard = next((tmp_path / "d").glob("*.h5"))
    arr = read_shard_arrays(shard, ["conditions", "mass", "force"])
    assert arr["conditions"].shape == (2, 7)
    assert not np.allclose(arr["conditions"][0], arr["conditions"][1])
    for c, m, f in zip(arr["conditions"], arr["mass"], arr["force"]):
        assert 0.6 * 9.4e4 <= c[0] <= 1.6 * 9.4e4
        assert f.sum() <= m * 9.81 * 1.001


def test_generate_records_the_sampler_and_randomisation_settings(tmp_path, capsys):
    import json

    from pressurepose.cli import main

    out = tmp_path / "g"
    assert main(["generate", "--partition", "general", "--gender", "m", "--count", "3", "--producer", "synthetic",
                 "--randomize", "--placement", "uniform", "--shapes", "uniform", "--hanging-limbs",
                 "--out", str(out), "--no-progress"]) == 0
    config = json.loads((out / "manifest.json").read_text())["config"]
    assert (config["randomize"], config["placement"], config["shapes"], config["hanging_limbs"]) == (
        True, "uniform", "uniform", True)
