"""Joint limits: the public code's ranges mean what the sampler says on a real body (elbows bend the
forearm forward, knees bend backward, hips flex forward, shoulders lift), the 1 : 2 collar/shoulder
split, and the hands-behind-head widening."""

import numpy as np
import pytest

from pressurepose.body.joints import joint_index as J
from pressurepose.pose.limits import joint_limits


def posed_joints(body, **local_deg):
    """Joints (24, 3) of the mean body (z-up, rest facing -y) with some local rotations in degrees."""
    pose = np.zeros((24, 3))
    for name, vec in local_deg.items():
        pose[J(name)] = np.deg2rad(vec)
    return body.forward(np.zeros(10), pose.reshape(1, 72))[1][0]


def test_elbows_bend_the_forearm_forward_within_their_limits(female):
    lim = joint_limits()
    lo_l, hi_r = lim.lower[J("left_elbow"), 1], lim.upper[J("right_elbow"), 1]
    assert np.rad2deg([lo_l, hi_r]) == pytest.approx([-147.3, 147.3])
    assert lim.hinge_axis[J("left_elbow")] == 1 and lim.hinge_axis[J("left_knee")] == 0
    rest = posed_joints(female)
    bent = posed_joints(female, left_elbow=(0, np.rad2deg(lo_l), 0), right_elbow=(0, np.rad2deg(hi_r), 0))
    for side in ("left", "right"):
        e, w, s = J(f"{side}_elbow"), J(f"{side}_wrist"), J(f"{side}_shoulder")
        forearm = bent[w] - bent[e]
        assert forearm[1] < -0.4 * np.linalg.norm(forearm)  # forward, the way the body faces (-y)
        # folded back toward the shoulder: the wrist ends near the shoulder, far closer than at rest
        assert np.linalg.norm(bent[w] - bent[s]) < 0.5 * np.linalg.norm(rest[w] - rest[s])
    # the other end of the range barely moves the forearm (hyperextension 2.8 deg)
    straight = posed_joints(female, left_elbow=(0, np.rad2deg(lim.upper[J("left_elbow"), 1]), 0))
    assert np.linalg.norm(straight[J("left_wrist")] - rest[J("left_wrist")]) < 0.02


def test_knee_bends_back_and_hip_flexes_forward(female):
    lim = joint_limits()
    rest = posed_joints(female)
    knee = posed_joints(female, left_knee=(np.rad2deg(lim.upper[J("left_knee"), 0]), 0, 0))
    assert knee[J("left_ankle"), 1] - knee[J("left_knee"), 1] > 0.2  # calf behind the knee (+y)
    hip = posed_joints(female, left_hip=(np.rad2deg(lim.lower[J("left_hip"), 0]), 0, 0))  # -90 deg
    thigh = hip[J("left_knee")] - hip[J("left_hip")]
    assert thigh[1] < -0.9 * np.linalg.norm(thigh)  # straight forward
    assert rest[J("left_knee"), 2] < rest[J("left_hip"), 2] - 0.3


@pytest.mark.parametrize("side,sign", [("left", 1), ("right", -1)])
def test_shoulder_z_lifts_the_arm_and_is_split_one_third_to_the_collar(female, side, sign):
    lim = joint_limits()
    s = 0 if side == "left" else 1
    top = lim.shoulder_upper[s, 2] if sign > 0 else lim.shoulder_lower[s, 2]
    assert abs(np.rad2deg(top)) == pytest.approx(80.4)
    total = np.array([0.0, 0.0, np.rad2deg(top)])
    split = posed_joints(female, **{f"{side}_collar": total / 3, f"{side}_shoulder": 2 * total / 3})
    sh, wr = J(f"{side}_shoulder"), J(f"{side}_wrist")
    assert split[wr, 2] - split[sh, 2] > 0.4  # raised near vertical
    np.testing.assert_allclose(lim.lower[J(f"{side}_collar")], lim.shoulder_lower[s] / 3)
    np.testing.assert_allclose(lim.upper[J(f"{side}_shoulder")], 2 * lim.shoulder_upper[s] / 3)


def test_hands_behind_head_widens_the_lifting_side_by_45_degrees():
    nominal, widened = joint_limits(), joint_limits("hands_behind_head")
    d_lo = np.rad2deg(widened.shoulder_lower - nominal.shoulder_lower)
    d_hi = np.rad2deg(widened.shoulder_upper - nominal.shoulder_upper)
    np.testing.assert_allclose(d_hi, [[45, 0, 45], [45, 0, 0]], atol=1e-9)
    np.testing.assert_allclose(d_lo, [[0, 0, 0], [0, 0, -45]], atol=1e-9)
    np.testing.assert_array_equal(widened.lower[J("left_hip")], nominal.lower[J("left_hip")])


def test_within_checks_ranges_and_the_collar_split():
    lim = joint_limits()
    pose = np.zeros((3, 24, 3))
    total = np.deg2rad([10.0, -100.0, 50.0])
    pose[:, J("left_collar")] = total / 3
    pose[:, J("left_shoulder")] = 2 * total / 3
    pose[1, J("left_knee"), 0] = np.deg2rad(150.0)  # beyond 139.9
    pose[2, J("left_collar")] = total / 2  # not a 1 : 2 split
    pose[2, J("left_shoulder")] = total / 2
    assert lim.within(pose.reshape(3, 72)).tolist() == [True, False, False]
    spine = np.zeros((1, 24, 3))
    spine[0, J("spine1"), 0] = 0.1  # held at 0 by the sampler
    assert not lim.within(spine.reshape(1, 72))[0]
