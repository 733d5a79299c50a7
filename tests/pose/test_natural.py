"""The natural pose model and partitions; end-joint distances; whole poses under the sampler's rules."""

import numpy as np
import pytest

from pressurepose.body import BodyModel
from pressurepose.body.capsules import capsule_endpoints, capsules_for, joint_frames
from pressurepose.body.contact import segment_distance
from pressurepose.body.joints import joint_index, mirror_permutation
from pressurepose.errors import BadInput
from pressurepose.pose import SamplerConfig, sample_bodies
from pressurepose.pose.collision import checker
from pressurepose.pose.fidelity import (
    END_JOINTS,
    end_joint_distances,
    pelvis_frame_joints,
)
from pressurepose.pose.limbs import LIMBS
from pressurepose.pose.limits import joint_limits
from pressurepose.pose.natural import (
    ASSET,
    MIN_COUNT,
    FitSettings,
    NaturalPoses,
    fit_natural_poses,
    mirror_poses,
    natural_poses,
    posture_groups,
)
from pressurepose.pose.posefile import PoseFile, PoseSet
from pressurepose.pose.posture import posture_classes
from pressurepose.pose.root import root_axis_angle, world_rotation
from pressurepose.pose.whole import clip_to_limits, partition_postures, within_limits


def test_shipped_model_holds_mixture_parameters_only_each_over_many_poses():
    with np.load(ASSET, allow_pickle=False) as z:
        keys = set(z.files)
    groups = ("supine", "left_lateral", "right_lateral")
    assert keys == {"dims", "groups", "fitted_to"} | {f"{g}.{k}" for g in groups
                                                      for k in ("weights", "means", "covariances", "poses")}
    model = natural_poses()
    assert set(model.mixtures) == set(groups)
    for g, mix in model.mixtures.items():
        assert np.all(mix.weights * model.poses[g] >= MIN_COUNT - 0.5), g  # no component of a few people
        assert len(mix.weights) <= FitSettings().components
    assert "subjects 1-60" in model.fitted_to


def test_mirroring_twice_is_the_identity_and_mirrors_the_body():
    rng = np.random.default_rng(0)
    pose = rng.normal(0, 0.3, (4, 72))
    np.testing.assert_allclose(mirror_poses(mirror_poses(pose)), pose)
    body = BodyModel("neutral")
    j = pelvis_frame_joints(pose, body)
    jm = pelvis_frame_joints(mirror_poses(pose), body)[:, mirror_permutation()]
    np.testing.assert_allclose(jm * [-1, 1, 1], j, atol=0.003)  # the body is symmetric to mm


def test_fit_on_known_groups_and_save_load(tmp_path):
    rng = np.random.default_rng(1)
    pose = np.zeros((240, 72))
    pose[:, 3 * joint_index("left_knee")] = np.r_[rng.normal(0.3, 0.05, 120), rng.normal(1.2, 0.05, 120)]
    pose[:, 3 * joint_index("spine1")] = rng.normal(0.1, 0.02, 240)
    groups = np.array(["supine"] * 120 + ["left_lateral"] * 120)
    model = fit_natural_poses(pose, groups, FitSettings(components=2, restarts=1, min_count=50))
    assert set(model.mixtures) == {"supine", "left_lateral"} and model.poses == {"supine": 120, "left_lateral": 120}
    knee = 3 * joint_index("left_knee") - 3
    assert knee in model.dims and 3 * joint_index("right_knee") - 3 not in model.dims  # held still: not modelled
    draws = np.array([model.draw(np.random.default_rng(k), "left_lateral") for k in range(300)])
    assert abs(draws[:, knee].mean() - 1.2) < 0.02 and np.all(draws[:, 3 * joint_index("right_knee") - 3] == 0)
    model.save(tmp_path / "m.npz")
    back = NaturalPoses.load(tmp_path / "m.npz")
    np.testing.assert_allclose(back.mixtures["supine"].means, model.mixtures["supine"].means, rtol=1e-6)
    with pytest.raises(BadInput, match="no right_lateral"):
        back.draw(np.random.default_rng(0), "right_lateral")


def test_fit_settings_regularise_and_mirror_the_supine_fit():
    """reg_deg is added to every covariance's diagonal (sd degrees); mirror_supine fits supine to the
    poses and their mirror images, so a one-sided supine set gives a two-sided model."""
    rng = np.random.default_rng(2)
    pose = np.zeros((200, 72))
    pose[:, 3 * joint_index("left_shoulder") + 2] = rng.normal(-0.6, 0.05, 200)  # left arm raised, right down
    pose[:, 3 * joint_index("right_shoulder") + 2] = rng.normal(0.05, 0.05, 200)
    groups = np.array(["supine"] * 200)
    base = dict(components=1, restarts=1, min_count=50)
    tight, loose = (fit_natural_poses(pose, groups, FitSettings(reg_deg=r, mirror_supine=False, **base))
                    for r in (0.5, 5.0))
    gap = np.diagonal(loose.mixtures["supine"].covariances[0]) - np.diagonal(tight.mixtures["supine"].covariances[0])
    np.testing.assert_allclose(gap, np.radians(5.0) ** 2 - np.radians(0.5) ** 2, rtol=1e-6)
    left = list(tight.dims).index(3 * joint_index("left_shoulder") - 1)
    right = list(tight.dims).index(3 * joint_index("right_shoulder") - 1)
    mirrored = fit_natural_poses(pose, groups, FitSettings(reg_deg=0.5, mirror_supine=True, **base))
    assert tight.mixtures["supine"].means[0, left] == pytest.approx(-0.6, abs=0.02)
    # mirrored, each side's shoulder averages the raised and the lowered arm (z negated in the mirror)
    assert mirrored.mixtures["supine"].means[0, left] == pytest.approx(-0.325, abs=0.02)
    assert mirrored.mixtures["supine"].means[0, right] == pytest.approx(0.325, abs=0.02)


def test_labels_name_the_group_where_given():
    pose = np.zeros((2, 72))
    pose[:, :3] = root_axis_angle(world_rotation(np.zeros(2), np.zeros(2)))  # both supine by the root
    ps = PoseSet(pose, "x", labels=np.array(["left", "other"]))
    assert posture_groups(ps).tolist() == ["left_lateral", "supine"]


def test_end_joint_distance_of_a_known_change():
    a = np.zeros((5, 72))
    b = a.copy()
    b[:, 3 * joint_index("left_elbow") + 1] = -np.pi / 2  # the left forearm bent forward
    body = BodyModel("neutral")
    d = end_joint_distances(a, b, body)
    ja, jb = pelvis_frame_joints(a[:1], body)[0], pelvis_frame_joints(b[:1], body)[0]
    w = joint_index("left_wrist")
    assert d.by_joint["left_wrist"] == pytest.approx(np.abs(ja[w] - jb[w]).mean())  # W1 of two points: their gap
    assert d.by_joint["left_wrist"] > 0.05
    assert all(d.by_joint[k] == 0 for k in END_JOINTS if k != "left_wrist")
    turned = b.copy()
    turned[:, :3] = [0.3, 1.0, -2.0]  # the root does not count
    assert end_joint_distances(a, turned, body).mean == pytest.approx(d.mean)
    assert end_joint_distances(b, b, body).mean == 0


def test_clipping_to_limits():
    limits = joint_limits()
    rng = np.random.default_rng(3)
    pose = rng.normal(0, 1.0, (50, 69))
    clipped = clip_to_limits(pose, limits)
    assert within_limits(clipped, limits).all() and not within_limits(pose, limits).all()
    inside = clip_to_limits(np.zeros((1, 69)), limits)
    np.testing.assert_array_equal(inside, 0)
    # poses drawn within the limits (each bounded value inside its range, the shoulders split 1 : 2)
    # are unchanged, the values the limits do not bound too
    box = rng.uniform(limits.lower, limits.upper, (50, 24, 3))
    for side, name in enumerate(("left_shoulder", "right_shoulder")):
        total = rng.uniform(limits.shoulder_lower[side], limits.shoulder_upper[side], (50, 3))
        box[:, joint_index(name.replace("shoulder", "collar"))] = limits.shoulder_split * total
        box[:, joint_index(name)] = (1.0 - limits.shoulder_split) * total
    box[:, joint_index("spine1")] = rng.normal(0, 0.3, (50, 3))
    within = box.reshape(50, 72)[:, 3:]
    assert within_limits(within, limits).all()
    np.testing.assert_allclose(clip_to_limits(within, limits), within, atol=1e-15)
    hip_y = 3 * joint_index("left_hip") + 1 - 3
    spine = 3 * joint_index("spine1") - 3
    one = np.zeros((1, 69))
    one[0, hip_y], one[0, spine] = np.radians(70), 0.7
    out = clip_to_limits(one, limits)
    assert out[0, hip_y] == pytest.approx(limits.upper[joint_index("left_hip"), 1]) and out[0, spine] == 0.7
    assert partition_postures(__import__("pressurepose.pose.partitions", fromlist=["x"]).get_partition("general")) == (
        "supine", "left_lateral", "prone", "right_lateral")


@pytest.mark.parametrize("partition, classes", [("natural_supine", {"supine"}),
                                                ("natural_lateral", {"left_lateral", "right_lateral"})])
def test_natural_partitions_lie_in_their_posture_within_the_rules(partition, classes):
    body = BodyModel("female")
    batch = sample_bodies(partition, "f", 24, seed=4, body=body)
    again = sample_bodies(partition, "f", 24, seed=4, body=body)
    np.testing.assert_array_equal(batch.pose, again.pose)
    assert set(posture_classes(batch.pose)) == classes
    assert within_limits(batch.pose[:, 3:], joint_limits()).all()
    # the spine and neck move too (the limb sampler holds them straight)
    spine = [3 * joint_index(n) + k for n in ("spine1", "spine2", "spine3", "neck") for k in range(3)]
    assert np.abs(batch.pose[:, spine]).max() > 0.05
    check = checker()
    cfg = SamplerConfig()
    x0, x1, y0, y1 = cfg.mattress
    for k in range(len(batch)):
        caps = capsules_for(body, batch.betas[k])
        pos, rot = joint_frames(body, batch.betas[k], batch.pose[k:k + 1], batch.transl[k:k + 1])
        assert not check.contacts(capsule_endpoints(caps, pos, rot)[0], caps.radius)
        on_bed = pos[0, [joint_index(f"{s}_{j}") for s in ("left", "right") for j in ("wrist", "ankle", "knee")]]
        assert np.all((on_bed[:, 0] > x0 + cfg.side_margin_m - 1e-6) & (on_bed[:, 0] < x1 - cfg.side_margin_m + 1e-6))
        assert np.all((on_bed[:, 1] > y0) & (on_bed[:, 1] < y1))
        np.testing.assert_allclose(pos[0], batch.joints[k], atol=1e-9)


NO_MARGIN = {"side_margin_m": 0.0}  # limbs anywhere over the mattress


def tiny_pose_file(path):
    """Three supine poses within the limits whose capsules touch nothing: arms 54 deg down from the
    T-pose (over the mattress with ``NO_MARGIN``), one with a bent knee, one with a bent elbow."""
    p = np.zeros((3, 72))
    p[:, :3] = root_axis_angle(world_rotation(np.zeros(3), np.zeros(3)))
    p[:, 3 * joint_index("left_shoulder") + 2] = np.radians(-54)
    p[:, 3 * joint_index("right_shoulder") + 2] = np.radians(54)
    p[1, 3 * joint_index("left_knee")] = np.radians(30)
    p[2, 3 * joint_index("right_elbow") + 1] = np.radians(40)
    np.savez(path, pose=p)
    return p


def test_a_pose_file_gives_its_poses(tmp_path):
    p = tiny_pose_file(tmp_path / "p.npz")
    body = BodyModel("female")
    exact = sample_bodies("general_supine", "f", 12, seed=0, body=body,
                          config=SamplerConfig(poses=PoseFile.of(tmp_path / "p.npz", noise_deg=0.0), **NO_MARGIN))
    gap = np.abs(exact.pose[:, None, 3:] - p[None, :, 3:]).max(-1).min(1)
    np.testing.assert_allclose(gap, 0, atol=1e-12)  # every body took one of the file's poses as it is
    assert len({tuple(np.round(q[3:], 6)) for q in exact.pose}) == 3  # all three drawn
    noisy = sample_bodies("general_supine", "f", 12, seed=0, body=body,
                          config=SamplerConfig(poses=PoseFile.of(tmp_path / "p.npz", noise_deg=3.0), **NO_MARGIN))
    near = np.abs(noisy.pose[:, None, 3:] - p[None, :, 3:]).mean(-1).min(1)
    assert np.all(np.degrees(near) < 4.0) and np.all(np.degrees(near) > 1.0)  # mean |normal| = 0.8 sd
    lateral = SamplerConfig(poses=PoseFile.of(tmp_path / "p.npz"))
    with pytest.raises(BadInput, match="no left_lateral, right_lateral poses"):
        sample_bodies("general_lateral", "f", 1, seed=0, body=body, config=lateral)
    with pytest.raises(BadInput, match="limb rules"):
        sample_bodies("supine_crossed_legs", "f", 1, seed=0, body=body, config=lateral)


@pytest.fixture(scope="module")
def folded_arms(tmp_path_factory):
    """(the file's pose (1, 72) with both forearms folded across the belly, so the hands sink into
    the trunk's capsules; the female body; 6 bodies drawn from that file with no noise)."""
    tmp = tmp_path_factory.mktemp("folded")
    p = tiny_pose_file(tmp / "p.npz")[:1]
    for side, sign in (("left", -1), ("right", 1)):
        p[0, 3 * joint_index(f"{side}_shoulder") + 2] = np.radians(sign * 75)
        p[0, 3 * joint_index(f"{side}_elbow") + 1] = np.radians(sign * 110)
    np.savez(tmp / "c.npz", pose=p)
    body = BodyModel("female")
    batch = sample_bodies("general_supine", "f", 6, seed=1, body=body,
                          config=SamplerConfig(poses=PoseFile.of(tmp / "c.npz", noise_deg=0.0), **NO_MARGIN))
    return p, body, batch


def test_colliding_file_poses_are_nudged_apart(folded_arms):
    p, body, batch = folded_arms
    caps = capsules_for(body, np.zeros(10))
    pos, rot = joint_frames(body, np.zeros(10), p)
    assert checker().contacts(capsule_endpoints(caps, pos, rot)[0], caps.radius)  # the file's pose collides
    for k in range(len(batch)):
        c = capsules_for(body, batch.betas[k])
        pos, rot = joint_frames(body, batch.betas[k], batch.pose[k:k + 1], batch.transl[k:k + 1])
        assert not checker().contacts(capsule_endpoints(c, pos, rot)[0], c.radius)
    moved = np.degrees(np.abs(batch.pose[:, 3:] - p[:, 3:])).max(1)
    assert np.all(moved > 0) and np.all(moved < 45)  # nudged, not redrawn
    legs = [3 * joint_index(n) + k for n in ("left_hip", "right_hip", "left_knee", "right_knee") for k in range(3)]
    np.testing.assert_array_equal(batch.pose[:, legs], p[:, legs].repeat(len(batch), 0))  # only the arms moved


def test_a_nudge_goes_no_further_than_frees_the_pose(folded_arms):
    p, body, batch = folded_arms
    caps = capsules_for(body, np.zeros(10))
    pos, rot = joint_frames(body, np.zeros(10), p)
    touching = checker().contacts(capsule_endpoints(caps, pos, rot)[0], caps.radius)
    for k in range(len(batch)):
        c = capsules_for(body, batch.betas[k])
        pos, rot = joint_frames(body, batch.betas[k], batch.pose[k:k + 1], batch.transl[k:k + 1])
        ends = capsule_endpoints(c, pos, rot)[0]
        gaps = [segment_distance(*ends[a], *ends[b]) - c.radius[a] - c.radius[b] for a, b in touching]
        # apart, and the nearest of the pairs that touched no more than a few millimetres apart: a
        # free nudge is shortened to within 1/64 of the least that frees the pose
        assert 0 <= min(gaps) < 0.005
        halfway = p[0, 3:] + 0.5 * (batch.pose[k, 3:] - p[0, 3:])
        pos, rot = joint_frames(body, batch.betas[k], np.concatenate([batch.pose[k, :3], halfway])[None])
        assert checker().contacts(capsule_endpoints(c, pos, rot)[0], c.radius)  # half the nudge still collides


def test_the_least_move_frees_a_pose_with_less_movement_than_random_nudges(folded_arms):
    """Both ways of separating the folded arms free the pose; the least move shifts the joints
    less than the best of the random nudges, for every body."""
    from pressurepose.pose import body_rng, get_partition
    from pressurepose.pose.whole import FileSource, WholePoseRun

    p, body, _ = folded_arms
    run = WholePoseRun(get_partition("general_supine"), body, SamplerConfig(**NO_MARGIN), False,
                       [body_rng(1, k) for k in range(6)], FileSource(PoseSet(p, "folded"), 0.0))
    base = p[0, 3:]
    arms = [3 * joint_index(n) - 3 + k for n in ("left_shoulder", "right_shoulder", "left_elbow", "right_elbow",
                                                  "left_wrist", "right_wrist") for k in range(3)]
    dofs = np.array(sorted(arms))
    moving = {c for limb in LIMBS if not limb.is_leg for c in limb.capsules}
    for i in range(6):
        joints, ends = run._posed(i, base[None])
        assert run.collision.contacts(ends[0], run.col_radius[i])
        least = run._least_move(i, base, dofs, moving)
        assert least is not None
        least = run._shortest_free(i, base, least)
        # it moves joints, not angles, least, but pays for turning: no arm value turns by more than
        # 30 degrees (a cost of 1 cm a radian instead of 10 turned some by 39-43)
        assert np.degrees(np.abs(least - base)).max() < 30
        nudged = run._nudge(i, base, dofs, joints)
        moved = []
        for q in (least, nudged):
            pos, ends = run._posed(i, q[None])
            assert not run.collision.contacts(ends[0], run.col_radius[i])
            moved.append(np.linalg.norm(pos - joints, axis=-1).sum())
        assert moved[0] < moved[1]
