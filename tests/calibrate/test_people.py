"""Calibration against people's image statistics: known constants recovered from targets made by the
same simulator, the loss, targets read back from a realism report, and the verb's input checks."""

from __future__ import annotations

import dataclasses
import json

import numpy as np
import pytest

from pressurepose.body import BodyModel
from pressurepose.body.joints import joint_index
from pressurepose.calibrate import people as C
from pressurepose.calibrate.objects import with_params
from pressurepose.errors import BadInput
from pressurepose.eval import realism as R
from pressurepose.sim.bed import get_bed

FAST_BED = get_bed(press_cell_m=0.0143)  # 2 x 2 cells per taxel
SUPINE_ROOT = np.array([0.0, -np.pi / np.sqrt(2), -np.pi / np.sqrt(2)])


def lying_body(body, betas, bed, arm_drop: float = 1.3, roll: float = 0.0) -> C.RestingBody:
    """A supine body (turned ``roll`` rad about the bed's long axis), arms lowered toward its sides,
    centred on the mat, lowest point at z = 0."""
    from pressurepose.body.lbs_numpy import (
        Y_UP_TO_Z_UP,
        rodrigues,
        rotation_to_axis_angle,
    )

    pose = np.zeros(72)
    turn = Y_UP_TO_Z_UP.T @ rodrigues(np.array([0.0, roll, 0.0])) @ Y_UP_TO_Z_UP
    pose[:3] = rotation_to_axis_angle(turn @ rodrigues(SUPINE_ROOT))
    pose[3 * joint_index("left_shoulder") + 2] -= arm_drop
    pose[3 * joint_index("right_shoulder") + 2] += arm_drop
    v, _ = body.forward(betas, pose, np.zeros(3))
    centre = (v[0].max(0) + v[0].min(0)) / 2
    transl = np.array([bed.mat.width_m / 2 - centre[0], bed.mat.length_m / 2 - centre[1], -v[0][:, 2].min()])
    return C.resting_body(body, betas, pose, transl, float(body.mass(betas)[0]), bed, "supine" if roll < 0.78 else
                          "lateral")


@pytest.fixture(scope="module")
def bodies():
    body = BodyModel("f")
    betas = [np.zeros(10), np.r_[1.0, 1.5, np.zeros(8)]]
    return [lying_body(body, b, FAST_BED) for b in betas]


def targets_of(bodies, bed) -> C.PeopleTargets:
    return C.PeopleTargets(C.simulated_stats(C.press_forces(bodies, bed), bodies, bed), "hidden constants")


def test_loss_is_zero_at_the_targets_and_one_at_the_tolerance(bodies):
    t = targets_of(bodies, FAST_BED)
    assert C.people_loss(t.groups, t) == 0.0
    g = t.groups["supine"]
    off = C.GroupTargets(g.contact_taxels * 1.2, g.mean_mmhg * 1.2, g.peak_mmhg * 1.3,
                         tuple(np.add(g.shares, 0.05)), g.n)
    assert C.people_loss({"supine": off}, t) == pytest.approx(1.0)
    with pytest.raises(BadInput, match="none in common"):
        C.people_loss({"prone": g}, t)


def test_known_constants_recovered(bodies):
    hidden = {"stiffness": 5.0e4, "threshold": 8.0}
    truth = with_params(FAST_BED, hidden)
    targets = targets_of(bodies, truth)
    begin = with_params(FAST_BED, {"threshold": 5.0})  # below 5 mmHg a threshold changes nothing measured
    start = C.people_loss(C.simulated_stats(C.press_forces(bodies, begin), bodies, begin), targets)
    res = C.calibrate_people(bodies, targets, begin, fit=("stiffness", "threshold"), popsize=8, seed=1, max_evals=240,
                             tolfun=1e-6)
    assert start > 0.3
    assert res.loss < 0.01
    assert res.fitted["stiffness"] == pytest.approx(hidden["stiffness"], rel=0.1)
    assert res.fitted["threshold"] == pytest.approx(hidden["threshold"], abs=0.6)
    assert res.bed.tissue_modulus_pa == FAST_BED.tissue_modulus_pa  # not fitted, not touched


def test_targets_from_images_and_from_a_realism_report(tmp_path, bodies):
    from tests.eval.test_realism import body as footprint

    imgs = np.stack([footprint(), footprint(head=False), footprint()])
    t = C.targets_from_images(imgs, ["supine", "supine", "lateral"], FAST_BED.mat, "hand-made")
    assert set(t.groups) == {"supine", "lateral"}
    assert t.groups["supine"].n == 2 and sum(t.groups["supine"].shares) == pytest.approx(1.0)
    stats = R.image_stats(imgs[:2], FAST_BED.mat)
    rep = {"real_name": "x", "postures": {"supine": {"real": R.summarise(stats)}}}
    (tmp_path / "realism.json").write_text(json.dumps(rep))
    back = C.targets_from_report(tmp_path / "realism.json")
    assert back.groups["supine"] == t.groups["supine"]
    (tmp_path / "bad.json").write_text("{}")
    with pytest.raises(BadInput, match="realism.json"):
        C.targets_from_report(tmp_path / "bad.json")


def test_verb_needs_real_and_bodies(tmp_path):
    from pressurepose.cli import main

    assert main(["calibrate", "--targets", "real", "--out", str(tmp_path / "b.json")]) == 2
    assert main(["calibrate", "--targets", "real", "--real", str(tmp_path), "--bodies", str(tmp_path / "none"),
                 "--out", str(tmp_path / "b.json")]) == 2


def test_resting_body_on_another_bed_takes_its_bone_fractions(bodies):
    b = bodies[0]
    assert b.on(FAST_BED) is b
    thin = dataclasses.replace(FAST_BED, tissue_bone_fraction={"thigh": 0.9})
    moved = b.on(thin)
    assert moved.fraction == thin.tissue_bone_fraction
    assert np.nanmax(moved.field.tissue) <= np.nanmax(b.field.tissue) + 1e-12
    assert (moved.field.tissue < b.field.tissue - 1e-4).any()  # thicker bone, thinner tissue over it
    assert np.array_equal(moved.field.bottom, b.field.bottom)


def test_bodies_matched_by_extent(tmp_path):
    """With real extent ratios to follow, the bodies drawn lie as long as the real ones: real images
    as short as the shortest of three simulated bodies draw that body first."""
    from pressurepose.cli import main

    out = tmp_path / "sim.npz"
    assert main(["simulate", "--partition", "general_supine", "--gender", "f", "--count", "3", "--seed", "1",
                 "--out", str(out)]) == 0
    with np.load(out) as z:
        a = {k: z[k] for k in ("pressure", "height", "betas", "pose", "transl")}
    ratio = R.extent_ratio(a["pressure"].astype(float), FAST_BED.mat, a["height"])
    short = int(np.argmin(ratio))
    assert np.sort(ratio)[1] > ratio[short] + 0.1  # the three lie differently long
    matched = C.resting_bodies(out, get_bed(), per_posture=1, postures=("supine",),
                               match={"supine": np.full(5, ratio[short])})
    expect = C.bone_cores(BodyModel("f"), a["betas"][short], a["pose"][short], a["transl"][short])
    assert len(matched) == 1 and np.allclose(matched[0].cores.ends, expect.ends)
    with pytest.raises(BadInput, match="27"):
        C.resting_bodies(out, get_bed("slp"), per_posture=1, match={"supine": np.ones(3)})
    half = tmp_path / "half.npz"
    half.write_bytes(out.read_bytes()[:1000])
    with pytest.raises(BadInput, match=r"settled bodies .*half.npz' is (corrupt|not a readable)"):
        C.resting_bodies(half, get_bed(), per_posture=1)


def test_a_constant_calibrate_cannot_fit_is_refused(tmp_path, capsys):
    from pressurepose.cli import main

    assert main(["calibrate", "--targets", "default", "--fit", "stiffness,bone_pelvis",
                 "--out", str(tmp_path / "b.json")]) == 2
    assert "cannot fit ['bone_pelvis']" in capsys.readouterr().err


def test_tipping_sees_what_the_first_order_re_press_does_not(bodies):
    """A body turned 0.32 rad onto its side without anything to hold it: the fit's first-order
    re-press finds it a support (slope under the 0.3 rad limit), the full press turns it again
    and again until it tips over. Resting supine bodies do not tip."""
    assert C.tipping(bodies, FAST_BED) == {"supine": (0, 2)}
    leaning = lying_body(BodyModel("f"), np.zeros(10), FAST_BED, roll=0.32)
    C.press_forces([leaning], FAST_BED)  # no PressFailed
    assert C.tipping([leaning], FAST_BED) == {"supine": (1, 1)}
    import dataclasses

    assert C.tipping([dataclasses.replace(leaning, vertices=None)], FAST_BED) == {}
