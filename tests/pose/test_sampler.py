"""The sampler's output checked from the outside: every property is recomputed from the returned
betas, pose and transl with the body model and capsules, not read back from the sampler."""

import numpy as np
import pytest
from scipy import stats

from pressurepose.body.capsules import (
    CAPSULE_NAMES,
    capsules_for,
    joint_frames,
    posed_capsules,
)
from pressurepose.body.joints import PARENTS
from pressurepose.body.joints import joint_index as J
from pressurepose.body.lbs_numpy import Y_UP_TO_Z_UP as Q
from pressurepose.body.lbs_numpy import rodrigues
from pressurepose.pose import SamplerConfig, joint_limits
from pressurepose.pose.config import DEFAULT_MATTRESS

# (partition, limbs_on_bed, count, seed): the paper's partitions, kept small for speed
CASES = [
    ("general", False, 120, 11),
    ("general", True, 50, 12),
    ("general_supine", False, 300, 13),
    ("hands_behind_head", True, 30, 14),
    ("prone_hands_up", True, 30, 15),
    ("supine_crossed_legs", False, 12, 16),
    ("supine_straight_limbs", True, 40, 17),
]
IDS = [f"{p}{'-on-bed' if b else ''}" for p, b, _, _ in CASES]
LIMB_JOINTS = ("left_knee", "left_ankle", "left_foot", "right_knee", "right_ankle", "right_foot",
               "left_elbow", "left_wrist", "left_hand", "right_elbow", "right_wrist", "right_hand")
SUPPORT = ("pelvis", "spine", "spine1", "spine2", "left_shoulder", "right_shoulder", "left_thigh", "right_thigh")
LIMB_CAPSULES = ("left_thigh", "left_calf", "left_foot", "right_thigh", "right_calf", "right_foot",
                 "left_shoulder", "left_upper_arm", "left_forearm", "left_hand", "right_shoulder",
                 "right_upper_arm", "right_forearm", "right_hand")


@pytest.fixture(params=CASES, ids=IDS)
def case(request, batch_of):
    partition, on_bed, count, seed = request.param
    return request.param, batch_of(partition, on_bed, count, seed)


def axes(batch):
    """World head, face and left directions (N, 3) from the root pose (W = Q R(r) Q^T)."""
    W = Q @ rodrigues(batch.pose[:, :3]) @ Q.T
    return W[:, :, 2], -W[:, :, 1], W[:, :, 0]


def capsules_of(body, batch, pose=None):
    ends, radii = [], []
    for i in range(len(batch)):
        caps = capsules_for(body, batch.betas[i])
        p = batch.pose[i:i + 1] if pose is None else pose[i:i + 1]
        e, r = posed_capsules(body, caps, batch.betas[i], p, batch.transl[i:i + 1])
        ends.append(e[0])
        radii.append(r)
    return np.array(ends), np.array(radii)


def test_joints_are_the_body_models_and_angles_within_limits(case, female):
    (partition, *_), batch = case
    _, joints = female.forward(batch.betas[:40], batch.pose[:40], batch.transl[:40])
    np.testing.assert_allclose(batch.joints[:40], joints, atol=1e-9)
    assert np.all(np.abs(batch.betas) <= 3.0)
    lim = joint_limits(partition)
    assert lim.within(batch.pose).all()
    if partition == "supine_straight_limbs":
        p = batch.pose.reshape(-1, 24, 3)
        assert np.all(p[:, [J("left_knee"), J("right_knee"), J("left_elbow"), J("right_elbow")]] == 0)


def test_no_self_collision_by_independent_distances(case, female, segment_distance_by_cases):
    (partition, *_), batch = case
    ends, radius = capsules_of(female, batch)
    checked = ["left_calf", "right_calf", "left_foot", "right_foot", "left_forearm", "right_forearm"]
    if partition != "hands_behind_head":  # there the hands rest against the head
        checked += ["left_hand", "right_hand"]
    joint_of = [0, 1, 2, 3, 4, 5, 6, 7, 8, 9, 12, 13, 14, 15, 16, 17, 18, 19, 20, 21]
    worst = np.inf
    for name in checked:
        a = CAPSULE_NAMES.index(name)
        for b in range(20):
            ja, jb = joint_of[a], joint_of[b]
            if b == a or PARENTS[ja] == jb or PARENTS[jb] == ja:
                continue
            d = segment_distance_by_cases(ends[:, a, 0], ends[:, a, 1], ends[:, b, 0], ends[:, b, 1])
            worst = min(worst, np.min(d - radius[:, a] - radius[:, b]))
    assert worst >= -1e-9


def test_root_transform_of_the_partition(case):
    (partition, *_), batch = case
    head, face, left = axes(batch)
    assert np.all(np.abs(head[:, 2]) < 1e-9)  # pitch 0: the long axis lies flat
    yaw = np.arctan2(head[:, 0], -head[:, 1])
    assert np.all(np.abs(yaw) <= np.pi / 6 + 1e-9)
    roll = np.arctan2(-left[:, 2], face[:, 2])  # 0 supine, +pi/2 left side down
    if partition == "general":
        assert stats.kstest((roll + np.pi) / (2 * np.pi), "uniform").pvalue > 1e-3
    elif partition == "prone_hands_up":
        assert np.all(face[:, 2] < -1 + 1e-9)
    else:
        assert np.all(face[:, 2] > 1 - 1e-9)
        assert np.all(batch.joints[:, J("head"), 1] < batch.joints[:, J("pelvis"), 1])
    centre = np.array([(DEFAULT_MATTRESS[0] + DEFAULT_MATTRESS[1]) / 2, (DEFAULT_MATTRESS[2] + DEFAULT_MATTRESS[3]) / 2])
    assert np.all(np.abs(batch.joints[:, 0, :2] - centre) <= 0.2 + 1e-9)


def limbs_below_support(body, batch):
    """(N,) how far the lowest limb capsule surface lies below the surface the body lies on (support
    capsules with the limbs at rest, root pose only), m; and the lowest capsule surface (N, 20)."""
    ends, radius = capsules_of(body, batch)
    lowest = ends[..., 2].min(-1) - radius  # (N, 20)
    root_only = np.zeros_like(batch.pose)
    root_only[:, :3] = batch.pose[:, :3]
    rest_ends, _ = capsules_of(body, batch, root_only)
    idx = [CAPSULE_NAMES.index(n) for n in SUPPORT]
    support = (rest_ends[:, idx][..., 2].min(-1) - radius[:, idx]).min(1)
    limbs = lowest[:, [CAPSULE_NAMES.index(n) for n in LIMB_CAPSULES]].min(1)
    return support - limbs, lowest


def test_start_height(case, female):
    _, batch = case
    _, lowest = limbs_below_support(female, batch)
    np.testing.assert_allclose(lowest.min(1), SamplerConfig().clearance, atol=1e-9)


def test_limbs_may_start_below_the_back(batch_of, female):
    """As in the paper and the public code, no test keeps a limb's capsules above the surface the body
    lies on: supine, a bent knee puts the lower leg up to ~0.15 m below the back."""
    below, _ = limbs_below_support(female, batch_of("general_supine", False, 300, 13))
    assert np.mean(below > 0.06) > 0.1


def test_distal_joints_near_the_height_of_their_proximal_joints(case):
    (partition, *_), batch = case
    z = batch.joints[..., 2]
    legs = z[:, [J("left_ankle"), J("right_ankle")]] - z[:, [J("left_hip"), J("right_hip")]]
    arms = z[:, [J("left_wrist"), J("right_wrist")]] - z[:, [J("left_shoulder"), J("right_shoulder")]]
    assert np.all(np.abs(legs) <= 0.2 + 1e-9)
    lo, hi = (-0.4, 0.0) if partition == "hands_behind_head" else (-0.2, 0.2)
    assert np.all((arms >= lo - 1e-9) & (arms <= hi + 1e-9))


def recomputed_bins(joints, head, rest):
    """Bins (N, 4) of the left/right ankle and wrist: the distal joint's distance footward of the
    proximal one along the head axis (N, 3), in limb lengths of the shaped rest joints (N, 24, 3)."""
    out = []
    for chain, n_bins, offset in ((("hip", "knee", "ankle"), 4, 0), (("shoulder", "elbow", "wrist"), 8, 4)):
        for s in ("left", "right"):
            p, m, d = (J(f"{s}_{n}") for n in chain)
            length = np.linalg.norm(rest[:, m] - rest[:, p], axis=-1) + np.linalg.norm(rest[:, d] - rest[:, m], axis=-1)
            along = -np.einsum("ni,ni->n", joints[:, d] - joints[:, p], head) / length
            out.append(np.clip(np.floor(4 * along) + offset, 0, n_bins - 1))
    return np.stack(out, axis=1).astype(int)


BED_HEADWARD = np.array([0.0, -1.0, 0.0])  # bins count along the bed (row 0 at the head end)


def bins_of(batch, female):
    head = np.broadcast_to(BED_HEADWARD, (len(batch), 3))
    return recomputed_bins(batch.joints, head, female.rest(batch.betas)[1])


def test_partition_definitions(case, female):
    (partition, on_bed, *_), batch = case
    j = batch.joints
    head, face, left = axes(batch)
    bins = bins_of(batch, female)
    np.testing.assert_array_equal(bins, batch.bins)
    if partition in ("hands_behind_head", "prone_hands_up"):
        assert np.all(bins[:, 2:] <= 3)  # wrists headward of the shoulders
    if partition == "hands_behind_head":
        for s, sign in (("left", 1), ("right", -1)):
            medial = sign * np.einsum("ni,ni->n", j[:, J(f"{s}_wrist")] - j[:, J(f"{s}_shoulder")], left)
            assert np.all(medial < 0)
            assert np.all(np.linalg.norm(j[:, J(f"{s}_wrist")] - j[:, J("head")], axis=-1) <= 0.25 + 1e-9)
    if partition == "supine_crossed_legs":
        across = np.einsum("ni,ni->n", j[:, J("left_ankle")] - j[:, J("right_ankle")], left)
        assert np.all(across < 0)  # the left ankle toward the body's right of the right ankle
        assert np.all(bins[:, :2] >= 1)
    if partition == "supine_straight_limbs":
        for a, b, c in (("hip", "knee", "ankle"), ("shoulder", "elbow", "wrist")):
            for s in ("left", "right"):
                u = j[:, J(f"{s}_{b}")] - j[:, J(f"{s}_{a}")]
                v = j[:, J(f"{s}_{c}")] - j[:, J(f"{s}_{b}")]
                cos = np.einsum("ni,ni->n", u, v) / np.linalg.norm(u, axis=1) / np.linalg.norm(v, axis=1)
                assert np.all(cos > np.cos(np.deg2rad(20)))  # the rest body's own bend only
    idx = [J(n) for n in LIMB_JOINTS]
    x0, x1, y0, y1 = DEFAULT_MATTRESS
    inside = ((j[:, idx, 0] > x0) & (j[:, idx, 0] < x1) & (j[:, idx, 1] > y0) & (j[:, idx, 1] < y1)).all(1)
    if on_bed:
        assert inside.all()
    elif partition == "general":
        assert not inside.all()  # without the rule some limbs do start off the mattress


def test_distal_joints_spread_evenly_over_the_bins(batch_of, female):
    batch = batch_of("general_supine", False, 300, 13)
    bins = bins_of(batch, female)
    legs = np.bincount(bins[:, :2].ravel(), minlength=4)
    arms = np.bincount(bins[:, 2:].ravel(), minlength=8)
    assert stats.chisquare(legs).pvalue > 1e-3, legs
    assert stats.chisquare(arms).pvalue > 1e-3, arms
    # the test has power: legs drawn uniformly in joint space (height band only) are far from even
    rng = np.random.default_rng(0)
    lim = joint_limits()
    n = 600
    pose = np.zeros((n, 24, 3))
    pose[:, 0] = batch.pose[0, :3]
    for s in ("left", "right"):
        pose[:, J(f"{s}_hip")] = rng.uniform(lim.lower[J(f"{s}_hip")], lim.upper[J(f"{s}_hip")], (n, 3))
        pose[:, J(f"{s}_knee"), 0] = rng.uniform(lim.lower[J(f"{s}_knee"), 0], lim.upper[J(f"{s}_knee"), 0], n)
    betas = np.zeros((n, 10))
    joints, _ = joint_frames(female, betas, pose.reshape(n, 72))
    naive = recomputed_bins(joints, np.broadcast_to(BED_HEADWARD, (n, 3)), female.rest(betas)[1])[:, :2]
    z = joints[..., 2]
    band = np.abs(z[:, [J("left_ankle"), J("right_ankle")]] - z[:, [J("left_hip"), J("right_hip")]]) <= 0.2
    assert stats.chisquare(np.bincount(naive[band], minlength=4)).pvalue < 1e-6


def test_rejection_counts_are_reported(case):
    (partition, on_bed, *_), batch = case
    rej, att = batch.rejections, batch.attempts
    assert att["full_poses"] >= len(batch)
    assert att["limb_candidates"] >= 4 * att["full_poses"]
    assert rej["height"] > 0 and rej["bin"] > 0
    # every judged limb candidate failed or was accepted; accepted: 4 per whole pose, 2 per failed
    # crossing, and up to 3 for a body that gave up and was redrawn
    failed = sum(v for k, v in rej.items() if k not in ("legs_not_crossed", "self_collision"))
    spare = att["limb_candidates"] - 4 * att["full_poses"] - 2 * rej["legs_not_crossed"] - failed
    assert 0 <= spare <= 3 * att["bodies_redrawn"]
    assert (rej["off_mattress"] > 0) == on_bed
    assert (rej["not_behind_head"] > 0) == (partition == "hands_behind_head")
    assert (rej["legs_not_crossed"] > 0) == (partition == "supine_crossed_legs")


def test_bed_referenced_heights_keep_the_distal_joints_near_the_bed(female):
    """height_reference='bed': every ankle and wrist starts within bed_height_band of the surface the
    body lies on (recomputed here: the support capsules with the limbs at rest), and the upper limbs
    of bodies on their side start lower than with the proximal rule."""
    from pressurepose.pose import sample_bodies
    from pressurepose.pose.posture import posture_classes

    config = SamplerConfig(height_reference="bed")
    lo, hi = config.bed_height_band
    bed = sample_bodies("general", "f", 60, 21, body=female, config=config)
    near = sample_bodies("general", "f", 60, 21, body=female)
    root_only = np.zeros_like(bed.pose)
    root_only[:, :3] = bed.pose[:, :3]
    rest_ends, radius = capsules_of(female, bed, root_only)
    idx = [CAPSULE_NAMES.index(n) for n in SUPPORT]
    support = (rest_ends[:, idx][..., 2].min(-1) - radius[:, idx]).min(1)
    distal = bed.joints[:, [J("left_ankle"), J("right_ankle"), J("left_wrist"), J("right_wrist")], 2]
    above = distal - support[:, None]
    assert np.all((above >= lo - 1e-9) & (above <= hi + 1e-9))
    highest = {}
    for name, batch in (("bed", bed), ("proximal", near)):
        lateral = np.char.endswith(posture_classes(batch.pose).astype(str), "lateral")
        z = batch.joints[lateral][:, [J("left_ankle"), J("right_ankle"), J("left_wrist"), J("right_wrist")], 2]
        highest[name] = np.mean(z.max(1) - batch.joints[lateral, J("pelvis"), 2])
    assert highest["bed"] < highest["proximal"] - 0.05


def test_general_lateral_draws_bodies_on_either_side(female):
    """general_lateral (not a paper partition): roll 60-120 degrees, left and right both drawn."""
    from pressurepose.pose.partitions import get_partition
    from pressurepose.pose.sampler import sample_bodies

    part = get_partition("general_lateral")
    assert part.either_side and not get_partition("general").either_side
    b = sample_bodies("general_lateral", "f", 40, 1, body=female)
    r = np.degrees(np.abs(b.roll))
    assert np.all((r >= 60) & (r <= 120))
    assert 8 <= np.sum(b.roll > 0) <= 32  # both sides, about even odds


def test_hands_behind_head_pose_with_a_hand_in_the_head_is_rejected(female, segment_distance_by_cases):
    """A hands-behind-head body's accepted pose with its left arm swapped for candidates that pass
    every limb test (the paper's exempts the hands there) but put the hand capsule more than 2 mm
    inside the head capsule (by the body model's own kinematics and an independent distance): the
    whole-pose check rejects each as a self-collision, and those the paper's test passes start the
    body afresh."""
    from pressurepose.pose.limbs import LIMBS
    from pressurepose.pose.partitions import get_partition
    from pressurepose.pose.rejection import Run
    from pressurepose.pose.samples import COUNTERS

    def accepted_run():
        run = Run(get_partition("hands_behind_head"), female, SamplerConfig(), True, [np.random.default_rng(7)])
        run.run()
        return run

    run = accepted_run()
    li = next(i for i, limb in enumerate(LIMBS) if limb.name == "left_arm")
    lo, hi = run.boxes[li]
    cand = np.random.default_rng(8).uniform(lo, hi, (1, 20000, lo.size))
    passing = cand[0, run._limb_causes(li, np.array([0]), cand)[0] == 0]
    drawn = run.angles[li][0].copy()
    pose = []
    for angles in passing:
        run.angles[li][0] = angles
        pose.append(run._assemble_pose(np.array([0]))[0])
    run.angles[li][0] = drawn
    caps = capsules_for(female, run.betas[0])
    ends, _ = posed_capsules(female, caps, run.betas[0], pose)
    hand, head = CAPSULE_NAMES.index("left_hand"), CAPSULE_NAMES.index("head")
    d = segment_distance_by_cases(ends[:, hand, 0], ends[:, hand, 1], ends[:, head, 0], ends[:, head, 1])
    inside = np.flatnonzero(d < caps.radius[hand] + caps.radius[head] - 0.002)
    assert len(inside) >= 2
    assert run._check(np.array([0])).all()  # the pose as drawn passes
    fresh = 0
    for k in inside:
        run = accepted_run()
        betas = run.betas[0].copy()
        paper_ok = not run.collision.collides(ends[k], run.col_radius[0])  # the paper's test alone
        run.angles[li][0] = passing[k]
        assert not run._check(np.array([0])).any()
        assert run.counts[0, COUNTERS.index("self_collision")] >= 1
        if paper_ok:  # then the start test rejected it: a new body, as a new attempt would draw
            assert not np.array_equal(run.betas[0], betas)
            fresh += 1
    assert fresh >= 1


def test_hands_behind_head_draws_pass_the_settles_start_test(batch_of, female):
    """30 accepted hands-behind-head bodies placed in the settle's ragdoll: MuJoCo finds no pair of
    its capsules more than the settle's tolerance inside each other, so none is rejected as
    self_collision (29 of 40 poses the paper's test accepts would be)."""
    import mujoco

    from pressurepose.sim.bed import get_bed
    from pressurepose.sim.ragdoll import ragdoll_params
    from pressurepose.sim.settle import cached_model
    from pressurepose.sim.settle_config import SettleConfig

    batch = batch_of("hands_behind_head", True, 30, 14)
    config = SettleConfig()
    for k in range(len(batch)):
        params = ragdoll_params(female, batch.betas[k], "female")
        sm = cached_model(get_bed(), config, params)
        sm.configure(params, batch.pose[k], batch.transl[k])
        mujoco.mj_forward(sm.model, sm.data)
        d = sm.data
        ours = np.isin(d.contact.geom[:d.ncon], sm.ragdoll.geom).all(axis=1)
        assert not np.any(ours & (d.contact.dist[:d.ncon] < -config.self_collision_tol_m)), k


def test_hands_behind_head_is_deterministic_per_seed(female):
    from pressurepose.pose import sample_bodies
    from pressurepose.pose.sampler import body_rng, sample_one

    a = sample_bodies("hands_behind_head", "f", 4, 31, limbs_on_bed=True, body=female)
    b = sample_bodies("hands_behind_head", "f", 4, 31, limbs_on_bed=True, body=female)
    one = sample_one("hands_behind_head", "f", body_rng(31, 2), limbs_on_bed=True, body=female)
    np.testing.assert_array_equal(a.pose, b.pose)
    np.testing.assert_array_equal(a.betas, b.betas)
    np.testing.assert_array_equal(a.counts, b.counts)
    np.testing.assert_array_equal(one.pose, a.pose[2])
    c = sample_bodies("hands_behind_head", "f", 4, 32, limbs_on_bed=True, body=female)
    assert not np.array_equal(a.pose, c.pose)


@pytest.mark.parametrize("partition", ["general", "general_supine", "prone_hands_up", "supine_crossed_legs",
                                       "supine_straight_limbs", "general_lateral", "propped_lateral"])
def test_only_the_hands_behind_head_sampler_adds_the_settles_start_test(female, partition):
    """Elsewhere the paper's test checks every capsule the settle does, with wider radii and longer
    trunk capsules, so the start test could reject nothing more: it is not run, and those
    partitions' draws do not depend on it."""
    from pressurepose.pose.partitions import get_partition
    from pressurepose.pose.rejection import Run

    run = Run(get_partition(partition), female, SamplerConfig(), True, [np.random.default_rng(0)])
    assert not run.start_pairs
    hbh = Run(get_partition("hands_behind_head"), female, SamplerConfig(), True, [np.random.default_rng(0)])
    assert hbh.start_pairs
