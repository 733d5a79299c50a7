"""The positioning wedge: its geometry, its load on the mat, and bodies settled against it."""

import math

import numpy as np
import pytest

from pressurepose.body import BodyModel
from pressurepose.body.capsules import CAPSULE_NAMES
from pressurepose.errors import BadInput
from pressurepose.pose.config import SamplerConfig
from pressurepose.pose.partitions import WEDGE_TRUNK
from pressurepose.pose.posture import roll_angle, roll_of_rotation
from pressurepose.pose.root import world_rotation
from pressurepose.pose.sampler import sample_one
from pressurepose.sim.bed import get_bed
from pressurepose.sim.foundation import PressFailed
from pressurepose.sim.sensor import read_sensor
from pressurepose.sim.settle import settle
from pressurepose.sim.simulate import Simulated, simulate_one
from pressurepose.sim.wedge import Wedge, relieved_body, wedge_behind, wedge_load

G = 9.81
BED = get_bed()


def _trunk_at(roll: float, yaw: float = 0.0):
    """Capsules (20, 2, 3) and radii of a stylised body lying at ``roll``: every capsule on the
    pelvis-to-head axis (the rest body's +z), the root turned by world_rotation(roll, yaw)."""
    W = world_rotation(roll, yaw)[0]
    ends = np.zeros((20, 2, 3))
    for k in range(20):
        ends[k] = [[0.0, 0.0, 0.1 * (k % 6)], [0.0, 0.0, 0.1 * (k % 6) + 0.1]]
    ends = ends @ W.T + np.array([0.4, 1.0, 0.15])
    return ends, np.full(20, 0.08), W


@pytest.mark.parametrize("roll", [math.radians(30), math.radians(-60), math.radians(45)])
def test_the_face_is_inclined_as_the_body_is_rolled_and_touches_the_trunks_back(roll):
    ends, radius, W = _trunk_at(roll, yaw=0.2)
    assert abs(roll_of_rotation(W) - roll) < 1e-9
    w = wedge_behind(ends, radius, W)
    assert w.angle_rad == pytest.approx(abs(roll), abs=1e-9)
    n = w.normal
    assert np.allclose(n, -W[:, 1] - (-W[:, 1] @ w.axis) * w.axis, atol=1e-9)  # the body's front
    assert abs(w.axis @ np.array([0.0, 0.0, 1.0])) < 1e-12 and abs(w.rise[2]) < 1e-12
    assert abs(w.toe[2]) < 1e-12
    k = [CAPSULE_NAMES.index(c) for c in WEDGE_TRUNK]
    gap = ends[k].reshape(-1, 3) @ n - np.repeat(radius[k], 2) - w.toe @ n
    assert gap.min() == pytest.approx(0.0, abs=1e-9)  # tangent: touching, not inside
    # the box's top face is the inclined face; its axes are a right-handed frame
    half, centre, rot = w.box()
    assert np.allclose(rot.T @ rot, np.eye(3), atol=1e-12) and np.linalg.det(rot) == pytest.approx(1.0)
    assert np.allclose(rot[:, 2], n)
    assert (centre + half[2] * n - w.toe) @ n == pytest.approx(0.0, abs=1e-12)
    assert w.base_width_m == pytest.approx(w.height_m / math.tan(w.angle_rad))


def test_a_wedge_props_only_half_turned_bodies():
    ends, radius, W = _trunk_at(0.0)
    with pytest.raises(BadInput, match="rolled"):
        wedge_behind(ends, radius, W)
    with pytest.raises(BadInput, match="expected"):
        wedge_behind(ends[:5], radius, W)


def _flat_wedge() -> Wedge:
    return Wedge(np.array([0.3, 1.0, 0.0]), np.array([0.0, 1.0, 0.0]), np.array([1.0, 0.0, 0.0]),
                 math.radians(30), 0.2, 1.0, 1.5)


def _grid(cell=0.01):
    xs = np.arange(0.0, 1.0, cell) + cell / 2
    ys = np.arange(0.0, 2.0, cell) + cell / 2
    return xs, ys, np.meshgrid(xs, ys)


def test_the_wedge_base_balances_force_and_moment_as_a_rigid_footing():
    w = _flat_wedge()
    xs, ys, (X, Y) = _grid()
    b = w.base_width_m
    centre = w.toe[:2] + np.array([b / 2, 0.0])
    # its own weight alone: the centroid of the triangle, b/3 from the back face
    q = wedge_load(w, np.zeros((0, 3)), np.zeros(0), xs, ys)
    assert q.sum() == pytest.approx(G * w.mass_kg, rel=1e-9) and q.min() >= 0
    assert (q * X).sum() / q.sum() == pytest.approx(centre[0] + b / 6, abs=0.003)
    # a load within the middle third: the pressure is linear and its resultant is the load's
    pts = np.array([[centre[0] - b / 8, centre[1] + 0.1, 0.05], [centre[0] + 0.01, centre[1] - 0.2, 0.1]])
    f = np.array([120.0, 60.0])
    q = wedge_load(w, pts, f, xs, ys)
    total = G * w.mass_kg + f.sum()
    assert q.sum() == pytest.approx(total, rel=1e-9)
    mx = (f @ pts[:, 0] + G * w.mass_kg * (centre[0] + b / 6)) / total
    my = (f @ pts[:, 1] + G * w.mass_kg * centre[1]) / total
    assert (q * X).sum() / total == pytest.approx(mx, abs=0.003)
    assert (q * Y).sum() / total == pytest.approx(my, abs=0.003)
    # nothing off the base
    on = (np.abs(Y - w.toe[1]) <= w.length_m / 2) & (X >= w.toe[0]) & (X <= w.toe[0] + b)
    assert q[~on].sum() == 0.0


def test_wedge_loads_are_checked():
    xs, ys, _ = _grid(0.05)
    with pytest.raises(BadInput, match="forces"):
        wedge_load(_flat_wedge(), np.zeros((1, 3)), np.array([-1.0]), xs, ys)
    with pytest.raises(BadInput, match="forces"):
        wedge_load(_flat_wedge(), np.zeros((2, 3)), np.array([1.0]), xs, ys)


def test_the_relieved_body_keeps_force_and_moment():
    pts = np.array([[0.2, 1.0, 0.1], [0.25, 1.3, 0.12]])
    f = np.array([80.0, 40.0])
    m, c = relieved_body(70.0, [0.4, 1.1], pts, f)
    assert m * G + f.sum() == pytest.approx(70.0 * G)
    assert m * G * c + f @ pts[:, :2] == pytest.approx(70.0 * G * np.array([0.4, 1.1]))
    with pytest.raises(PressFailed):
        relieved_body(10.0, [0.4, 1.1], pts, np.array([60.0, 40.0]))


@pytest.fixture(scope="module")
def female():
    return BodyModel("f")


def _propped(female, seeds=range(20)):
    """The first propped_lateral body (of ``seeds``) that settles against its wedge."""
    for seed in seeds:
        d = sample_one("propped_lateral", "f", np.random.default_rng(seed), False, body=female, config=SamplerConfig())
        r = settle(female, d.betas, d.pose, d.transl, "f", BED, wedge=True)
        if r.ok and r.wedge_force_z.sum() > 0.02 * G * r.mass_kg:
            return d, r
    pytest.fail("no propped_lateral body of 20 rested against its wedge")


def test_a_propped_body_rests_on_the_bed_and_the_wedge_which_carry_its_weight(female):
    drawn, r = _propped(female)
    assert r.wedge is not None and len(r.wedge_points) == len(r.wedge_force_z) > 0
    # at rest, within what the resting test leaves: it bounds every capsule point's acceleration by
    # 0.5 m/s^2 (5 % of g); on 17 propped bodies the imbalance was at most 1.6 % with the fine step
    # throughout and 2.1 % with the default coarse step (median 0.06 and 0.12 %)
    assert r.bed_force_n + r.wedge_force_z.sum() == pytest.approx(r.mass_kg * G, rel=0.025)
    side = np.sign(roll_angle(drawn.pose))
    assert math.radians(5) <= side * roll_angle(r.pose) <= math.radians(100)  # still on its side
    # the body leans on the face: the contacts that hold it up lie on it (a trunk bent over the
    # wedge's top edge may also touch the edge, pushing it sideways only)
    loaded = r.wedge_force_z > 0
    assert loaded.sum() >= 1
    assert np.allclose((r.wedge_points[loaded] - r.wedge.toe) @ r.wedge.normal, 0.0, atol=0.01)


def test_sampled_propped_bodies_keep_their_limbs_out_of_the_wedge(female):
    statuses = []
    for seed in range(6):
        d = sample_one("propped_lateral", "f", np.random.default_rng(100 + seed), False, body=female,
                       config=SamplerConfig())
        rest = settle(female, d.betas, d.pose, d.transl, "f", BED, wedge=True)
        statuses.append(rest.status)
    assert "support_overlap" not in statuses, statuses


def test_a_propped_image_shows_the_wedge_beside_the_body(female):
    for seed in range(30):
        clock = {}
        s = simulate_one(female, BED, "propped_lateral", "f", np.random.default_rng(seed), timings=clock)
        assert set(clock) == {"sample", "settle", "press", "steps"} and min(clock.values()) >= 0
        if isinstance(s, Simulated) and (s.image.force[~s.image.contact] > 0).sum() > 20:
            assert clock["steps"] > 0 and clock["press"] > 0
            break
    else:
        pytest.fail("no propped image with a wedge footprint in 30 attempts")
    img = s.image
    assert img.bed_force.sum() > s.mass * G  # the body's weight and the wedge's
    beside = img.force[~img.contact]
    assert beside.sum() > 0.02 * s.mass * G  # the wedge carries part of the body
    assert np.all(img.pressure >= 0) and np.isfinite(img.pressure).all()
    assert s.wedge is not None and 0 < s.wedge.angle_rad < math.pi / 2
    # the wedge's part of the mat's force: non-negative, most of what lies beside the body, and the
    # body's own print is what is left
    wf = s.wedge_force
    assert wf.shape == img.force.shape and np.all(wf >= 0)
    assert wf[~img.contact].sum() == pytest.approx(beside.sum(), rel=1e-9)
    body_only = read_sensor(img.force - wf, BED)
    assert np.all(body_only <= img.pressure + 1e-9) and body_only[~img.contact].sum() == 0


def test_an_unpropped_body_has_no_wedge_force(female):
    for seed in range(10):
        s = simulate_one(female, BED, "general_supine", "f", np.random.default_rng(seed))
        if isinstance(s, Simulated):
            break
    assert isinstance(s, Simulated) and s.wedge is None and s.wedge_force is None


def test_a_wedge_round_trips_through_its_row_of_numbers():
    w = _flat_wedge()
    back = Wedge.from_array(w.as_array())
    assert np.array_equal(back.as_array(), w.as_array()) and back.base_width_m == w.base_width_m
    assert Wedge.from_array(np.full(13, np.nan)) is None and Wedge.from_array(np.zeros(5)) is None
