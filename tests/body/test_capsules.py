"""Capsules: direct fit covers the mesh, regressors reproduce it, posed capsules follow the mesh."""

import numpy as np
import pytest
import torch

from pressurepose.body import BodyModel
from pressurepose.body.capsules import (
    CAPSULE_JOINTS,
    CAPSULE_NAMES,
    NOMINAL_AXES,
    CapsuleRegressors,
    capsule_regions,
    capsules_for,
    fit_capsules,
    fit_regressors,
    load_regressors,
    point_capsule_distance,
    posed_capsules,
    regressed_capsules,
    regressor_path,
    save_regressors,
)
from pressurepose.body.joints import JOINT_NAMES
from pressurepose.body.lbs_numpy import Y_UP_TO_Z_UP
from pressurepose.body.model import asset_path
from pressurepose.body.toy import TOY_REST_JOINTS, toy_body_arrays
from pressurepose.errors import BadInput

GENDERS = ("female", "male", "neutral")


def shipped(gender):
    """The shipped body model, or skip while it has not been baked yet."""
    if not asset_path(f"{gender}.npz").is_file():
        pytest.skip(f"shipped body model {gender}.npz not baked yet (tools/bake_body_model.py)")
    return BodyModel(gender)


@pytest.fixture(scope="module")
def toy():
    return BodyModel(toy_body_arrays())


def surface_distance(verts, ends, radius):
    """(V,) distance of each vertex outside the nearest capsule (0 inside)."""
    return np.maximum(point_capsule_distance(verts, ends) - radius, 0.0).min(1)


def rest_ends(body, caps, betas):
    ends, _ = posed_capsules(body, caps, betas, np.zeros((1, 72)))
    return ends[0]


def test_layout_is_smplify():
    assert len(CAPSULE_NAMES) == 20 and len(CAPSULE_JOINTS) == 20
    # every capsule named after the side and part of its joint's limb
    for name, j in zip(CAPSULE_NAMES, CAPSULE_JOINTS):
        side = name.split("_")[0]
        if side in ("left", "right"):
            assert JOINT_NAMES[j].startswith(side)
    assert CAPSULE_JOINTS[CAPSULE_NAMES.index("head")] == JOINT_NAMES.index("head")
    assert CAPSULE_JOINTS[CAPSULE_NAMES.index("left_hand")] == JOINT_NAMES.index("left_wrist")


def test_toy_fit_answers_known_on_paper(toy):
    """A toy limb is a box of half-width 3 cm from its joint to its child joint, with its 8 corners as
    vertices (equal areas): centroid = box centre, mean squared distance from the axis = 2 (3 cm)^2,
    axial variance = (l / 2)^2, so r = 3 sqrt(2) cm and extent sqrt(12 var) = sqrt(3) l."""
    caps = fit_capsules(toy, np.zeros(10))
    for name, j, child in (("left_upper_arm", 16, 18), ("right_calf", 5, 8), ("left_forearm", 18, 20)):
        k = CAPSULE_NAMES.index(name)
        bone = TOY_REST_JOINTS[child] - TOY_REST_JOINTS[j]
        ell = np.linalg.norm(bone)
        assert caps.radius[k] == pytest.approx(0.03 * np.sqrt(2), abs=1e-9)
        assert caps.length[k] == pytest.approx(np.sqrt(3) * ell - caps.radius[k], abs=1e-9)
        np.testing.assert_allclose(caps.center[k], bone / 2, atol=1e-9)
        np.testing.assert_allclose(caps.axis[k], bone / ell, atol=1e-9)
    # the frame is a rotation and the axis is its z column
    R = caps.rest_transform[:, :3, :3]
    np.testing.assert_allclose(R @ np.swapaxes(R, 1, 2), np.broadcast_to(np.eye(3), R.shape), atol=1e-12)
    np.testing.assert_allclose(np.linalg.det(R), 1.0, atol=1e-12)
    assert np.all(caps.rest_transform[:, 3] == [0, 0, 0, 1])


def test_posed_capsules_move_rigidly_with_their_region(toy):
    """Toy vertices are skinned rigidly (weight 1, no pose blend shapes): every vertex of a capsule's
    own joint (toes and fingers bend on their own joints) keeps its distance from the capsule's axis
    whatever the pose, root turn and translation."""
    rng = np.random.default_rng(1)
    betas = rng.uniform(-2, 2, 10)
    caps = fit_capsules(toy, betas)
    regions = capsule_regions(toy)
    own = np.isin(np.argmax(toy.arrays.weights, 1), CAPSULE_JOINTS)
    pose = rng.normal(0, 0.6, (4, 72))
    transl = rng.normal(0, 1, (4, 3))
    verts, _ = toy.forward(np.tile(betas, (4, 1)), pose, transl)
    ends, radius = posed_capsules(toy, caps, betas, pose, transl)
    v0, _ = toy.rest(betas[None])
    d0 = point_capsule_distance(v0[0], rest_ends(toy, caps, betas))[np.arange(len(regions)), regions]
    for b in range(4):
        d = point_capsule_distance(verts[b], ends[b])[np.arange(len(regions)), regions]
        np.testing.assert_allclose(d[own], d0[own], atol=1e-9)
        assert not np.allclose(d, d0, atol=1e-3)  # the toes and fingers did move
    np.testing.assert_array_equal(radius, caps.radius)


def test_rest_pose_places_capsule_centres_at_joint_plus_offset(toy):
    betas = np.linspace(-1, 1, 10)
    caps = fit_capsules(toy, betas)
    _, joints = toy.rest(betas[None])
    ends = rest_ends(toy, caps, betas)
    np.testing.assert_allclose(ends.mean(1), joints[0, list(CAPSULE_JOINTS)] + caps.center, atol=1e-12)
    np.testing.assert_allclose(np.linalg.norm(ends[:, 1] - ends[:, 0], axis=1), caps.length, atol=1e-12)
    np.testing.assert_allclose(ends[:, 1] - ends[:, 0], caps.length[:, None] * caps.axis, atol=1e-12)


def test_torch_layer_rotations_give_the_same_capsules(toy):
    """Documented recipe for BodyLayer outputs: W_j = rotations[:, j] @ Q^T."""
    from pressurepose.body.capsules import capsule_endpoints

    rng = np.random.default_rng(2)
    betas = rng.normal(0, 1, (3, 10))
    pose = rng.normal(0, 0.5, (3, 72))
    transl = rng.normal(0, 1, (3, 3))
    caps = fit_capsules(toy, betas[0])
    layer = toy.torch_layer(dtype=torch.float64)
    t = {k: torch.as_tensor(v) for k, v in dict(b=betas, p=pose, t=transl).items()}
    out = layer(betas=t["b"], global_orient=t["p"][:, :3], body_pose=t["p"][:, 3:], transl=t["t"])
    W = out.rotations.numpy() @ Y_UP_TO_Z_UP.T
    ends_torch = capsule_endpoints(caps, out.joints.numpy(), W)
    ends_np, _ = posed_capsules(toy, caps, betas, pose, transl)
    np.testing.assert_allclose(ends_torch, ends_np, atol=1e-10)


def test_toy_regressors_reproduce_direct_fit_and_round_trip(toy, tmp_path):
    """The toy's first two betas scale and widen it; the others jiggle the corners of its 8-vertex
    boxes at random, which moves such tiny regions' moments non-linearly, so only the first two vary."""
    reg, _ = fit_regressors(toy, num_samples=30, seed=3, num_betas=2)
    assert reg.betas2lens.shape == (11, 20) and reg.betas2centers.shape == (11, 60)
    np.testing.assert_array_equal(reg.betas2lens[2:10], 0.0)
    rng = np.random.default_rng(4)
    for betas in np.pad(rng.uniform(-3, 3, (5, 2)), ((0, 0), (0, 8))):
        direct = fit_capsules(toy, betas)
        fast = regressed_capsules(reg, betas)
        assert np.abs(fast.length - direct.length).max() < 0.005
        assert np.abs(fast.radius - direct.radius).max() < 0.005
        assert np.abs(fast.center - direct.center).max() < 0.005
        # the product is exactly SMPLify's form
        np.testing.assert_allclose(fast.length, np.maximum(np.append(betas, 1) @ reg.betas2lens, 0))
    path = tmp_path / "caps.npz"
    save_regressors(reg, path)
    back = load_regressors(path)
    assert back.model_identity == toy.identity
    b = rng.normal(0, 1, 10)
    np.testing.assert_array_equal(capsules_for(toy, b, path).rest_transform,
                                  regressed_capsules(reg, b).rest_transform)
    assert back.meta["fit_num_samples"] == 30


def test_smplify_style_file_without_placement(toy, tmp_path):
    """A file with only betas2lens / betas2rads over 300 betas (SMPLify's) works: betas are zero-padded,
    capsules lie along their nominal axes, starting at the joint (pelvis and spines centred)."""
    rng = np.random.default_rng(5)
    lens, rads = rng.uniform(0, 0.01, (301, 20)), rng.uniform(0, 0.001, (301, 20))
    lens[300], rads[300] = 0.2, 0.05
    path = tmp_path / "regressors_locked_normalized_female.npz"
    np.savez(path, betas2lens=lens, betas2rads=rads, v2lens=np.zeros((3, 20)))
    betas = rng.normal(0, 1, 10)
    caps = capsules_for(toy, betas, path)
    pad = np.concatenate([betas, np.zeros(290), [1.0]])
    np.testing.assert_allclose(caps.length, pad @ lens)
    np.testing.assert_allclose(caps.radius, pad @ rads)
    np.testing.assert_allclose(caps.axis, NOMINAL_AXES, atol=1e-12)
    np.testing.assert_allclose(caps.center[0], 0.0, atol=1e-12)
    np.testing.assert_allclose(caps.center[1], 0.5 * caps.length[1] * NOMINAL_AXES[1])


def test_unshipped_body_falls_back_to_direct_fit(toy):
    betas = np.arange(10) / 10.0
    np.testing.assert_array_equal(capsules_for(toy, betas).rest_transform,
                                  fit_capsules(toy, betas).rest_transform)


def test_bad_inputs(toy, tmp_path):
    for betas in (np.zeros(11), np.zeros((2, 10)), np.zeros(0), np.r_[np.nan, np.zeros(9)]):
        with pytest.raises(BadInput, match="betas"):
            capsules_for(toy, betas)
        with pytest.raises(BadInput, match="betas"):
            fit_capsules(toy, betas)
    caps = fit_capsules(toy, np.zeros(10))
    with pytest.raises(BadInput, match="pose"):
        posed_capsules(toy, caps, np.zeros(10), np.zeros((2, 69)))
    with pytest.raises(BadInput, match="pose"):
        posed_capsules(toy, caps, np.zeros(10), np.full((1, 72), np.nan))
    junk = tmp_path / "junk.npz"
    junk.write_bytes(b"not a zip file at all")
    with pytest.raises(BadInput, match="junk.npz"):
        load_regressors(junk)
    np.savez(tmp_path / "nolens.npz", betas2rads=np.zeros((11, 20)))
    with pytest.raises(BadInput, match="betas2lens"):
        load_regressors(tmp_path / "nolens.npz")
    np.savez(tmp_path / "shape.npz", betas2rads=np.zeros((11, 20)), betas2lens=np.zeros((11, 19)))
    with pytest.raises(BadInput, match="R \\+ 1, 20"):
        load_regressors(tmp_path / "shape.npz")
    reg = CapsuleRegressors(np.zeros((6, 20)), np.zeros((6, 20)))
    with pytest.raises(BadInput, match="at most 5"):
        capsules_for(toy, np.zeros(10), reg)


# ------------------------------------------------------------------ shipped human models


@pytest.mark.parametrize("gender", GENDERS)
def test_capsules_cover_the_human_mesh(gender):
    body = shipped(gender)
    rng = np.random.default_rng(6)
    for betas in np.vstack([np.zeros(10), rng.uniform(-3, 3, (2, 10))]):
        verts, _ = body.rest(betas[None])
        for caps in (fit_capsules(body, betas), capsules_for(body, betas)):
            out = surface_distance(verts[0], rest_ends(body, caps, betas), caps.radius)
            assert np.mean(out <= 0.03) >= 0.9, (gender, betas)


@pytest.mark.parametrize("gender", GENDERS)
def test_shipped_regressors_reproduce_direct_fit(gender):
    body = shipped(gender)
    if not regressor_path(gender).is_file():
        pytest.skip(f"capsules_{gender}.npz not fitted yet (tools/fit_capsules.py)")
    reg = load_regressors(regressor_path(gender))
    assert reg.model_identity == body.identity, "regressors were fitted to another body model; refit"
    rng = np.random.default_rng(7)
    for betas in rng.uniform(-3, 3, (3, 10)):
        direct, fast = fit_capsules(body, betas), capsules_for(body, betas)
        assert np.abs(fast.length - direct.length).max() < 0.006
        assert np.abs(fast.radius - direct.radius).max() < 0.005
        # centroids of fixed area weights are linear in betas: reproduced exactly
        assert np.abs(fast.center - direct.center).max() < 1e-6
        assert np.abs(fast.axis - direct.axis).max() < 0.03


@pytest.mark.parametrize("gender", GENDERS)
def test_mean_shape_capsules_are_left_right_symmetric(gender):
    body = shipped(gender)
    caps = capsules_for(body, np.zeros(10))
    ends = rest_ends(body, caps, np.zeros(10))
    mirror = np.array([-1.0, 1.0, 1.0])
    for k, name in enumerate(CAPSULE_NAMES):
        if name.startswith("left_"):
            m = CAPSULE_NAMES.index("right_" + name[5:])
            assert abs(caps.radius[k] - caps.radius[m]) < 0.005, name
            assert abs(caps.length[k] - caps.length[m]) < 0.01, name
            # same segment mirrored (either end order)
            mirrored = ends[m] * mirror
            err = min(np.abs(ends[k] - mirrored).max(), np.abs(ends[k] - mirrored[::-1]).max())
            assert err < 0.015, name
        elif not name.startswith("right_"):
            assert abs(ends[k].mean(0)[0]) < 0.01, name  # central capsules on the midline


def test_posed_human_capsules_track_the_mesh():
    """Vertices skinned almost entirely to one capsule's joint keep their distance to its axis."""
    body = shipped("female")
    rng = np.random.default_rng(8)
    betas = rng.uniform(-2, 2, 10)
    caps = capsules_for(body, betas)
    regions = capsule_regions(body)
    rigid = (body.arrays.weights.max(1) > 0.95) & np.isin(np.argmax(body.arrays.weights, 1), CAPSULE_JOINTS)
    v0, _ = body.rest(betas[None])
    idx = np.flatnonzero(rigid)
    d0 = point_capsule_distance(v0[0, idx], rest_ends(body, caps, betas))[np.arange(len(idx)), regions[idx]]
    pose = rng.normal(0, 0.3, (2, 72))
    verts, _ = body.forward(np.tile(betas, (2, 1)), pose, np.array([[0.3, 1.0, 0.2], [0, 0, 0]]))
    ends, _ = posed_capsules(body, caps, betas, pose, np.array([[0.3, 1.0, 0.2], [0, 0, 0]]))
    for b in range(2):
        d = point_capsule_distance(verts[b, idx], ends[b])[np.arange(len(idx)), regions[idx]]
        assert np.percentile(np.abs(d - d0), 95) < 0.01
