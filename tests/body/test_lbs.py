"""Skinning: a hand-built model with answers worked out on paper, numpy/torch agreement, gradients."""

import numpy as np
import pytest
import torch

from pressurepose.body import BodyModel
from pressurepose.body.lbs_numpy import Y_UP_TO_Z_UP, rodrigues
from pressurepose.body.lbs_torch import batch_rodrigues
from pressurepose.body.smpl_io import SmplArrays
from pressurepose.body.toy import TOY_REST_JOINTS, toy_body_arrays
from pressurepose.errors import BadInput


def chain_model() -> SmplArrays:
    """Three joints on the model x axis at 0, 1, 2 m; vertices at known places and weights."""
    v = np.array([[0.5, 0, 0], [1.5, 0, 0], [2.5, 0, 0], [1.5, 0, 0], [0, 0, 0], [1, 0, 0], [2, 0, 0]], float)
    w = np.zeros((7, 3))
    w[0, 0] = w[1, 1] = w[2, 2] = 1
    w[3, :2] = 0.5
    w[4, 0] = w[5, 1] = w[6, 2] = 1
    jreg = np.zeros((3, 7))
    jreg[0, 4] = jreg[1, 5] = jreg[2, 6] = 1
    shapedirs = np.zeros((7, 3, 1))
    shapedirs[:, 0, 0] = 0.1 * np.arange(7)  # beta moves vertex i by 0.1 i along x
    return SmplArrays(v, shapedirs, np.zeros((7, 3, 18)), jreg, w, np.array([-1, 0, 1]),
                      np.array([[0, 1, 2]]), {"source": "chain"})


def test_chain_model_answers_known_on_paper():
    body = BodyModel(chain_model())
    pose = np.zeros(9)
    pose[3:6] = [0, 0, np.pi / 2]  # joint 1 turns 90 deg about the model z axis
    verts, joints = body.forward(np.zeros(1), pose, transl=[0.0, 0.0, 1.0])
    # in the model frame: v1 -> (1, .5, 0), v2 -> (1, 1.5, 0), v3 -> mean of (1.5,0,0),(1,.5,0);
    # the output frame maps (x, y, z) -> (x, -z, y), then adds transl.
    expected = np.array([[0.5, 0, 1], [1, 0, 1.5], [1, 0, 2.5], [1.25, 0, 1.25]])
    np.testing.assert_allclose(verts[0, :4], expected, atol=1e-12)
    np.testing.assert_allclose(joints[0], [[0, 0, 1], [1, 0, 1], [1, 0, 2]], atol=1e-12)
    # shape: beta = 1 moves joint vertices 4, 5, 6 by 0.4, 0.5, 0.6 along x
    _, j = body.forward(np.ones(1), np.zeros(9))
    np.testing.assert_allclose(j[0, :, 0], [0.4, 1.5, 2.6], atol=1e-12)


def test_global_orient_rotates_whole_body_rigidly():
    body = BodyModel(toy_body_arrays())
    rng = np.random.default_rng(1)
    betas = rng.uniform(-2, 2, (1, 10))
    pose = np.zeros((1, 72))
    v0, j0 = body.forward(betas, pose)
    pose[0, :3] = [0.3, -1.2, 0.7]
    v1, j1 = body.forward(betas, pose)
    # world rotation W = Q R Q^T about the root joint
    W = Y_UP_TO_Z_UP @ rodrigues(pose[0, :3]) @ Y_UP_TO_Z_UP.T
    root = j0[0, 0]
    np.testing.assert_allclose(v1[0], (v0[0] - root) @ W.T + root, atol=1e-10)


def test_rest_pose_is_z_up_and_faces_minus_y():
    body = BodyModel(toy_body_arrays())
    _, j = body.forward(np.zeros(10), np.zeros(72))
    np.testing.assert_allclose(j[0], TOY_REST_JOINTS, atol=1e-12)
    assert j[0, 15, 2] > j[0, 0, 2] > j[0, 7, 2]          # head above pelvis above ankle
    assert j[0, 16, 0] > 0 > j[0, 17, 0]                    # left shoulder at +x
    assert j[0, 10, 1] < j[0, 7, 1]                         # toes in front (-y) of the ankle


@pytest.mark.parametrize("dtype,atol", [(torch.float64, 1e-10), (torch.float32, 2e-5)])
def test_numpy_and_torch_agree(dtype, atol):
    body = BodyModel(toy_body_arrays())
    rng = np.random.default_rng(0)
    arrays = body.arrays
    # give the toy pose blend shapes so that path is exercised too
    pd = 0.01 * rng.standard_normal(arrays.posedirs.shape)
    body = BodyModel(SmplArrays(arrays.v_template, arrays.shapedirs, pd, arrays.J_regressor,
                                arrays.weights, arrays.parents, arrays.faces, {"source": "toy+pd"}))
    b = 4
    betas, pose, transl = rng.normal(size=(b, 10)), rng.normal(scale=0.6, size=(b, 72)), rng.normal(size=(b, 3))
    v_np, j_np = body.forward(betas, pose, transl)
    layer = body.torch_layer(dtype=dtype)
    t = lambda a: torch.as_tensor(a, dtype=dtype)  # noqa: E731
    out = layer(betas=t(betas), body_pose=t(pose[:, 3:]), global_orient=t(pose[:, :3]), transl=t(transl))
    np.testing.assert_allclose(out.vertices.numpy(), v_np, atol=atol)
    np.testing.assert_allclose(out.joints.numpy(), j_np, atol=atol)


def test_torch_layer_gradcheck():
    torch.manual_seed(0)
    layer = BodyModel(toy_body_arrays()).torch_layer(dtype=torch.float64)
    betas = torch.randn(1, 10, dtype=torch.float64, requires_grad=True)
    body_pose = (0.5 * torch.randn(1, 69, dtype=torch.float64)).requires_grad_()
    orient = torch.randn(1, 3, dtype=torch.float64, requires_grad=True)
    transl = torch.randn(1, 3, dtype=torch.float64, requires_grad=True)

    def f(b, p, o, tr):
        out = layer(betas=b, body_pose=p, global_orient=o, transl=tr)
        return out.vertices[:, ::7], out.joints

    assert torch.autograd.gradcheck(f, (betas, body_pose, orient, transl), eps=1e-6, atol=1e-5)


def test_rodrigues_gradient_finite_at_zero_and_matches_numpy():
    aa = torch.zeros(2, 3, dtype=torch.float64, requires_grad=True)
    R = batch_rodrigues(aa)
    R.sum().backward()
    assert torch.all(torch.isfinite(aa.grad))
    x = np.random.default_rng(3).normal(size=(5, 3))
    np.testing.assert_allclose(batch_rodrigues(torch.as_tensor(x)).numpy(), rodrigues(x), atol=1e-12)
    # gradcheck across the small-angle switch
    tiny = torch.tensor([[1e-5, -2e-5, 3e-5]], dtype=torch.float64, requires_grad=True)
    assert torch.autograd.gradcheck(batch_rodrigues, (tiny,), eps=1e-7, atol=1e-6)


def test_bad_parameters_are_named():
    body = BodyModel(toy_body_arrays())
    with pytest.raises(BadInput, match="betas"):
        body.forward(np.zeros(11), np.zeros(72))
    with pytest.raises(BadInput, match="pose"):
        body.forward(np.zeros(10), np.zeros(69))
    with pytest.raises(BadInput, match="NaN"):
        body.forward(np.full(10, np.nan), np.zeros(72))
    with pytest.raises(BadInput, match="transl"):
        body.forward(np.zeros(10), np.zeros(72), transl=np.zeros(2))


def test_mass_and_volume_of_toy_boxes():
    body = BodyModel(toy_body_arrays())
    # 24 boxes of 6 cm x 6 cm cross-section; volume = 0.0036 * total box length
    v, _ = body.rest(np.zeros(10))
    lengths = []
    for j in range(24):
        c = v[0, 8 * j: 8 * j + 8]
        lengths.append(np.linalg.norm(c[4] - c[0]))
    np.testing.assert_allclose(body.volume(np.zeros(10)), 0.06 * 0.06 * sum(lengths), rtol=1e-9)
    # beta 0 scales all lengths by 1.05: volume by 1.05^3
    np.testing.assert_allclose(body.volume(np.eye(10)[:1]), body.volume(np.zeros(10)) * 1.05 ** 3, rtol=1e-9)
    np.testing.assert_allclose(body.mass(np.zeros(10)), 1000 * body.volume(np.zeros(10)))
