"""Sensor law and the body-weight conversion."""

import numpy as np
import pytest

from pressurepose.errors import BadInput
from pressurepose.sim import MMHG_PA, force_to_mmhg, get_bed, read_sensor
from pressurepose.sim.sensor import GRAVITY, sensor_law


def test_ideal_sensor_reads_mean_pressure_in_mmhg():
    bed = get_bed()
    force = np.zeros(bed.mat.shape)
    force[10, 5] = 1.0  # 1 N on a 28.6 mm taxel
    force[11, 5] = 0.5
    u = read_sensor(force, bed)
    assert u[10, 5] == pytest.approx(1.0 / 0.0286 ** 2 / 133.322)  # 9.17 mmHg
    assert u[11, 5] == pytest.approx(0.5 * u[10, 5])
    assert np.count_nonzero(u) == 2


def test_quadratic_law_offset_and_clipping():
    x = np.array([0.0, 0.0, 10.0, 40.0, 200.0])
    u = sensor_law(x, c0=5.0, c1=1.5, c2=0.01, max_mmhg=100.0)
    np.testing.assert_allclose(u, [0.0, 0.0, 5 + 15 + 1, 5 + 60 + 16, 100.0])  # no load reads 0, top clipped
    assert np.all(sensor_law(x, c0=-30.0, c1=1.0, c2=0.0, max_mmhg=100.0)[:3] == 0)  # clipped at 0


def test_bed_constants_drive_the_reading():
    bed = get_bed(sensor_c0=2.0, sensor_c1=0.8, sensor_c2=0.002)
    force = np.full(bed.mat.shape, 2.0)
    x = 2.0 / bed.mat.taxel_area_m2 / MMHG_PA
    np.testing.assert_allclose(read_sensor(force, bed), 0.002 * x * x + 0.8 * x + 2.0)


def test_read_sensor_refuses_bad_forces():
    bed = get_bed()
    with pytest.raises(BadInput, match="64 x 27"):
        read_sensor(np.zeros((60, 27)), bed)
    bad = np.zeros(bed.mat.shape)
    bad[0, 0] = -1
    with pytest.raises(BadInput, match="non-negative"):
        read_sensor(bad, bed)
    bad[0, 0] = np.nan
    with pytest.raises(BadInput):
        read_sensor(bad, bed)


def test_force_to_mmhg_carries_the_body_weight():
    rng = np.random.default_rng(0)
    raw = rng.uniform(0, 1, size=(3, 64, 27)) * (rng.uniform(size=(3, 64, 27)) > 0.6)
    mass = np.array([50.0, 70.0, 90.0])
    area = 0.0286 ** 2
    p = force_to_mmhg(raw, mass, area)
    np.testing.assert_allclose(p.sum((1, 2)) * area * MMHG_PA, mass * GRAVITY)
    np.testing.assert_allclose(p[1] / p[1].max(), raw[1] / raw[1].max())  # shape kept
    single = force_to_mmhg(raw[0], 50.0, area)
    np.testing.assert_allclose(single, p[0])
    assert np.all(force_to_mmhg(np.zeros((4, 4)), 60.0, area) == 0)


@pytest.mark.parametrize("image, mass, area, match", [
    (-np.ones((4, 4)), 60.0, 1e-3, "non-negative"),
    (np.ones(4), 60.0, 1e-3, "rows, cols"),
    (np.ones((4, 4)), -1.0, 1e-3, "mass_kg"),
    (np.ones((4, 4)), 60.0, 0.0, "taxel_area"),
])
def test_force_to_mmhg_bad_inputs(image, mass, area, match):
    with pytest.raises(BadInput, match=match):
        force_to_mmhg(image, mass, area)
