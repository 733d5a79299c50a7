"""The capsule ragdoll: rotations, pose <-> qpos, frames against the body model, springs, limits, and
the reused compiled model against a fresh compile."""

import mujoco
import numpy as np
import pytest
from scipy.spatial.transform import Rotation

from pressurepose.body import BodyModel
from pressurepose.body.capsules import CAPSULE_NAMES, capsules_for, posed_capsules
from pressurepose.body.contact import MIN_CONTACT_LENGTH_M, TRUNK_SIDE_JOINTS
from pressurepose.body.joints import joint_index
from pressurepose.body.toy import toy_body_arrays
from pressurepose.errors import BadInput
from pressurepose.sim import ragdoll as rd
from pressurepose.sim import springs
from pressurepose.sim.bed import get_bed
from pressurepose.sim.settle_config import SettleConfig
from pressurepose.sim.settle_model import SettleModel, build_spec

BETAS = np.array([0.5, -1.0, 0.3, 0.0, 0.2, 0.0, 0.0, 0.0, 0.0, 0.0])


@pytest.fixture(scope="module")
def body():
    return BodyModel(toy_body_arrays())


@pytest.fixture(scope="module")
def params(body):
    return rd.ragdoll_params(body, BETAS, "female")


@pytest.fixture(scope="module")
def solo(params):
    """A compiled ragdoll on its own and its index."""
    spec = mujoco.MjSpec()
    spec.compiler.degree = False
    rd.add_ragdoll(spec, params)
    model = spec.compile()
    index = rd.RagdollIndex.of(model)
    rd.set_spring_pose(model, index, params.home)
    return model, mujoco.MjData(model), index


def random_pose(rng, scale=0.6):
    pose = rng.uniform(-scale, scale, 72)
    pose[:3] = Rotation.random(random_state=rng.integers(1 << 31)).as_rotvec()
    return pose


def test_rotvec_quat_round_trip_and_scipy():
    rng = np.random.default_rng(0)
    axes = rng.normal(size=(200, 3))
    v = axes / np.linalg.norm(axes, axis=1, keepdims=True) * rng.uniform(0, np.pi - 1e-6, (200, 1))
    v[:3] = [[0, 0, 0], [1e-10, 0, 0], [0, 0, np.pi - 1e-9]]
    q = rd.rotvec_to_quat(v)
    np.testing.assert_allclose(np.linalg.norm(q, axis=1), 1.0, atol=1e-12)
    ref = Rotation.from_rotvec(v).as_quat()  # x, y, z, w
    np.testing.assert_allclose(np.abs(np.einsum("ni,ni->n", q, ref[:, [3, 0, 1, 2]])), 1.0, atol=1e-12)
    np.testing.assert_allclose(rd.quat_to_rotvec(q), v, atol=1e-9)
    # the same rotation with the opposite sign, or unnormalised, gives the same vector
    np.testing.assert_allclose(rd.quat_to_rotvec(-3.0 * q), v, atol=1e-9)


def test_rotation_to_quat_matches_scipy():
    R = Rotation.random(20, random_state=1)
    q = rd.rotation_to_quat(R.as_matrix())
    np.testing.assert_allclose(rd.quat_to_rotvec(q), R.as_rotvec(), atol=1e-10)


def test_right_jacobian_inverse_by_finite_differences():
    rng = np.random.default_rng(2)
    for w in rng.normal(scale=0.8, size=(10, 3)):  # angles below pi: scipy then returns w itself
        Jinv = rd.right_jacobian_inv(w[None])[0]
        eps = 1e-6
        for i in range(3):
            d = np.zeros(3)
            d[i] = eps
            plus = (Rotation.from_rotvec(w) * Rotation.from_rotvec(d)).as_rotvec()
            minus = (Rotation.from_rotvec(w) * Rotation.from_rotvec(-d)).as_rotvec()
            np.testing.assert_allclose((plus - minus) / (2 * eps), Jinv[:, i], atol=1e-6)


def test_limit_torques_are_minus_the_energy_gradient_and_zero_inside():
    rng = np.random.default_rng(3)
    lower = np.array([[-0.3, -0.2, -0.1]])
    upper = np.array([[0.2, 0.3, 0.1]])
    k = np.array([50.0])

    def energy(w):
        r = rd.local_to_smpl(w)
        return 0.5 * k[0] * np.sum((r - np.clip(r, lower[0], upper[0])) ** 2)

    inside = rd.smpl_to_local(np.array([[0.1, 0.0, 0.05]]))
    np.testing.assert_array_equal(rd.limit_torques(inside, lower, upper, k), 0.0)
    for _ in range(5):
        w = rd.smpl_to_local(rng.uniform(-0.8, 0.8, (1, 3)))
        tau = rd.limit_torques(w, lower, upper, k)[0]
        eps = 1e-6
        for i in range(3):
            d = np.zeros(3)
            d[i] = eps
            plus = (Rotation.from_rotvec(w[0]) * Rotation.from_rotvec(d)).as_rotvec()
            minus = (Rotation.from_rotvec(w[0]) * Rotation.from_rotvec(-d)).as_rotvec()
            assert tau[i] == pytest.approx(-(energy(plus) - energy(minus)) / (2 * eps), abs=1e-5)


def test_ball_limits_are_the_per_joint_torques_to_the_bit(per_joint_limits):
    """Random states of the limited ball joints (small to large rotations, either quaternion sign,
    some at the identity): the torques for all joints at once are the joint-by-joint ones exactly,
    zero for joints inside their box, and cleared when every joint is back inside."""
    params = rd.ragdoll_params(BodyModel(toy_body_arrays()), BETAS, "female")
    spec = mujoco.MjSpec()
    spec.compiler.degree = False
    rd.add_ragdoll(spec, params)
    model = spec.compile()
    index = rd.RagdollIndex.of(model)
    fast, slow = rd.BallLimits(params, index, 300.0), per_joint_limits(params, index, 300.0)
    assert len(slow.joints) >= 4
    data, ref = mujoco.MjData(model), mujoco.MjData(model)
    rng = np.random.default_rng(7)
    some_out = some_in = 0
    for i in range(400):
        v = rng.normal(size=(len(slow.joints), 3)) * (0.05, 0.3, 1.0, 3.0)[i % 4]
        q = rd.rotvec_to_quat(v) * rng.choice((-1.0, 1.0), (len(v), 1))
        if i % 5 == 0:
            q[rng.integers(len(q))] = (1.0, 0.0, 0.0, 0.0)
        data.qpos[fast.qpos] = q
        ref.qpos[:] = data.qpos
        fast.apply(data.qpos, data.qfrc_applied)
        slow.apply(ref.qpos, ref.qfrc_applied)
        assert data.qfrc_applied.tobytes() == ref.qfrc_applied.tobytes()
        torque = data.qfrc_applied[fast.dof].reshape(-1, 3)
        some_out += np.any(torque != 0)
        some_in += np.any(np.all(torque == 0, axis=1))
    assert some_out > 100 and some_in > 100
    data.qpos[fast.qpos] = (1.0, 0.0, 0.0, 0.0)
    fast.apply(data.qpos, data.qfrc_applied)
    assert not np.any(data.qfrc_applied)


def test_split_twist():
    axis = np.array([0.0, 0.0, 1.0])
    swing, angle = rd.split_twist(np.array([0.0, 0.0, 1.2]), axis)
    np.testing.assert_allclose(swing, [1, 0, 0, 0], atol=1e-12)
    assert angle == pytest.approx(1.2)
    w = np.array([0.3, -0.2, 0.9])
    swing, angle = rd.split_twist(w, axis)
    twist = np.array([np.cos(angle / 2), 0, 0, np.sin(angle / 2)])
    back = rd.quat_to_rotvec(rd._quat_mul(swing, twist))
    np.testing.assert_allclose(back, w, atol=1e-12)
    assert abs(swing[3]) < 1e-12  # the swing has no part about the axis


def test_pose_round_trip_through_qpos(params, solo):
    model, data, index = solo
    rng = np.random.default_rng(4)
    for _ in range(5):
        pose = random_pose(rng)
        transl = rng.normal(size=3)
        qpos = np.zeros(model.nq)
        rd.pose_to_qpos(model, index, params, pose, transl, qpos)
        back, t = rd.qpos_to_pose(model, index, params, qpos, np.zeros(72))
        np.testing.assert_allclose(t, transl, atol=1e-12)
        R_in = Rotation.from_rotvec(pose.reshape(24, 3)).as_matrix()
        R_out = Rotation.from_rotvec(back.reshape(24, 3)).as_matrix()
        joints = list(rd.CAPSULE_JOINTS)
        np.testing.assert_allclose(R_out[joints], R_in[joints], atol=1e-10)
        others = [j for j in range(24) if j not in joints]
        np.testing.assert_array_equal(back.reshape(24, 3)[others], 0.0)  # kept from pose_in


def test_ragdoll_capsules_match_the_body_model(body, params, solo):
    """MuJoCo's kinematics of the ragdoll puts every capsule where posed_capsules puts the mesh's
    (with the body's capsule lengths; the contact geoms are the same segments, the trunk's shorter)."""
    model, data, index = solo
    caps = capsules_for(body, BETAS)
    rng = np.random.default_rng(5)
    for _ in range(3):
        pose, transl = random_pose(rng), rng.normal(size=3)
        rd.pose_to_qpos(model, index, params, pose, transl, data.qpos)
        mujoco.mj_kinematics(model, data)
        g = index.geom
        axis = data.geom_xmat[g].reshape(-1, 3, 3)[:, :, 2]
        half = 0.5 * params.length[:, None]
        ends = np.stack([data.geom_xpos[g] - half * axis, data.geom_xpos[g] + half * axis], axis=1)
        mesh_ends, radius = posed_capsules(body, caps, BETAS, pose[None], transl[None])
        np.testing.assert_allclose(ends, mesh_ends[0], atol=1e-9)
        np.testing.assert_allclose(model.geom_size[g, 0], radius)
        np.testing.assert_allclose(model.geom_size[g, 1], 0.5 * params.contact_length)


@pytest.mark.parametrize("gender", ["female", "male"])
def test_trunk_contact_ends_at_the_side_of_the_mesh(gender):
    """The trunk capsules of the shipped bodies reach past the mesh's sides; their contact geoms end
    no farther out than the side of the rest mesh (the widest within 5 mm of it); the limbs' keep the
    capsule's length."""
    body = BodyModel(gender)
    for betas in (np.zeros(10), np.r_[3.0, -3.0, np.zeros(8)], np.r_[-3.0, 3.0, np.zeros(8)]):
        caps = capsules_for(body, betas)
        p = rd.ragdoll_params(body, betas, gender, caps=caps)
        trunk = sorted(TRUNK_SIDE_JOINTS)
        limbs = [k for k in range(20) if k not in TRUNK_SIDE_JOINTS]
        np.testing.assert_array_equal(p.contact_length[limbs], p.length[limbs])
        assert np.all(p.contact_length[trunk] < p.length[trunk])  # every trunk capsule sticks out
        v, _ = body.forward(betas, np.zeros(72))  # rest pose, centred on x = 0
        side_joints = [joint_index(n) for names in TRUNK_SIDE_JOINTS.values() for n in names]
        half_width = np.abs(v[0, np.isin(body.arrays.weights.argmax(1), side_joints), 0]).max()
        tips = (p.contact_length / 2 + p.radius)[trunk]
        assert np.all(tips <= half_width + 1e-3)
        assert tips.max() == pytest.approx(half_width, abs=0.005)  # the widest reaches the body's side
        assert (p.length / 2 + p.radius)[trunk].max() > half_width + 0.01


def test_home_pose_has_arms_at_the_sides_and_straight_legs(body):
    pose = rd.home_pose()
    _, joints = body.forward(np.zeros(10), pose)
    j = joints[0]
    for side in ("left", "right"):
        shoulder, wrist = j[joint_index(f"{side}_shoulder")], j[joint_index(f"{side}_wrist")]
        arm = np.linalg.norm(wrist - shoulder)
        assert shoulder[2] - wrist[2] == pytest.approx(arm, rel=0.02)  # hanging straight down
        assert abs(wrist[0]) > abs(j[joint_index(f"{side}_hip")][0])  # beside the body, not in front
    np.testing.assert_array_equal(pose.reshape(24, 3)[[1, 2, 4, 5, 7, 8]], 0.0)


def test_stiffness_scales_with_mass_and_damping_is_15x(body, params):
    heavy = rd.ragdoll_params(body, BETAS + np.array([3.0] + [0.0] * 9), "female")
    ratio = heavy.total_mass / params.total_mass
    assert ratio > 1.2
    np.testing.assert_allclose(heavy.stiffness, ratio * params.stiffness)
    neck = np.isin(CAPSULE_NAMES, ["neck", "head"])
    np.testing.assert_allclose(params.damping[~neck], 15.0 * params.stiffness[~neck])
    # the relaxed neck (default): soft, lightly damped neck and head joints
    relaxed = params.stiffness[neck] * springs.MEAN_MASS_KG["female"] / params.total_mass
    np.testing.assert_allclose(relaxed, springs.RELAXED_NECK_STIFFNESS)
    np.testing.assert_allclose(params.damping[neck], springs.RELAXED_NECK_DAMPING_S * params.stiffness[neck])
    # the relaxed spine (default): spine1-3 as soft as the limbs' joints, damped as the paper's
    spine = np.isin(CAPSULE_NAMES, ["spine", "spine1", "spine2"])  # capsules on the spine1-3 joints
    relaxed = params.stiffness[spine] * springs.MEAN_MASS_KG["female"] / params.total_mass
    np.testing.assert_allclose(relaxed, springs.RELAXED_SPINE_STIFFNESS)
    firm = rd.ragdoll_params(body, BETAS, "female", spine_stiffness=50.0)
    np.testing.assert_allclose(firm.stiffness[spine] / params.stiffness[spine], 50.0 / springs.RELAXED_SPINE_STIFFNESS)
    np.testing.assert_array_equal(firm.stiffness[~spine], params.stiffness[~spine])
    params = rd.ragdoll_params(body, BETAS, "female", relaxed_neck=False, spine_stiffness=None)  # the paper's
    np.testing.assert_allclose(params.damping, 15.0 * params.stiffness)
    k = dict(zip(CAPSULE_NAMES, params.stiffness * springs.MEAN_MASS_KG["female"] / params.total_mass))
    assert k["pelvis"] == 0.0
    assert (k["left_thigh"], k["left_calf"], k["left_foot"], k["spine1"], k["head"]) == pytest.approx(
        (6.0, 3.0, 6.0, 200.0, 200.0))
    assert (k["left_upper_arm"], k["left_forearm"], k["left_hand"]) == pytest.approx((4.0, 2.0, 4.0))


@pytest.mark.parametrize("bad", [0.0, -3.0, float("nan"), True, "10"])
def test_spine_stiffness_rejects_bad_values(body, bad):
    with pytest.raises(BadInput, match="spine_stiffness"):
        rd.ragdoll_params(body, BETAS, "female", spine_stiffness=bad)


def test_model_mass_properties(body, params, solo):
    model, _, index = solo
    assert model.body_mass[index.body].sum() == pytest.approx(params.total_mass)
    from pressurepose.body.masses import joint_frame_mass_properties, segment_masses

    caps = capsules_for(body, BETAS)
    m = segment_masses(body, BETAS, "female", caps=caps)
    com, inertia = joint_frame_mass_properties(m, caps)
    for k in range(20):
        b = index.body[k]
        R = np.zeros(9)
        mujoco.mju_quat2Mat(R, model.body_iquat[b])
        R = R.reshape(3, 3)
        np.testing.assert_allclose(R @ np.diag(model.body_inertia[b]) @ R.T, inertia[k], atol=1e-12)
        np.testing.assert_allclose(model.body_ipos[b], com[k], atol=1e-12)


def test_hinges_carry_the_joint_limits(params, solo):
    model, _, index = solo
    for k in index.hinge:
        j = rd.CAPSULE_JOINTS[k]
        a = rd.HINGE_AXIS[j]
        assert model.jnt_limited[index.jnt[k]]
        np.testing.assert_allclose(model.jnt_range[index.jnt[k]], [params.lower[k, a], params.upper[k, a]])
    assert sorted(CAPSULE_NAMES[k] for k in index.hinge) == sorted(
        ["left_calf", "right_calf", "left_forearm", "right_forearm"])


def test_reused_model_equals_a_fresh_compile(body, params):
    """Rewriting a compiled model for another body gives the model a fresh compile would."""
    bed = get_bed()
    config = SettleConfig(cell_m=0.2)
    sm = SettleModel(bed, config, params, bed.stiffness_n_m3)
    other = rd.ragdoll_params(body, np.array([2.0, -1.5, 1.0, 0, 0, 0, 0, 0, 0, 0.5]), "male")
    pose = rd.home_pose()
    pose[:3] = [0.3, -2.0, 0.2]
    pose[3 * 4] = 0.8  # left knee
    pose[3 * 18 + 1] = -1.0  # left elbow
    transl = np.array([0.3, 0.9, 0.2])
    sm.configure(other, pose, transl)
    fresh = build_spec(other, sm.cells, config).compile()
    fresh_index = rd.RagdollIndex.of(fresh)
    rd.set_spring_pose(fresh, fresh_index, other.home)
    mujoco.mj_setConst(fresh, mujoco.MjData(fresh))
    # dof_length only scales MuJoCo's sleep tolerance (sleep is off here); the sameframe flags are
    # shortcuts, and 0 (no shortcut) is always valid
    skip = {"dof_length", "body_sameframe", "geom_sameframe"}
    for name in skip - {"dof_length"}:
        mine, theirs = getattr(sm.model, name), getattr(fresh, name)
        assert np.all((mine == theirs) | (mine == 0)), name
    for name in dir(fresh):
        a = getattr(fresh, name)
        if name.startswith("_") or name in skip or not isinstance(a, np.ndarray) or a.dtype == object:
            continue
        np.testing.assert_allclose(getattr(sm.model, name), a, rtol=1e-9, atol=1e-12, err_msg=name)
    assert sm.model.stat.meaninertia == pytest.approx(fresh.stat.meaninertia)
    # and it moves the same way
    fd = mujoco.MjData(fresh)
    fd.qpos[:] = sm.data.qpos
    for _ in range(20):
        mujoco.mj_step(sm.model, sm.data)
        mujoco.mj_step(fresh, fd)
    np.testing.assert_allclose(sm.data.qpos, fd.qpos, atol=1e-10)


def test_springs_rest_at_the_home_pose(params, solo):
    model, data, index = solo
    mujoco.mj_resetData(model, data)
    rd.pose_to_qpos(model, index, params, rd.home_pose(), np.zeros(3), data.qpos)
    mujoco.mj_forward(model, data)
    np.testing.assert_allclose(data.qfrc_spring[6:], 0.0, atol=1e-9)
    pose = rd.home_pose()
    pose[3 * 16 + 2] += 0.3  # raise the left arm
    rd.pose_to_qpos(model, index, params, pose, np.zeros(3), data.qpos)
    mujoco.mj_forward(model, data)
    assert np.abs(data.qfrc_spring[6:]).max() > 0.2 * params.stiffness[CAPSULE_NAMES.index("left_upper_arm")]


def test_an_extreme_shape_with_a_zero_length_neck_still_builds():
    """Betas from U(-3, 3) can give a neck capsule of zero length (the regressor's clamp), which
    MuJoCo refuses ("size 1 must be positive in geom neck"); its contact geom keeps a minimal cylinder
    and the ragdoll compiles."""
    body = BodyModel("male")
    betas = np.array([2.56, 2.81, -2.91, 2.18, 2.89, 2.74, -2.11, 2.84, 2.34, 1.93])
    caps = capsules_for(body, betas)
    neck = CAPSULE_NAMES.index("neck")
    assert caps.length[neck] <= 0.0  # the case this guards
    p = rd.ragdoll_params(body, betas, "male", caps=caps)
    assert np.all(p.contact_length >= MIN_CONTACT_LENGTH_M)
    spec = mujoco.MjSpec()
    spec.compiler.degree = False
    rd.add_ragdoll(spec, p)
    spec.compile()
