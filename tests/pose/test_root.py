"""Root orientation on the bed: roll/yaw conventions checked on the real mesh (nose up when supine,
down when prone, head toward row 0) and the axis-angle conversion through the body model."""

import numpy as np
import pytest

from pressurepose.body.joints import joint_index as J
from pressurepose.pose.root import (
    body_axes,
    root_axis_angle,
    root_rotation,
    world_rotation,
)


def nose_index(body):
    """The most forward (-y) vertex of the rest head, above the neck: the tip of the nose."""
    verts, joints = body.rest(np.zeros((1, 10)))
    v, j = verts[0], joints[0]
    head = np.flatnonzero(v[:, 2] > j[J("neck"), 2] + 0.05)
    return head[np.argmin(v[head, 1])]


def test_axes_of_the_named_postures():
    ax = body_axes(world_rotation([0.0, np.pi / 2, -np.pi / 2, np.pi], [0.0] * 4))
    np.testing.assert_allclose(ax["head"], [[0, -1, 0]] * 4, atol=1e-12)  # head toward row 0
    np.testing.assert_allclose(ax["face"][0], [0, 0, 1], atol=1e-12)  # supine: face up
    np.testing.assert_allclose(ax["left"][0], [-1, 0, 0], atol=1e-12)
    np.testing.assert_allclose(ax["left"][1], [0, 0, -1], atol=1e-12)  # +pi/2: on the left side
    np.testing.assert_allclose(ax["left"][2], [0, 0, 1], atol=1e-12)  # -pi/2: on the right side
    np.testing.assert_allclose(ax["face"][3], [0, 0, -1], atol=1e-12)  # prone


@pytest.mark.parametrize("yaw", [-0.5, 0.3])
def test_yaw_turns_counter_clockwise_seen_from_above(yaw):
    head = body_axes(world_rotation([0.7], [yaw]))["head"][0]
    np.testing.assert_allclose(head, [np.sin(yaw), -np.cos(yaw), 0.0], atol=1e-12)


def test_root_axis_angle_round_trip_through_the_body_model(female):
    rng = np.random.default_rng(0)
    roll, yaw = rng.uniform(-np.pi, np.pi, 5), rng.uniform(-np.pi / 6, np.pi / 6, 5)
    W = world_rotation(roll, yaw)
    r = root_axis_angle(W)
    np.testing.assert_allclose(root_rotation(r), W, atol=1e-10)
    pose = np.zeros((5, 72))
    pose[:, :3] = r
    betas = rng.uniform(-3, 3, (5, 10))
    _, joints = female.forward(betas, pose)
    _, rest = female.rest(betas)
    expected = np.einsum("bij,bkj->bki", W, rest - rest[:, :1]) + rest[:, :1]
    np.testing.assert_allclose(joints, expected, atol=1e-9)


@pytest.mark.parametrize("roll,up", [(0.0, True), (np.pi, False)])
def test_nose_points_up_when_supine_and_down_when_prone(female, roll, up):
    pose = np.zeros((1, 72))
    pose[0, :3] = root_axis_angle(world_rotation([roll], [0.0]))
    verts, joints = female.forward(np.zeros((1, 10)), pose)
    nose, head, pelvis = verts[0, nose_index(female)], joints[0, J("head")], joints[0, J("pelvis")]
    assert (nose[2] - head[2] > 0.05) == up and (head[2] - nose[2] > 0.05) == (not up)
    assert head[1] < pelvis[1] - 0.4  # head toward row 0
