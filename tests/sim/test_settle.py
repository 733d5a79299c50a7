"""Physics simulation #1 against known truths: the cell bed's force balance and analytic sinks, a
settled body's force balance, symmetry, joint limits, mesh agreement, rejections and determinism."""

import dataclasses

import numpy as np
import pytest

from pressurepose.body import BodyModel
from pressurepose.body.capsules import CAPSULE_JOINTS, capsules_for, posed_capsules
from pressurepose.body.joints import JOINT_NAMES
from pressurepose.body.model import asset_path
from pressurepose.body.toy import toy_body_arrays
from pressurepose.errors import BadInput
from pressurepose.pose.limits import joint_limits
from pressurepose.pose.posture import posture_class, posture_classes, roll_angle
from pressurepose.pose.root import root_axis_angle, world_rotation
from pressurepose.sim.bed import get_bed
from pressurepose.sim.cellbed import cell_bed, rigid_sink
from pressurepose.sim.ragdoll import home_pose, ragdoll_params
from pressurepose.sim.settle import settle
from pressurepose.sim.settle_config import SettleConfig
from pressurepose.sim.settle_stiffness import (
    BODY_PART_CAPSULES,
    calibrate_stiffness,
    settle_sink_fn,
)
from pressurepose.sim.stiffness import fit_settle_stiffness

G = 9.81
BED = get_bed()
FAST = SettleConfig()
FINE = dataclasses.replace(FAST, coarse_factor=1.0)  # 0.01 s throughout: the step never coarsens
COARSE = dataclasses.replace(FAST, coarse_after_steps=10)  # the step doubles soon after touching
BETAS = np.zeros(10)


@pytest.fixture(scope="module")
def body():
    return BodyModel(toy_body_arrays())


def lying(roll: float = 0.0, yaw: float = 0.0) -> np.ndarray:
    """Home pose with the root lying at the given roll (0 supine) and yaw."""
    pose = home_pose()
    pose[:3] = root_axis_angle(world_rotation(roll, yaw))[0]
    return pose


def centre_transl(body, pose, xy=None) -> np.ndarray:
    """transl putting the pelvis over bed-frame xy (default the mattress centre)."""
    x0, x1, y0, y1 = BED.mattress_bounds
    xy = np.array([(x0 + x1) / 2, (y0 + y1) / 2]) if xy is None else np.asarray(xy, float)
    _, joints = body.forward(BETAS, pose, np.zeros(3))
    return np.array([xy[0] - joints[0, 0, 0], xy[1] - joints[0, 0, 1], 0.3])


@pytest.fixture(scope="module")
def supine(body):
    pose = lying()
    transl = centre_transl(body, pose)
    return pose, transl, settle(body, BETAS, pose, transl, "female", BED, FAST)


# ------------------------------------------------------------------------------ the bed alone

def _box_on_cells(cells, nx: int, ny: int, mass: float):
    """A flat box exactly over nx x ny whole cells (1 mm short of their edges), resting."""
    hx, hy = nx * cells.dx / 2 - 0.001, ny * cells.dy / 2 - 0.001
    cx, cy = cells.x0 + 15 * cells.dx, cells.y0 + 30 * cells.dy  # on cell corners
    return rigid_sink(cells, "box", (hx, hy, 0.03), mass, (cx, cy))


def test_box_sinks_as_a_winkler_foundation_says():
    """Uncoupled cells: sink = m g / (k_A A) and the cells carry m g."""
    cells = cell_bed(BED, coupling=False)
    m, nx, ny = 20.0, 8, 12
    res = _box_on_cells(cells, nx, ny, m)
    assert res.rested
    analytic = m * G / (cells.stiffness_n_m3 * nx * cells.dx * ny * cells.dy)
    assert res.cell_force.sum() == pytest.approx(m * G, rel=0.01)
    loaded = res.cell_force > 1e-3
    assert loaded.sum() == nx * ny
    np.testing.assert_allclose(-res.cell_sink[loaded], analytic, rtol=0.01)
    # the box sits on the cells (MuJoCo's soft contact adds under a millimetre)
    assert res.sink_m == pytest.approx(analytic, abs=1e-3)


def test_box_on_coupled_cells_matches_the_discrete_solution():
    """Coupled cells: the sink of a rigid flat punch on the spring grid, solved directly."""
    cells = cell_bed(BED)
    m, nx, ny = 20.0, 8, 12
    res = _box_on_cells(cells, nx, ny, m)
    w = res.cells
    n = w.nx * w.ny
    idx = np.arange(n).reshape(w.ny, w.nx)
    K = np.eye(n) * w.k_cell
    for a, b, k in ((idx[:, :-1], idx[:, 1:], w.coupling_x), (idx[:-1], idx[1:], w.coupling_y)):
        for i, j in zip(a.ravel(), b.ravel()):
            K[i, i] += k
            K[j, j] += k
            K[i, j] -= k
            K[j, i] -= k
    covered = (res.cell_force > 1e-3).ravel()
    assert covered.sum() == nx * ny
    free = ~covered
    u_free = -np.linalg.solve(K[np.ix_(free, free)], K[np.ix_(free, covered)] @ np.ones(covered.sum()))
    punch = (K[np.ix_(covered, covered)] @ np.ones(covered.sum()) + K[np.ix_(covered, free)] @ u_free).sum()
    expected = m * G / punch
    assert res.cell_force.sum() == pytest.approx(m * G, rel=0.01)
    np.testing.assert_allclose(-res.cell_sink.ravel()[covered], expected, rtol=0.01)
    # coupling spreads the load: the bed is stiffer than the plain Winkler one
    assert w.coupling_x > 0 and expected < 0.99 * m * G / (w.stiffness_n_m3 * nx * w.dx * ny * w.dy)


def test_capsule_sink_grows_with_weight():
    cells = cell_bed(BED)
    light = rigid_sink(cells, "capsule", (0.05, 0.2), 2.0, (0.4, 0.9), 0.3)
    heavy = rigid_sink(cells, "capsule", (0.05, 0.2), 8.0, (0.4, 0.9), 0.3)
    assert light.rested and heavy.rested
    assert 0 < light.sink_m < heavy.sink_m < 0.05
    assert heavy.cell_force.sum() == pytest.approx(8.0 * G, rel=0.01)


def test_settle_stiffness_fit_recovers_a_hidden_stiffness():
    """Appendix A.5: 'measure' capsule sinks at a hidden modulus, fit it back with the sink function."""

    class Measured:  # the fields of calibration_data.CapsuleMeasurements that the fit reads
        radius_m = np.array([0.06])
        length_m = np.array([0.37])  # end to end
        mass_kg = np.array([5.0])
        center_xy_m = np.array([[0.4, 0.9]])
        yaw_rad = np.array([0.0])

    sink_fn = settle_sink_fn(Measured, BED)
    hidden = 8.0e4
    measured = sink_fn(hidden)
    fit = fit_settle_stiffness(measured, sink_fn, bounds=(1e4, 1e6), xtol=1e-3)
    assert fit.stiffness == pytest.approx(hidden, rel=0.02)


def test_default_stiffness_makes_capsules_sink_as_in_the_press_model():
    fit = calibrate_stiffness(BED, FAST)
    raw = settle_sink_fn(BODY_PART_CAPSULES, BED, FAST)(BED.stiffness_n_m3)
    press = fit.sinks / (1 + fit.relative_error)
    assert np.abs(np.log(fit.sinks / press)).mean() < np.abs(np.log(raw / press)).mean()
    assert np.abs(fit.relative_error).max() < 0.35


def test_bad_bed_objects_are_rejected():
    cells = cell_bed(BED)
    with pytest.raises(BadInput):
        rigid_sink(cells, "sphere", (0.1,), 1.0)
    with pytest.raises(BadInput):
        rigid_sink(cells, "box", (0.1, -0.1, 0.1), 1.0)
    with pytest.raises(BadInput):
        rigid_sink(cells, "capsule", (0.1, 0.2), 1.0, (5.0, 5.0))  # off the bed
    with pytest.raises(BadInput):
        cell_bed(BED, cell_m=-0.01)
    with pytest.raises(BadInput):
        cell_bed(BED, stiffness_n_m3=0.0)


# ------------------------------------------------------------------------------ settling a body

def test_supine_body_rests_in_place_and_the_bed_carries_its_weight(supine):
    pose, transl, res = supine
    assert res.status == "settled", res.status
    assert res.touch_step > 0 and res.steps < FAST.max_steps
    assert res.bed_force_n == pytest.approx(res.mass_kg * G, rel=0.01)
    assert np.linalg.norm(res.transl[:2] - transl[:2]) < 0.01  # no drift
    assert abs(roll_angle(res.pose) - roll_angle(pose)) < np.deg2rad(2)  # no roll
    assert res.posture_start == res.posture == "supine"
    assert 0.0 < res.max_sink_m < 0.1
    # left and right limbs rest at the same heights
    z = res.capsules[..., 2].mean(-1)
    for left, right in ((1, 2), (4, 5), (7, 8), (14, 15), (16, 17), (18, 19)):
        assert z[left] == pytest.approx(z[right], abs=0.005)


def test_resting_pose_puts_the_mesh_capsules_on_the_ragdoll(body, supine):
    _, _, res = supine
    caps = capsules_for(body, BETAS)
    ends, radius = posed_capsules(body, caps, BETAS, res.pose[None], res.transl[None])
    np.testing.assert_allclose(ends[0], res.capsules, atol=1e-6)
    np.testing.assert_allclose(radius, res.radius)


def test_joint_limits_hold_legs_hanging_over_the_foot_end(body):
    """Hips at the foot edge: the legs hang down until the hip's extension limit stops them."""
    pose = lying()
    _, joints = body.forward(BETAS, pose, np.zeros(3))
    x0, x1, y0, y1 = BED.mattress_bounds
    hip_y = joints[0, 1, 1]
    transl = np.array([(x0 + x1) / 2 - joints[0, 0, 0], y1 - 0.03 - hip_y, 0.3])
    res = settle(body, BETAS, pose, transl, "female", BED, FAST)
    assert res.status == "settled", res.status
    lim = joint_limits()
    p = res.pose.reshape(24, 3)
    for hip in (1, 2):  # hip extension (x) is at its limit, within a degree
        assert p[hip, 0] == pytest.approx(lim.upper[hip, 0], abs=np.deg2rad(1.0))
    for knee in (4, 5):  # the calves hang from hinges, inside their range
        assert lim.lower[knee, 0] <= p[knee, 0] <= lim.upper[knee, 0]
        assert p[knee, 0] > np.deg2rad(10)
    inside = (p[1:] >= lim.lower[1:] - np.deg2rad(1.0)) & (p[1:] <= lim.upper[1:] + np.deg2rad(1.0))
    assert np.all(inside[lim.limited[1:]])


def test_a_limb_that_will_hang_stops_the_settle_where_it_first_hangs(body):
    """Hips at the foot edge: run to rest, the legs hang (the resting body fails ``limb_off_bed``);
    asked to test hanging limbs, the settle stops as ``limb_off_bed`` at the check where they first
    hang, in fewer steps, and the joints there hang as the resting body's test counts them."""
    from pressurepose.sim.simulate import HANG_DEPTH_M, limb_off_bed

    pose = lying()
    _, joints = body.forward(BETAS, pose, np.zeros(3))
    x0, x1, _, y1 = BED.mattress_bounds
    transl = np.array([(x0 + x1) / 2 - joints[0, 0, 0], y1 - 0.03 - joints[0, 1, 1], 0.3])
    full = settle(body, BETAS, pose, transl, "female", BED, FAST)
    assert full.status == "settled"
    assert limb_off_bed(body.forward(full.betas, full.pose, full.transl)[1][0], BED)
    early = settle(body, BETAS, pose, transl, "female", BED, FAST, hang_depth_m=HANG_DEPTH_M)
    assert early.status == "limb_off_bed"
    assert early.steps < full.steps and early.steps % FAST.posture_check_steps == 0
    assert limb_off_bed(body.forward(early.betas, early.pose, early.transl)[1][0], BED)


def test_the_hanging_limb_test_leaves_a_resting_body_as_it_was(body, supine):
    """The test only reads the state: a body whose limbs stay on the bed rests bit for bit where it
    rests without it."""
    from pressurepose.sim.simulate import HANG_DEPTH_M

    pose, transl, res = supine
    tested = settle(body, BETAS, pose, transl, "female", BED, FAST, hang_depth_m=HANG_DEPTH_M)
    assert tested.status == res.status == "settled" and tested.steps == res.steps
    np.testing.assert_array_equal(tested.pose, res.pose)
    np.testing.assert_array_equal(tested.transl, res.transl)
    np.testing.assert_array_equal(tested.capsules, res.capsules)


def test_the_settle_rests_bodies_as_the_per_joint_limit_torques_do(body, monkeypatch, per_joint_limits):
    """The settle with the ball-joint limit torques joint by joint (legs hanging over the foot end
    onto their hip limits, held there for most of the steps) rests the body bit for bit where the
    settle does."""
    import pressurepose.sim.settle as settle_module

    pose = lying()
    _, joints = body.forward(BETAS, pose, np.zeros(3))
    x0, x1, _, y1 = BED.mattress_bounds
    transl = np.array([(x0 + x1) / 2 - joints[0, 0, 0], y1 - 0.03 - joints[0, 1, 1], 0.3])
    res = settle(body, BETAS, pose, transl, "female", BED, FAST)
    held = []

    class Counted(per_joint_limits):
        def apply(self, qpos, qfrc_applied):
            super().apply(qpos, qfrc_applied)
            held.append(any(np.any(qfrc_applied[d: d + 3]) for d in self.dof.values()))

    monkeypatch.setattr(settle_module, "BallLimits", Counted)
    ref = settle(body, BETAS, pose, transl, "female", BED, FAST)
    assert sum(held) > len(held) / 2
    assert res.status == ref.status == "settled"
    assert res.steps == ref.steps and res.touch_step == ref.touch_step
    assert res.capsules.tobytes() == ref.capsules.tobytes()
    assert res.pose.tobytes() == ref.pose.tobytes() and res.transl.tobytes() == ref.transl.tobytes()

def test_body_dropped_beside_the_bed_falls_off(body):
    pose = lying()
    x0, x1, y0, y1 = BED.mattress_bounds
    res = settle(body, BETAS, pose, centre_transl(body, pose, (x1 + 0.1, (y0 + y1) / 2)), "female", BED, FAST)
    assert res.status == "fell_off_bed"


def test_limb_inside_the_body_at_start_is_rejected(body):
    pose = lying()
    pose[3 * 16 + 2] = -2.0  # the left arm swung down through the hip
    res = settle(body, BETAS, pose, centre_transl(body, pose), "female", BED, FAST)
    assert res.status == "self_collision"
    assert res.steps == 0


def test_lateral_body_with_straight_limbs_rolls_and_is_rejected(body):
    """Lying on its side with arms and legs straight, the capsule body rolls onto its front."""
    pose = lying(np.pi / 2)
    res = settle(body, BETAS, pose, centre_transl(body, pose), "female", BED, FAST)
    assert res.posture_start == "left_lateral"
    assert res.status == "posture_changed" and res.posture != "left_lateral"
    # it is stopped as soon as it leaves its class, not run on until it rests in the new one
    late = settle(body, BETAS, pose, centre_transl(body, pose), "female", BED,
                  dataclasses.replace(FAST, posture_check_steps=100_000))
    assert late.status == "posture_changed" and late.posture == res.posture
    assert res.steps < late.steps
    # and not later than one check after it left: a check earlier it was still lying on its side
    before = settle(body, BETAS, pose, centre_transl(body, pose), "female", BED,
                    dataclasses.replace(FAST, max_steps=res.steps - FAST.posture_check_steps - 1))
    assert before.status == "not_settled" and before.posture == "left_lateral"


# A `general` female body (sampler seed 13, body 50, 4 decimals) lying on her left side, roll 95.6 deg.
LATERAL_BETAS = np.array([0.1452, 1.2861, 2.9573, 0.2815, 0.9633, 2.7508, 0.5943, -0.3099, -1.1139, 2.9319])
LATERAL_POSE = np.zeros(72)
LATERAL_POSE[[0, 1, 2, 3, 4, 5, 6, 7, 8, 12, 15]] = [1.5166, -1.42, -0.9136, -0.6728, -0.29, -0.0795, -0.4983,
                                                     0.4179, 0.0482, 2.1568, 1.7733]
LATERAL_POSE[39:45] = [0.3662, -0.4587, -0.0938, 0.444, 0.5174, -0.0643]
LATERAL_POSE[48:54] = [0.7324, -0.9174, -0.1876, 0.888, 1.0348, -0.1286]
LATERAL_POSE[[55, 58]] = [-0.7612, 0.5166]
LATERAL_TRANSL = np.array([0.3676, 0.9666, 0.3083])


def test_lateral_body_rests_on_its_side_not_on_capsule_caps_outside_it():
    """The trunk contact ends at the body's side: this lateral body stays on its side (within 10
    degrees). With the fitted trunk capsules as contacts, whose caps stand outside its sides, the
    same body rolls onto its front."""
    female = BodyModel("female")
    assert posture_class(LATERAL_POSE) == "left_lateral"
    res = settle(female, LATERAL_BETAS, LATERAL_POSE, LATERAL_TRANSL, "female", BED, FAST)
    assert res.status == "settled", res.status
    assert abs(roll_angle(res.pose) - roll_angle(LATERAL_POSE)) < np.deg2rad(10)
    params = ragdoll_params(female, LATERAL_BETAS, "female")
    wide = dataclasses.replace(params, contact_length=params.length)
    rolled = settle(female, LATERAL_BETAS, LATERAL_POSE, LATERAL_TRANSL, "female", BED, FAST, params=wide)
    assert rolled.status == "posture_changed" and rolled.posture == "prone"


@pytest.mark.parametrize("early_coarse", [False, True])
def test_settle_is_deterministic_whatever_ran_before(body, early_coarse):
    """The compiled model is shared by every body settled with one config; with the coarse step it
    changes its time step mid-settle, so the next body must start at the fine step again."""
    config = COARSE if early_coarse else FAST
    pose = lying()
    transl = centre_transl(body, pose)
    first = settle(body, BETAS, pose, transl, "female", BED, config)
    other = lying(np.pi, 0.3)
    settle(body, BETAS + 1.0, other, centre_transl(body, other), "male", BED, config)
    again = settle(body, BETAS, pose, transl, "female", BED, config)
    assert again.steps == first.steps and again.status == first.status
    np.testing.assert_array_equal(again.pose, first.pose)
    np.testing.assert_array_equal(again.transl, first.transl)
    np.testing.assert_array_equal(again.capsules, first.capsules)


def test_bad_settle_inputs_are_rejected(body):
    pose = lying()
    t = centre_transl(body, pose)
    with pytest.raises(BadInput):
        settle(body, BETAS, pose[:69], t, "female", BED, FAST)
    with pytest.raises(BadInput):
        settle(body, BETAS, pose, np.array([0.0, np.nan, 0.0]), "female", BED, FAST)
    for bad in ({"max_steps": 0}, {"rest_speed_m_s": -1.0}, {"timestep_s": float("nan")}):
        with pytest.raises(BadInput):
            SettleConfig(**bad)


# ------------------------------------------------------------------------------ posture classes

def test_posture_classes_from_the_root():
    rolls = np.array([0.0, 0.4, 1.4, np.pi / 2, 2.0, np.pi, -np.pi + 0.3, -np.pi / 2, -0.6])
    poses = np.zeros((len(rolls), 72))
    for i, r in enumerate(rolls):
        poses[i] = lying(r, yaw=0.4 * (-1) ** i)
    expected = ["supine", "supine", "left_lateral", "left_lateral", "left_lateral", "prone", "prone",
                "right_lateral", "supine"]
    assert list(posture_classes(poses)) == expected
    np.testing.assert_allclose(roll_angle(poses), np.angle(np.exp(1j * rolls)), atol=1e-9)
    assert posture_class(poses[3]) == "left_lateral"
    with pytest.raises(BadInput):
        posture_class(np.zeros(5))


# ------------------------------------------------------------------------------ the stiffness cache

def test_settle_stiffness_is_fitted_once_then_read_from_the_cache(tmp_path, monkeypatch):
    import pressurepose.sim.settle_stiffness as settle_module

    calls = []

    def fake_fit(bed, config):
        calls.append(bed.stiffness_n_m3)
        return type("Fit", (), {"stiffness": bed.stiffness_n_m3 / 3})()

    monkeypatch.setattr(settle_module, "calibrate_stiffness", fake_fit)
    monkeypatch.setenv(settle_module.CACHE_ENV, str(tmp_path / "cache"))
    k = settle_module.settle_stiffness(BED, FAST)
    assert k == BED.stiffness_n_m3 / 3 and calls == [BED.stiffness_n_m3]
    assert settle_module.settle_stiffness(BED, FAST) == k and len(calls) == 1  # read back, exactly
    softer = get_bed(stiffness_n_m3=BED.stiffness_n_m3 / 2)  # another bed: another key, fitted again
    assert settle_module.settle_stiffness(softer, FAST) == softer.stiffness_n_m3 / 3 and len(calls) == 2
    other = dataclasses.replace(FAST, taxels_per_cell=1)
    assert settle_module.stiffness_cache_key(BED, other) != settle_module.stiffness_cache_key(BED, FAST)
    files = sorted((tmp_path / "cache").iterdir())
    assert len(files) == 2
    for f in files:
        f.write_text("{not json")  # a damaged cache file is fitted again, not trusted
    assert settle_module.settle_stiffness(BED, FAST) == k and len(calls) == 3
    monkeypatch.setenv(settle_module.CACHE_ENV, "")  # no cache at all
    assert settle_module.settle_stiffness(BED, FAST) == k and len(calls) == 4


def test_cached_stiffness_is_the_fit():
    from pressurepose.sim.settle_stiffness import settle_stiffness

    assert settle_stiffness(BED, FAST) == calibrate_stiffness(BED, FAST).stiffness


@pytest.mark.skipif(not asset_path("female.npz").is_file(), reason="the shipped female body model is not baked")
def test_a_supine_head_rests_on_the_bed():
    """With the relaxed neck (default) a supine head falls onto the bed while settling and the press
    finds it loading the mat; the paper's stiff neck holds it higher."""
    from pressurepose.pose.sampler import body_rng, sample_one
    from pressurepose.sim.press import press
    from pressurepose.sim.tissue import body_bones

    body = BodyModel("female")
    drawn = sample_one("general_supine", "f", body_rng(3, 0), body=body)
    betas = drawn.betas
    caps = capsules_for(body, betas)
    head = caps.names.index("head")
    low = {}
    for relaxed in (True, False):
        res = settle(body, betas, drawn.pose, drawn.transl, "female", BED,
                     dataclasses.replace(FAST, relaxed_neck=relaxed))
        assert res.ok
        ends, radius = posed_capsules(body, caps, betas, res.pose[None], res.transl[None])
        low[relaxed] = ends[0, head, :, 2].min() - radius[head]
        if relaxed:
            verts, joints = body.forward(betas, res.pose, res.transl)
            img = press(verts[0], body.faces, res.mass_kg, BED, bones=body_bones(body, betas, res.pose, res.transl))
            near = np.linalg.norm(BED.taxel_centers() - joints[0, 15, :2], axis=-1) < 0.1
            head_mass = res.mass_kg * 0.06  # the head is 6-8 % of the body's mass
            assert img.force[near].sum() > 0.5 * head_mass * G
    assert low[True] < 0.0             # the head capsule is sunk into the mattress
    assert low[True] < low[False] - 0.01


@pytest.mark.skipif(not asset_path("female.npz").is_file(), reason="the shipped female body model is not baked")
@pytest.mark.parametrize("seed", [3, 7])
def test_a_relaxed_spine_lets_the_pelvis_sink(seed):
    """A lying trunk does not hold its standing curvature: with the relaxed spine (default) the
    heavy pelvis sinks deeper against the upper back than with the paper's stiff spine, and the
    trunk bends at the spine joints instead of resting as one rigid piece."""
    from pressurepose.pose.sampler import body_rng, sample_one

    body = BodyModel("female")
    drawn = sample_one("supine_straight_limbs", "f", body_rng(seed, 0), body=body)
    caps = capsules_for(body, drawn.betas)
    pelvis, chest = caps.names.index("pelvis"), caps.names.index("spine2")
    spine = [JOINT_NAMES.index(n) for n in ("spine1", "spine2", "spine3")]
    sag, bend = {}, {}
    for k in (None, FAST.spine_stiffness):  # the paper's 200 N m/rad, then the default
        res = settle(body, drawn.betas, drawn.pose, drawn.transl, "female", BED,
                     dataclasses.replace(FAST, spine_stiffness=k))
        assert res.ok
        assert res.bed_force_n == pytest.approx(res.mass_kg * G, rel=0.02)  # at rest: the bed carries it
        ends, radius = posed_capsules(body, caps, drawn.betas, res.pose[None], res.transl[None])
        low = ends[0, :, :, 2].min(axis=1) - radius
        sag[k] = low[chest] - low[pelvis]  # grows as the pelvis sinks below the upper back
        bend[k] = np.linalg.norm((res.pose - drawn.pose).reshape(24, 3)[spine], axis=1).sum()
    assert FAST.spine_stiffness < 200.0
    assert sag[FAST.spine_stiffness] > sag[None] + 0.002
    assert bend[FAST.spine_stiffness] > 3 * bend[None]


@pytest.mark.parametrize("bad", [0.0, -1.0, float("inf"), True])
def test_settle_config_rejects_a_bad_spine_stiffness(bad):
    with pytest.raises(BadInput, match="spine_stiffness"):
        SettleConfig(spine_stiffness=bad)


def test_settle_presets():
    import argparse

    from pressurepose.cli.sim import add_settle_argument
    from pressurepose.sim.settle_config import SETTLES
    from pressurepose.sim.settle_config import settle_preset

    assert settle_preset("relaxed") == SettleConfig()
    paper = settle_preset("paper")
    assert paper.spine_stiffness is None and paper.relaxed_neck is False
    assert paper == SettleConfig(relaxed_neck=False, spine_stiffness=None)
    assert SETTLES == ("relaxed", "paper")
    with pytest.raises(BadInput, match="settle 'floppy' is not known"):
        settle_preset("floppy")
    p = argparse.ArgumentParser()
    add_settle_argument(p)
    assert tuple(p._option_string_actions["--settle"].choices) == SETTLES


# ------------------------------------------------------------------------------ the coarse step

@pytest.mark.parametrize("bad", [0.5, 4.5, float("nan"), True, "2"])
def test_settle_config_rejects_a_bad_coarse_step(bad):
    with pytest.raises(BadInput, match="coarse_factor"):
        SettleConfig(coarse_factor=bad)
    with pytest.raises(BadInput, match="coarse_after_steps"):
        SettleConfig(coarse_after_steps=0)


def test_a_coarse_step_rests_a_body_where_the_fine_one_does(body):
    """The longer step after the pelvis touches changes the integration, not the physics: the body
    rests in the same place within a centimetre and the bed carries its weight (what it saves is
    measured by benchmarks/bench_settle.py --agreement on sampled bodies, whose limbs creep for
    hundreds of steps; this body rests soon after the switch)."""
    pose = lying()
    transl = centre_transl(body, pose)
    fine = settle(body, BETAS, pose, transl, "female", BED, FINE)
    coarse = settle(body, BETAS, pose, transl, "female", BED, COARSE)
    assert coarse.ok and fine.ok
    assert coarse.touch_step == fine.touch_step
    assert fine.steps > coarse.touch_step + COARSE.coarse_after_steps  # the switch happened
    assert coarse.bed_force_n == pytest.approx(coarse.mass_kg * G, rel=0.01)
    # a rest is where motion fell under 0.05 m/s, not an exact equilibrium: capsules agree within the
    # 1-2 cm that two immaterially different starts give (bench:settle_agreement's noise floor)
    move = np.linalg.norm(coarse.capsules - fine.capsules, axis=-1)
    assert move.max() < 0.02 and np.median(move) < 0.005
    assert coarse.posture == "supine"


def test_the_step_budget_is_kept_in_seconds_with_a_coarse_step(body, supine):
    """A body that cannot rest within the budget runs as many simulated seconds as with the fine
    step, in fewer steps."""
    pose, transl, _ = supine
    budget = dataclasses.replace(COARSE, max_steps=150, coarse_after_steps=10, rest_speed_m_s=1e-6)
    res = settle(body, BETAS, pose, transl, "female", BED, budget)
    assert res.status == "not_settled"
    fine_steps = res.touch_step + budget.coarse_after_steps
    expected = fine_steps + (budget.max_steps - fine_steps) / 2  # the rest of 1.5 s at 0.02 s
    assert abs(res.steps - expected) <= 1


def test_the_start_test_is_what_mujoco_finds_between_the_ragdolls_capsules(body):
    """The settle's start test (pressurepose.body.contact.start_overlap) against MuJoCo's own contacts
    of the compiled ragdoll (any pair of ragdoll geoms deeper than the tolerance), over arms and legs
    swung at random: the same verdict, and both verdicts occur."""
    import mujoco

    from pressurepose.body.contact import start_overlap
    from pressurepose.sim.settle import cached_model
    from pressurepose.sim.settle_model import capsule_ends

    params = ragdoll_params(body, BETAS, "female")
    sm = cached_model(BED, FAST, params)
    m, d, ri = sm.model, sm.data, sm.ragdoll
    rng = np.random.default_rng(3)
    verdicts = []
    for _ in range(60):
        pose = lying()
        for j in (1, 2, 4, 5, 13, 14, 16, 17, 18, 19):  # hips, knees, collars, shoulders, elbows
            pose[3 * j:3 * j + 3] += rng.normal(0.0, 0.8, 3)
        sm.configure(params, pose, centre_transl(body, pose))
        mujoco.mj_forward(m, d)
        geom = d.contact.geom[:d.ncon]
        ours = np.isin(geom, ri.geom).all(axis=1)
        by_mujoco = bool(np.any(ours & (d.contact.dist[:d.ncon] < -FAST.self_collision_tol_m)))
        assert bool(start_overlap(capsule_ends(m, d, ri), params.radius, FAST.self_collision_tol_m)) == by_mujoco
        verdicts.append(by_mujoco)
    assert 5 < sum(verdicts) < 55


@pytest.mark.parametrize("depth", [-0.1, float("nan"), "0.1", True])
def test_settle_refuses_a_hang_depth_that_is_not_metres(body, depth):
    with pytest.raises(BadInput, match="hang_depth_m"):
        settle(body, BETAS, lying(), np.zeros(3), "female", BED, FAST, hang_depth_m=depth)


# ------------------------------------------------------------------------------ where the springs rest

def _arms_bent() -> np.ndarray:
    """A supine pose far from the home pose: elbows bent 1.5 rad, arms half raised."""
    pose = lying()
    for collar, shoulder, elbow, sign in ((13, 16, 18, -1.0), (14, 17, 19, 1.0)):
        pose[3 * collar + 2] = sign * 0.2
        pose[3 * shoulder + 2] = sign * 0.4
        pose[3 * elbow + 1] = sign * 1.5
    return pose


def _spring_torques(body, pose, spring_pose) -> np.ndarray:
    """The joint springs' generalised forces with the ragdoll at ``pose`` (free root excluded), on
    the settle's model after a settle that rested its springs at ``spring_pose``."""
    import mujoco

    from pressurepose.sim.ragdoll import pose_to_qpos
    from pressurepose.sim.settle import cached_model

    t = centre_transl(body, pose)
    settle(body, BETAS, pose, t, "female", BED, FAST, spring_pose=spring_pose)
    params = ragdoll_params(body, BETAS, "female")
    sm = cached_model(BED, FAST, params)
    m, d, ri = sm.model, sm.data, sm.ragdoll
    mujoco.mj_resetData(m, d)
    pose_to_qpos(m, ri, params, pose, t, d.qpos)
    mujoco.mj_forward(m, d)
    elbows = [int(ri.dof[CAPSULE_JOINTS.index(j)]) for j in (18, 19)]  # hinges: one dof each
    return d.qfrc_spring[ri.dof[1]: sm.nv].copy(), d.qfrc_spring[elbows], params.stiffness[
        [CAPSULE_JOINTS.index(j) for j in (18, 19)]]


def test_springs_rest_at_the_pose_given_and_pull_toward_home_without_one(body):
    pose = _arms_bent()
    held, _, _ = _spring_torques(body, pose, pose)
    assert np.abs(held).max() < 1e-9  # no spring torque at the springs' rest pose
    _, elbows, k = _spring_torques(body, pose, None)
    # the paper's springs rest at home (elbows straight): -k x the 1.5 rad bend, toward straight
    np.testing.assert_allclose(elbows, [k[0] * 1.5, -k[1] * 1.5], rtol=1e-9)
    assert np.abs(_spring_torques(body, home_pose(), None)[0]).max() < 1e-9


def test_springs_at_the_home_pose_given_rest_a_body_as_the_default(body):
    pose = _arms_bent()
    t = centre_transl(body, pose)
    a = settle(body, BETAS, pose, t, "female", BED, FAST)
    b = settle(body, BETAS, pose, t, "female", BED, FAST, spring_pose=home_pose())
    assert a.status == b.status == "settled" and a.steps == b.steps
    np.testing.assert_array_equal(a.pose, b.pose)


@pytest.mark.parametrize("bad", [np.zeros(69), np.full(72, np.nan), np.zeros((24, 3))])
def test_a_bad_spring_pose_is_rejected(body, bad):
    pose = lying()
    with pytest.raises(BadInput, match="spring_pose"):
        settle(body, BETAS, pose, centre_transl(body, pose), "female", BED, FAST, spring_pose=bad)
