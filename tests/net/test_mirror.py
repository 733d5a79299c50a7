"""Test-time mirror averaging (pressurepose.net.mirror): the mirror of a body is the body posed with
the mirrored parameters, the rotation midpoint is the geodesic one, and the averaged estimate of a
mirrored image is the mirror of the averaged estimate of the image, for any network."""

import dataclasses
import json
import math
import warnings

import numpy as np
import pytest
import torch

from pressurepose.body.model import BodyModel
from pressurepose.cli import main
from pressurepose.mat import custom_mat
from pressurepose.net.checkpoint import gendered_body, save_model
from pressurepose.net.infer import estimate
from pressurepose.net.mirror import (
    midpoint_rotation,
    mirror_averaged,
    mirror_images,
    mirror_joints,
    mirror_points,
    mirror_pose,
)
from pressurepose.net.model import NetConfig, PressureNet
from pressurepose.net.outputs import OutputConfig
from pressurepose.net.rotations import axis_angle_to_quat, quat_to_axis_angle
from pressurepose.pose.posture import roll_angle
from tests.net.synth import toy_body, toy_dataset

torch.set_num_threads(1)
# the toy body is 10 mm from symmetric: the network-level checks below do not need it to be
pytestmark = pytest.mark.filterwarnings("ignore:this body model is not mirror symmetric")
GRID = custom_mat(rows=16, cols=16, pitch_row_m=0.125, pitch_col_m=0.0625)


def test_mirroring_a_pose_twice_gives_it_back_and_turns_the_roll_the_other_way():
    pose = 0.5 * torch.randn(6, 72, generator=torch.Generator().manual_seed(1), dtype=torch.float64)
    torch.testing.assert_close(mirror_pose(mirror_pose(pose)), pose)
    np.testing.assert_allclose(roll_angle(mirror_pose(pose).numpy()), -roll_angle(pose.numpy()), atol=1e-12)
    p = torch.tensor([[0.1, 0.2, 0.3]])
    assert mirror_points(p, 1.0)[0].tolist() == pytest.approx([0.9, 0.2, 0.3])


@pytest.mark.parametrize("gender", ["female", "male"])
def test_the_default_bodies_are_mirror_symmetric(gender):
    """The open body models' mirrored parameters pose the mirrored skeleton to within 2 mm: what
    makes the mirror of an image the image of the mirrored body."""
    layer = BodyModel(gender).torch_layer(dtype=torch.float64)
    g = torch.Generator().manual_seed(2)
    pose = 0.4 * torch.randn(4, 72, generator=g, dtype=torch.float64)
    betas = torch.randn(4, 10, generator=g, dtype=torch.float64)
    transl = torch.tensor([[0.3, 1.0, 0.1]], dtype=torch.float64).expand(4, 3)
    width = 0.77
    a = layer(betas=betas, body_pose=pose[:, 3:], global_orient=pose[:, :3], transl=transl)
    mp = mirror_pose(pose)
    b = layer(betas=betas, body_pose=mp[:, 3:], global_orient=mp[:, :3], transl=mirror_points(transl, width))
    err = (mirror_joints(a.joints, width) - b.joints).norm(dim=-1)
    assert float(err.max()) < 2e-3


def test_an_asymmetric_body_is_warned_about_once(net):
    from pressurepose.net.mirror import rest_asymmetry_m

    assert rest_asymmetry_m(BodyModel("female").torch_layer()) < 1e-4
    toy = toy_body()  # its boxes are not placed symmetrically (10 mm)
    net2 = PressureNet(net.config, gendered_body(toy, toy)).eval()
    p = toy_dataset(1, grid=GRID)
    with pytest.warns(UserWarning, match="not mirror symmetric"):
        with torch.no_grad():
            mirror_averaged(net2, p["pressure"], p["gender"])
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        with torch.no_grad():
            mirror_averaged(net2, p["pressure"], p["gender"])  # once per body layer


def test_midpoint_rotation_is_the_geodesic_midpoint():
    axis = torch.tensor([0.6, 0.0, 0.8], dtype=torch.float64)
    for angle in (0.0, 0.3, 2.0, 3.0):
        mid = midpoint_rotation(torch.zeros(1, 3, dtype=torch.float64), (angle * axis)[None])
        torch.testing.assert_close(mid[0], 0.5 * angle * axis)
    g = torch.Generator().manual_seed(3)
    a, b = (torch.randn(20, 3, generator=g, dtype=torch.float64) for _ in range(2))
    ab, ba = midpoint_rotation(a, b), midpoint_rotation(b, a)
    qa, qb = axis_angle_to_quat(ab), axis_angle_to_quat(ba)
    assert torch.allclose((qa * qb).sum(-1).abs(), torch.ones(20, dtype=torch.float64))  # symmetric
    torch.testing.assert_close(midpoint_rotation(a, a), quat_to_axis_angle(axis_angle_to_quat(a)))
    # equally far from both ends: the angle of R_a^T R_mid equals that of R_mid^T R_b
    def angle_between(x, y):
        dot = (axis_angle_to_quat(x) * axis_angle_to_quat(y)).sum(-1).abs().clamp(max=1)
        return 2 * torch.acos(dot)
    torch.testing.assert_close(angle_between(a, ab), angle_between(ab, b))
    torch.testing.assert_close(angle_between(a, ab) * 2, angle_between(a, b))
    assert math.isfinite(float(midpoint_rotation(torch.zeros(1, 3), torch.tensor([[math.pi, 0, 0]])).sum()))


@pytest.fixture(scope="module")
def net():
    torch.manual_seed(0)
    body = toy_body()
    cfg = NetConfig(grid=GRID, outputs=OutputConfig.default((0.5, 1.0, 0.2), (0.3, 0.3, 0.1)))
    return PressureNet(cfg, gendered_body(body, body)).eval()


@pytest.mark.parametrize("use_pmr", [True, False])
def test_the_averaged_estimate_of_a_mirrored_image_is_the_mirrored_estimate(net, use_pmr):
    """Holds for any network, trained or not (both branches are read either way): a check of every
    sign and swap in the mirroring and the averaging; with and without PMR (the paper's ablation)."""
    if not use_pmr:
        net = PressureNet(dataclasses.replace(net.config, use_pmr=False), net.body).eval()
    data = toy_dataset(4, grid=GRID)
    p, g = data["pressure"], data["gender"]
    with torch.no_grad():
        _, a = mirror_averaged(net, p, g)
        _, b = mirror_averaged(net, mirror_images(p), g)
        plain1, plain2 = net(p, g)
    width = GRID.size_m[0]
    torch.testing.assert_close(b.params.betas, a.params.betas, atol=1e-5, rtol=0)
    torch.testing.assert_close(b.params.transl, mirror_points(a.params.transl, width), atol=1e-5, rtol=0)
    qa = axis_angle_to_quat(mirror_pose(a.params.pose).view(-1, 24, 3))
    qb = axis_angle_to_quat(b.params.pose.view(-1, 24, 3))
    torch.testing.assert_close((qa * qb).sum(-1).abs(), torch.ones(4, 24), atol=1e-5, rtol=0)
    # an untrained network is not symmetric, so averaging changes its estimate
    assert float((a.joints - plain2.joints).abs().max()) > 1e-4
    assert a.maps is not None and a.maps.q.shape == (4, 16, 16)


def test_estimate_and_the_cli_take_mirror(net, tmp_path):
    body = net.body.layers[0]
    path = save_model(tmp_path / "m.safetensors", net, (toy_body(), toy_body()))
    data = toy_dataset(2, grid=GRID)
    x = data["pressure"].numpy()
    plain = estimate(x, "f", model=path)
    mirrored = estimate(x, "f", model=path, mirror=True)
    assert mirrored.joints.shape == plain.joints.shape == (2, 24, 3)
    assert mirrored.mod1_joints.shape == (2, 24, 3) and body is not None
    assert not np.allclose(mirrored.joints, plain.joints)
    np.save(tmp_path / "p.npy", x)
    assert main(["infer", str(tmp_path / "p.npy"), "--gender", "f", "--model", str(path), "--out",
                 str(tmp_path / "e"), "--mirror", "--max-figures", "0"]) == 0
    got = np.load(tmp_path / "e" / "estimate.npz")["joints"]
    np.testing.assert_allclose(got, mirrored.joints, atol=1e-5)
    assert mirrored.mirror and not plain.mirror
    assert json.loads((tmp_path / "e" / "estimate.json").read_text())["mirror_averaged"] is True
