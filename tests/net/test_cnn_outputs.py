import numpy as np
import pytest
import torch

from pressurepose.body.lbs_numpy import Y_UP_TO_Z_UP
from pressurepose.body.lbs_torch import batch_rodrigues
from pressurepose.net.cnn import NUM_OUTPUTS, PressureCNN, flattened_size
from pressurepose.net.outputs import (
    ANATOMICAL_RANGES_DEG,
    OutputConfig,
    OutputLayer,
    network_joint_ranges,
    sampled_joint_limits,
)
from pressurepose.net.rotations import euler_to_root_axis_angle, pairs_to_euler
from pressurepose.pose.root import world_rotation

torch.set_num_threads(1)


def test_flattened_size_of_the_paper_input_is_67200():
    assert flattened_size(128, 54) == 67_200
    cnn = PressureCNN(3, 128, 54)
    assert cnn.fc.in_features == 67_200 and cnn.fc.out_features == NUM_OUTPUTS == 88
    assert cnn(torch.zeros(2, 3, 128, 54)).shape == (2, 88)
    convs = [m for m in cnn.features if isinstance(m, torch.nn.Conv2d)]
    assert [c.out_channels for c in convs] == [192, 192, 384, 384]
    assert (convs[0].kernel_size, convs[0].stride, convs[0].padding) == ((7, 7), (2, 2), (3, 3))
    assert all(c.kernel_size == (3, 3) and c.stride == (1, 1) and c.padding == (0, 0) for c in convs[1:])
    assert sum(isinstance(m, torch.nn.Tanh) for m in cnn.features) == 4
    assert [m.p for m in cnn.features if isinstance(m, torch.nn.Dropout)] == [0.1] * 4


def test_eval_forward_equals_the_layer_sequence():
    torch.manual_seed(0)
    cnn = PressureCNN(3, 64, 40).eval()
    x = torch.randn(2, 3, 64, 40)
    with torch.no_grad():
        ref = cnn.fc(cnn.features(x).flatten(1))  # conv, tanh, dropout (identity), pool, ...
        assert torch.allclose(cnn(x), ref, atol=1e-6)
    cnn.train()
    torch.manual_seed(1)
    a = cnn(x)
    torch.manual_seed(1)
    b = cnn.fc(cnn.features(x.contiguous(memory_format=torch.channels_last)).flatten(1))
    assert torch.allclose(a, b, atol=1e-6)


def test_cnn_other_mats_and_gender_input():
    cnn = PressureCNN(5, 56 * 2, 40 * 2, gender_input=True)  # TIP sheet, Mod2 channels
    assert cnn.fc.in_features == flattened_size(112, 80) + 1
    out = cnn(torch.zeros(3, 5, 112, 80), torch.tensor([0, 1, 1]))
    assert out.shape == (3, 88)
    with pytest.raises(ValueError):
        PressureCNN(3, 20, 20)


def test_network_ranges_use_the_sampler_table_and_anatomical_fallbacks():
    lo, hi = network_joint_ranges(inflate=1.0)
    s_lo, s_hi = sampled_joint_limits()
    lo, hi = lo.reshape(23, 3), hi.reshape(23, 3)
    wide = (s_hi[1:] - s_lo[1:]) > np.deg2rad(1)
    np.testing.assert_allclose(lo[wide], s_lo[1:][wide])
    np.testing.assert_allclose(hi[wide], s_hi[1:][wide])
    # spine1 (joint 3) is not sampled: anatomical range
    np.testing.assert_allclose(np.rad2deg(lo[2]), np.array(ANATOMICAL_RANGES_DEG["spine"])[:, 0])
    assert np.all(hi > lo)
    # inflation is about the middle
    lo2, hi2 = network_joint_ranges(inflate=1.2)
    np.testing.assert_allclose((lo2 + hi2) / 2, (lo + hi).reshape(-1) / 2, atol=1e-12)
    np.testing.assert_allclose(hi2 - lo2, 1.2 * (hi - lo).reshape(-1), atol=1e-12)


def _layer(gain=0.1):
    return OutputLayer(OutputConfig.default((0.4, 0.9, 0.1), (0.4, 0.4, 0.1), gain=gain))


def test_soft_limits_hold_for_extreme_raw_values():
    layer = _layer()
    lo = torch.tensor(layer.config.angle_lower)
    hi = torch.tensor(layer.config.angle_upper)
    g = torch.Generator().manual_seed(0)
    raw = torch.cat([torch.randn(64, 88, generator=g) * 10 ** torch.randint(0, 7, (64, 1), generator=g),
                     torch.full((1, 88), 1e9), torch.full((1, 88), -1e9)])
    p = layer(raw)
    assert torch.all(p.body_pose >= lo) and torch.all(p.body_pose <= hi)
    assert torch.all(p.betas.abs() <= 3.0)
    assert torch.all(p.root_euler.abs() <= np.pi)
    assert torch.isfinite(p.global_orient).all()
    # raw 0: the home estimate (angles mid-range, betas 0, translation offset, supine root)
    home = layer(torch.zeros(1, 88))
    assert torch.allclose(home.body_pose[0], (lo + hi) / 2)
    assert torch.all(home.betas == 0) and torch.allclose(home.transl, torch.tensor([[0.4, 0.9, 0.1]]))
    assert torch.all(home.root_euler == 0)


def test_residuals_add_in_the_unconstrained_space():
    layer = _layer()
    raw1 = torch.randn(4, 88)
    p1 = layer(raw1)
    assert torch.allclose(layer(torch.zeros(4, 88), base=p1).body_pose, p1.body_pose)
    p2 = layer(raw1, base=layer(torch.zeros(4, 88)))
    assert torch.allclose(p2.unconstrained, p1.unconstrained, atol=1e-6)


def _rx(a):
    c, s = np.cos(a), np.sin(a)
    return np.array([[1, 0, 0], [0, c, -s], [0, s, c]])


def _ry(a):
    c, s = np.cos(a), np.sin(a)
    return np.array([[c, 0, s], [0, 1, 0], [-s, 0, c]])


def _rz(a):
    c, s = np.cos(a), np.sin(a)
    return np.array([[c, -s, 0], [s, c, 0], [0, 0, 1]])


W0 = np.array([[-1.0, 0, 0], [0, 0, -1], [0, -1, 0]])  # supine, head toward row 0


def test_root_euler_convention():
    rng = np.random.default_rng(0)
    eulers = np.concatenate([[[0, 0, 0], [np.pi, 0, 0], [-np.pi / 2, 0.1, 0.4]],
                             rng.uniform(-np.pi, np.pi, (20, 3))])
    r = euler_to_root_axis_angle(torch.tensor(eulers))
    R = batch_rodrigues(r).numpy()
    Q = Y_UP_TO_Z_UP
    for e, Rs in zip(eulers, R):
        W = _rz(e[2]) @ _rx(e[1]) @ _ry(-e[0]) @ W0
        np.testing.assert_allclose(Q @ Rs @ Q.T, W, atol=1e-12)
    # with pitch 0: the pose sampler's (roll, yaw) convention
    e0 = torch.tensor([[0.7, 0.0, -0.3], [-2.0, 0.0, 0.5]], dtype=torch.float64)
    Rs0 = np.einsum("ij,bjk,lk->bil", Q, batch_rodrigues(euler_to_root_axis_angle(e0)).numpy(), Q)
    np.testing.assert_allclose(Rs0, world_rotation(e0[:, 0].numpy(), e0[:, 2].numpy()), atol=1e-12)
    # supine: the rest body's head (+z) points to -y (row 0), its front (-y) points up
    np.testing.assert_allclose(W0 @ [0, 0, 1], [0, -1, 0])
    np.testing.assert_allclose(W0 @ [0, -1, 0], [0, 0, 1])
    # pairs -> angles by atan2
    pairs = torch.tensor([[1.0, 0.0, -1.0, 0.0, 2.0, 0.0]])
    assert torch.allclose(pairs_to_euler(pairs), torch.tensor([[0.0, np.pi / 2, np.pi]]))


def test_root_rotation_gradients_by_finite_differences():
    # through the rotation matrix (smooth everywhere, also at the supine / prone angle pi points)
    e = torch.tensor([[0.0, 0.0, 0.0], [np.pi - 1e-3, 0.05, -0.2], [0.3, -0.2, 0.1]], dtype=torch.float64,
                     requires_grad=True)
    assert torch.autograd.gradcheck(lambda x: batch_rodrigues(euler_to_root_axis_angle(x)), (e,))
