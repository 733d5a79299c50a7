import dataclasses

import numpy as np
import torch

from pressurepose.body.model import BodyModel
from pressurepose.body.toy import toy_body_arrays
from pressurepose.mat import custom_mat
from pressurepose.net.checkpoint import gendered_body
from pressurepose.net.losses import LossScales, dataset_scales, loss_l1, loss_l2
from pressurepose.net.model import ModuleOutput, NetConfig, PressureNet
from pressurepose.net.outputs import BodyParams, OutputConfig
from pressurepose.net.pmr import PMRMaps
from pressurepose.net.transforms import InputConfig
from tests.net.synth import toy_dataset

torch.set_num_threads(1)
GRID = custom_mat(rows=20, cols=16, pitch_row_m=0.1, pitch_col_m=0.0625)  # 2 x 1 m, input 40 x 32


def _config(**kw) -> NetConfig:
    return NetConfig(grid=GRID, outputs=OutputConfig.default((0.5, 1.0, 0.2), (0.3, 0.3, 0.1)), **kw)


def _bodies():
    female = BodyModel(toy_body_arrays())
    arrays = toy_body_arrays()
    male = BodyModel(dataclasses.replace(arrays, v_template=arrays.v_template * 1.1))
    return female, male


def test_shapes_and_gradients_through_the_whole_network():
    torch.manual_seed(0)
    data = toy_dataset(4, grid=GRID)
    net = PressureNet(_config(), gendered_body(*_bodies()))
    out1, out2 = net(data["pressure"], data["gender"])
    for out in (out1, out2):
        assert out.vertices.shape == (4, 192, 3) and out.joints.shape == (4, 24, 3)
        assert out.params.pose.shape == (4, 72) and out.params.betas.shape == (4, 10)
        assert out.maps.q.shape == (4, 20, 16)
    # Mod2 starts as the identity on Mod1's estimate (zero-initialised residual layer)
    assert torch.allclose(out2.params.unconstrained, out1.params.unconstrained)
    assert net.mod2.cnn.features[0].in_channels == 5 and net.mod1.cnn.features[0].in_channels == 3
    # L2 of Mod2 reaches Mod2's CNN (all layers), not Mod1's
    x1 = net.inputs(data["pressure"])
    with torch.no_grad():
        base = net.run_mod1(x1, data["gender"])
    out = net.run_mod2(x1, data["gender"], base)
    scales = dataset_scales(data["joints"], data["betas"], out.maps.q.detach() + 1, out.maps.contact)
    loss, parts = loss_l2(out, data["joints"], data["betas"], torch.zeros(4, 20, 16), torch.zeros(4, 20, 16), scales)
    loss.backward()
    assert all(p.grad is not None and torch.isfinite(p.grad).all() for p in net.mod2.parameters())
    assert float(net.mod2.cnn.fc.weight.grad.abs().sum()) > 0
    assert all(p.grad is None for p in net.mod1.parameters())
    # and L1 of Mod1 reaches every Mod1 weight (through the body layer), with finite values
    net.zero_grad()
    loss1, _ = loss_l1(net.run_mod1(x1, data["gender"], maps=False), data["joints"], data["betas"])
    loss1.backward()
    assert all(p.grad is not None and torch.isfinite(p.grad).all() and p.grad.abs().sum() > 0
               for p in net.mod1.parameters())


def test_gender_selects_the_body_per_element():
    female, male = _bodies()
    body = gendered_body(female, male)
    g = torch.Generator().manual_seed(0)
    params = BodyParams(unconstrained=torch.zeros(4, 88), betas=torch.randn(4, 10, generator=g),
                        transl=torch.randn(4, 3, generator=g), root_euler=torch.zeros(4, 3),
                        global_orient=torch.randn(4, 3, generator=g), body_pose=0.2 * torch.randn(4, 69, generator=g))
    gender = torch.tensor([0, 1, 1, 0])
    verts, joints = body(params, gender)
    for i, model in enumerate([female, male, male, female]):
        v, j = model.forward(params.betas[i].numpy(), params.pose[i].numpy(), params.transl[i].numpy())
        np.testing.assert_allclose(verts[i].numpy(), v[0], atol=1e-5)
        np.testing.assert_allclose(joints[i].numpy(), j[0], atol=1e-5)
    # the GPU's path (both bodies for the whole batch, picked per element) gives the same bodies
    args = dict(betas=params.betas, body_pose=params.body_pose, global_orient=params.global_orient,
                transl=params.transl, check=False)
    for vertices in (True, False):
        v_sel, j_sel = body._posed_by_selection(args, gender, vertices)
        torch.testing.assert_close(j_sel, joints, atol=1e-6, rtol=0)
        if vertices:
            torch.testing.assert_close(v_sel, verts, atol=1e-6, rtol=0)
        else:
            assert v_sel is None


def test_ablations_change_the_inputs():
    data = toy_dataset(2, grid=GRID)
    net = PressureNet(_config(use_pmr=False, inputs=InputConfig(edges_contact=False)),
                      gendered_body(*_bodies()))
    assert net.mod1.cnn.features[0].in_channels == 1 and net.mod2.cnn.features[0].in_channels == 1
    out1, out2 = net(data["pressure"], data["gender"])
    assert out1.maps is None and out2.maps is not None


def test_config_round_trip():
    cfg = _config(gender_input=True)
    assert NetConfig.from_dict(cfg.to_dict()) == cfg


def _fake_output(joints, betas, q=None, c=None):
    params = BodyParams(torch.zeros(1, 88), betas, torch.zeros(1, 3), torch.zeros(1, 3), torch.zeros(1, 3),
                        torch.zeros(1, 69))
    maps = None if q is None else PMRMaps(depth=-q / 1000, q=q, contact_soft=c, contact=c)
    return ModuleOutput(params, torch.zeros(1, 1, 3), joints, maps)


def test_losses_against_hand_computed_values():
    true_j = torch.zeros(1, 24, 3)
    pred_j = true_j.clone()
    pred_j[..., 0], pred_j[..., 1] = 0.03, 0.04  # every joint 5 cm off
    pred_j[0, 0] = 0  # ... but the first exact
    betas = torch.zeros(1, 10)
    pred_b = torch.zeros(1, 10)
    pred_b[0, :5] = 1.0  # mean |error| 0.5
    s = LossScales(joints_m=0.1, betas=2.0, q=4.0, contact=0.5)
    loss, parts = loss_l1(_fake_output(pred_j, pred_b), true_j, betas, s)
    assert abs(float(loss) - (0.05 * 23 / 24 / 0.1 + 0.5 / 2.0)) < 1e-5
    q_hat = torch.zeros(1, 2, 2)
    q_hat[0, 0, 0] = 6.0  # squared error 36 on 1 of 4 taxels -> mean 9
    c_hat = torch.full((1, 2, 2), 0.25)
    loss2, parts2 = loss_l2(_fake_output(pred_j, pred_b, q_hat, c_hat), true_j, betas, torch.zeros(1, 2, 2),
                            torch.zeros(1, 2, 2), s)
    assert abs(float(loss2) - float(loss) - (9.0 / 16.0 + 0.25 / 0.5)) < 1e-5
    # paper sigmas by default; dataset sigmas from data
    assert LossScales().joints_m == 0.17528 and LossScales().betas == 1.72816
    j = torch.zeros(4, 24, 3)
    j[:2, :, 0], j[2:, :, 0] = 1.0, -1.0  # x std 1 about the mean, y and z 0 -> pooled sqrt(1/3)
    sc = dataset_scales(j, torch.tensor([[1.0] * 10, [-1.0] * 10]), torch.tensor([0.0, 2.0]), None)
    assert abs(sc.joints_m - (1 / 3) ** 0.5) < 1e-9 and abs(sc.betas - (20 / 19) ** 0.5) < 1e-9
    assert abs(sc.q - 2 ** 0.5) < 1e-9 and sc.contact == 1.0


def test_mixed_precision_keeps_geometry_in_float32():
    # what a CUDA training step does, here with CPU autocast (bfloat16)
    data = toy_dataset(2, grid=GRID)
    net = PressureNet(_config(), gendered_body(*_bodies()))
    with torch.autocast("cpu", dtype=torch.bfloat16):
        x1 = net.inputs(data["pressure"])
        out1 = net.run_mod1(x1, data["gender"])
        out2 = net.run_mod2(x1, data["gender"], out1)
        assert net.mod1.cnn(x1).dtype == torch.bfloat16  # the CNN does run in half precision
        loss, _ = loss_l2(out2, data["joints"], data["betas"], torch.zeros(2, 20, 16), torch.zeros(2, 20, 16),
                          LossScales())
    assert x1.dtype == torch.float32 and out1.vertices.dtype == torch.float32
    assert out2.maps.q.dtype == torch.float32 and out2.params.betas.dtype == torch.float32
    loss.backward()
    assert all(torch.isfinite(p.grad).all() for p in net.mod2.parameters())
