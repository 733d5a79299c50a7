"""The inference speed-ups change no result: the shipped model's estimates on fixed images equal
those recorded before them, and each faster piece equals the plain computation it replaces."""

import hashlib
from pathlib import Path

import numpy as np
import pytest
import torch

from pressurepose.body.lbs_torch import batch_rodrigues
from pressurepose.body.model import BodyModel
from pressurepose.body.toy import toy_body_arrays
from pressurepose.net.cnn import PressureCNN
from pressurepose.net.infer import DEFAULT_MODEL, estimate
from pressurepose.net.rotations import (
    Q_Y_UP_TO_Z_UP,
    euler_to_root_axis_angle,
    euler_to_world_quat,
    quat_mul,
    quat_to_axis_angle,
)
from tests.net.golden_image import fixed_images

GOLDEN = Path(__file__).parent / "data" / "golden_estimate.npz"

torch.set_num_threads(1)


def _shipped_model_sha256() -> str | None:
    names = ("pressurenet.json", "pressurenet.mod1.safetensors", "pressurenet.mod2.safetensors")
    if not all((DEFAULT_MODEL.parent / n).is_file() for n in names):
        return None
    h = hashlib.sha256()
    for n in names:
        h.update((DEFAULT_MODEL.parent / n).read_bytes())
    return h.hexdigest()


@pytest.fixture(scope="module")
def golden():
    g = np.load(GOLDEN)
    if _shipped_model_sha256() != str(g["model_sha256"]):
        pytest.skip("the shipped model is not the one the golden estimates were recorded with: "
                    "run tools/record_golden_estimate.py on the commit that ships it")
    return g


def _check(est, golden):
    for k in ("betas", "pose", "transl", "joints", "mod1_joints"):
        np.testing.assert_allclose(getattr(est, k), golden[k], atol=1e-5, err_msg=k)
    np.testing.assert_allclose(est.vertices[:, ::50], golden["vertices"], atol=1e-5)
    np.testing.assert_allclose(est.q, golden["q"], atol=1e-2)  # mm of sink, up to ~230
    assert np.mean(est.contact != golden["contact"]) < 0.002


def test_estimate_equals_the_estimates_before_the_speed_ups(golden):
    images = fixed_images()
    _check(estimate(images, ["f", "m"]), golden)  # a batch of two genders
    one = [estimate(images[i], g) for i, g in enumerate("fm")]  # one image per call, model cached
    for _ in range(2):
        again = estimate(images[0], "f")
        np.testing.assert_array_equal(again.joints, one[0].joints)

    class Both:
        pass

    both = Both()
    for k in ("betas", "pose", "transl", "joints", "mod1_joints", "vertices", "q", "contact"):
        setattr(both, k, np.concatenate([getattr(e, k) for e in one]))
    _check(both, golden)


def test_fused_cnn_inference_equals_the_plain_layers():
    torch.manual_seed(0)
    cnn = PressureCNN(5, 64, 40, channels=(24, 24, 48, 48)).eval()
    x = torch.rand(3, 5, 64, 40)
    with torch.no_grad():
        fast = cnn(x)
    with torch.enable_grad():  # autograd on: the plain layers
        plain = cnn(x).detach()
        ref = cnn.fc(cnn.features(x).flatten(1)).detach()
    torch.testing.assert_close(fast, plain, atol=1e-5, rtol=1e-5)
    torch.testing.assert_close(plain, ref, atol=1e-5, rtol=1e-5)
    # a changed weight is seen (the packed weights are rebuilt), in place or by loading
    with torch.no_grad():
        cnn.convs[2].weight.mul_(1.5)
        changed = cnn(x)
        assert not torch.allclose(changed, fast)
        torch.testing.assert_close(changed, cnn.fc(cnn.features(x).flatten(1)), atol=1e-5, rtol=1e-5)
        other = PressureCNN(5, 64, 40, channels=(24, 24, 48, 48)).eval()
        cnn.load_state_dict(other.state_dict())
        torch.testing.assert_close(cnn(x), other(x), atol=1e-5, rtol=1e-5)
        torch.testing.assert_close(cnn(x[:1]), other(x[:1]), atol=1e-5, rtol=1e-5)  # another batch size


def test_root_axis_angle_closed_form_equals_the_quaternion_chain():
    g = torch.Generator().manual_seed(0)
    e = (torch.rand(500, 3, generator=g, dtype=torch.float64) - 0.5) * 2 * torch.pi
    e[:4] = torch.tensor([[0.0, 0, 0], [torch.pi, 0, 0], [-torch.pi / 2, 0, 0.3], [torch.pi, 0.1, -torch.pi]])
    qq = torch.tensor(Q_Y_UP_TO_Z_UP, dtype=torch.float64).expand(500, 4)
    qq_inv = qq * torch.tensor([1.0, -1.0, -1.0, -1.0], dtype=torch.float64)
    chain = quat_to_axis_angle(quat_mul(quat_mul(qq_inv, euler_to_world_quat(e)), qq))
    fast = euler_to_root_axis_angle(e)
    torch.testing.assert_close(batch_rodrigues(fast), batch_rodrigues(chain), atol=1e-12, rtol=0)
    below_pi = chain.norm(dim=-1) < 3.1  # at a half turn r and -r are the same rotation
    assert below_pi.sum() > 400
    torch.testing.assert_close(fast[below_pi], chain[below_pi], atol=1e-12, rtol=0)


def test_body_layer_gradients_are_those_of_its_numbers():
    layer = BodyModel(toy_body_arrays()).torch_layer(dtype=torch.float64)
    g = torch.Generator().manual_seed(1)
    betas = torch.randn(2, 10, generator=g, dtype=torch.float64, requires_grad=True)
    pose = (0.5 * torch.randn(2, 69, generator=g, dtype=torch.float64)).requires_grad_()
    orient = torch.randn(2, 3, generator=g, dtype=torch.float64, requires_grad=True)
    transl = torch.randn(2, 3, generator=g, dtype=torch.float64, requires_grad=True)

    def f(b, p, o, t):
        out = layer(betas=b, body_pose=p, global_orient=o, transl=t)
        return out.vertices[:, ::7], out.joints

    assert torch.autograd.gradcheck(f, (betas, pose, orient, transl))


def test_kinematic_tree_by_pointer_jumping_equals_the_joint_by_joint_chain():
    from types import SimpleNamespace

    from pressurepose.body.lbs_torch import BodyLayer, _tree_jumps

    # a chain of depth 6 (seven links: three jumps), side branches, a joint deeper than a later one
    parents = [-1, 0, 1, 0, 2, 3, 1, 4, 7, 8]
    tables = _tree_jumps(parents)
    assert len(tables) == 3  # 2^3 >= 6 + 1 links
    assert _tree_jumps([-1]) == [] and len(_tree_jumps([-1, 0])) == 1
    tree = SimpleNamespace(_jumps=tables, _jump_index={})
    tree._jump_tensors = lambda device: BodyLayer._jump_tensors(tree, device)
    g = torch.Generator().manual_seed(3)
    n = len(parents)
    rot = batch_rodrigues(torch.randn(2, n, 3, generator=g, dtype=torch.float64))
    J = torch.randn(2, n, 3, generator=g, dtype=torch.float64)
    Rw, tw = BodyLayer._kinematic_tree(tree, rot, J)
    R_ref, t_ref = [rot[:, 0]], [J[:, 0]]
    for j in range(1, n):
        p = parents[j]
        R_ref.append(R_ref[p] @ rot[:, j])
        t_ref.append(t_ref[p] + (R_ref[p] @ (J[:, j] - J[:, p])[..., None])[..., 0])
    torch.testing.assert_close(Rw, torch.stack(R_ref, 1), atol=1e-12, rtol=0)
    torch.testing.assert_close(tw, torch.stack(t_ref, 1), atol=1e-12, rtol=0)


def test_posing_the_skeleton_dispatches_a_few_operations_whatever_the_tree_depth():
    # a GPU training step is bound by the number of operations it dispatches: the skeleton costs
    # a fixed handful per pointer jump, not a product per tree level
    from types import SimpleNamespace

    from benchmarks.bench_net import dispatched_ops
    from pressurepose.body.lbs_torch import BodyLayer, _tree_jumps

    def skeleton_ops(parents):
        tree = SimpleNamespace(_jumps=_tree_jumps(parents), _jump_index={})
        tree._jump_tensors = lambda device: BodyLayer._jump_tensors(tree, device)
        rot = batch_rodrigues(0.3 * torch.randn(4, len(parents), 3))
        J = torch.randn(4, len(parents), 3)
        BodyLayer._kinematic_tree(tree, rot, J)  # the index tensors made once
        return dispatched_ops(lambda: BodyLayer._kinematic_tree(tree, rot, J)), len(tree._jumps)

    ops9, jumps9 = skeleton_ops([-1] + list(range(8)))  # a chain of depth 8 (SMPL's): 9 links
    ops16, jumps16 = skeleton_ops([-1] + list(range(15)))  # depth 15: 16 links
    assert jumps9 == jumps16 == 4
    assert ops9 == ops16 <= 20 * jumps9 + 10


def test_body_layer_first_called_in_inference_mode_still_trains():
    # its cached constants (cross-product map, jump tables) must not be inference tensors
    layer = BodyModel(toy_body_arrays()).torch_layer(dtype=torch.float64)
    with torch.inference_mode():
        layer(body_pose=torch.zeros(1, 69, dtype=torch.float64))
    pose = (0.3 * torch.randn(2, 69, dtype=torch.float64)).requires_grad_()
    layer(body_pose=pose).joints.sum().backward()
    assert torch.isfinite(pose.grad).all() and pose.grad.abs().sum() > 0
