import numpy as np

from pressurepose.body import BodyModel
from pressurepose.cli import main


def test_simulate_writes_labels_that_match_the_images(tmp_path, capsys):
    out = tmp_path / "s.npz"
    assert main(["simulate", "--partition", "general_supine", "--gender", "f", "--count", "1", "--seed", "2",
                 "--out", str(out), "--plot", str(tmp_path / "s.png")]) == 0
    z = np.load(out)
    assert z["pressure"].shape == (1, 64, 27) and z["pose"].shape == (1, 72)
    _, joints = BodyModel("f").forward(z["betas"], z["pose"], z["transl"])
    np.testing.assert_allclose(joints, z["joints"], atol=1e-9)
    weight = z["mass"][0] * 9.81
    assert 0.6 * weight < z["force"][0].sum() <= 1.001 * weight  # the sensing area carries most of it
    assert (tmp_path / "s.png").stat().st_size > 20_000
    assert np.isnan(z["wedge"]).all()  # no wedge in this partition


def test_simulate_keeps_and_draws_the_wedge_of_a_propped_body(tmp_path, capsys):
    from pressurepose.sim.wedge import Wedge

    out = tmp_path / "p.npz"
    assert main(["simulate", "--partition", "propped_lateral", "--gender", "m", "--count", "1", "--seed", "3",
                 "--out", str(out), "--plot", str(tmp_path / "p.png")]) == 0
    z = np.load(out)
    w = Wedge.from_array(z["wedge"][0])
    assert w is not None and 0 < w.angle_rad < np.pi / 2 and w.height_m > 0
    assert abs(np.linalg.norm(w.axis) - 1) < 1e-9
    # the wedge's base shows on the mat: force where the body does not touch
    assert z["force"][0][~z["contact"][0]].sum() > 0
    assert (tmp_path / "p.png").stat().st_size > 20_000


def test_simulate_bad_input(tmp_path, capsys):
    assert main(["simulate", "--partition", "sideways", "--gender", "f", "--out", str(tmp_path / "x.npz")]) == 2
    assert "sideways" in capsys.readouterr().err
    assert main(["simulate", "--partition", "general", "--gender", "f", "--count", "0",
                 "--out", str(tmp_path / "x.npz")]) == 2


def test_simulate_passes_the_height_reference_to_the_sampler(tmp_path, capsys):
    poses = {}
    for ref in ("proximal", "bed"):
        out = tmp_path / f"{ref}.npz"
        assert main(["simulate", "--partition", "general", "--gender", "f", "--count", "1", "--seed", "4",
                     "--height-reference", ref, "--out", str(out)]) == 0
        poses[ref] = np.load(out)["pose"][0]
    assert not np.allclose(poses["proximal"], poses["bed"])


def test_a_hanging_limb_is_one_beyond_the_edge_and_below_the_top():
    from pressurepose.sim import get_bed
    from pressurepose.sim.simulate import limb_off_bed

    bed = get_bed()
    x0, x1, y0, y1 = bed.mattress_bounds
    joints = np.zeros((24, 3))
    joints[:, :2] = [(x0 + x1) / 2, (y0 + y1) / 2]
    assert not limb_off_bed(joints, bed)
    knee = joints.copy()
    knee[4] = [x1 + 0.1, (y0 + y1) / 2, -0.45]  # a knee bent down over the side, 0.45 m below the top
    assert limb_off_bed(knee, bed)
    hand = joints.copy()
    hand[22] = [(x0 + x1) / 2, y0 - 0.05, -0.02]  # a hand resting across the head end
    assert not limb_off_bed(hand, bed)
    deep_inside = joints.copy()
    deep_inside[7, 2] = -0.3  # below the top but over the mattress: not hanging (the press fails it)
    assert not limb_off_bed(deep_inside, bed)


def test_no_limb_hangs_over_the_edge_unless_asked(tmp_path, capsys):
    """supine_straight_limbs (where legs hung over the side in 3 of 6 bodies before): by default every
    resting limb joint lies over the mattress or within HANG_DEPTH_M of its top; --hanging-limbs
    --placement uniform lets limbs start beyond the mattress again (the paper's sampler)."""
    from pressurepose.sim import get_bed
    from pressurepose.sim.simulate import HANG_DEPTH_M, LIMB_JOINTS

    x0, x1, y0, y1 = get_bed().mattress_bounds
    out = tmp_path / "s.npz"
    assert main(["simulate", "--partition", "supine_straight_limbs", "--gender", "m", "--count", "4", "--seed", "3",
                 "--out", str(out)]) == 0
    j = np.load(out)["joints"][:, list(LIMB_JOINTS)]
    over = (j[..., 0] >= x0) & (j[..., 0] <= x1) & (j[..., 1] >= y0) & (j[..., 1] <= y1)
    assert np.all(over | (j[..., 2] > -HANG_DEPTH_M))
    assert main(["sample", "--partition", "supine_straight_limbs", "--gender", "m", "--count", "40", "--seed", "3",
                 "--hanging-limbs", "--placement", "uniform", "--shapes", "uniform",
                 "--out", str(tmp_path / "p.npz")]) == 0
    j = np.load(tmp_path / "p.npz")["joints"][:, list(LIMB_JOINTS)]
    assert np.any((j[..., 0] < x0) | (j[..., 0] > x1))  # the paper's sampler lets limbs start beyond the sides


def test_simulate_on_a_bed_file(tmp_path, capsys):
    """`simulate --bed FILE`: the body is pressed on that bed (here: every bone as thick as its capsule,
    so the tissue is as thin as it gets, and the imprint shrinks); a --mat that is not the bed's is refused."""
    import json

    from pressurepose.sim.bed import BONE_PARTS, get_bed

    (tmp_path / "bed.json").write_text(json.dumps(get_bed(tissue_bone_fraction=(1.0,) * len(BONE_PARTS)).to_dict()))
    common = ["simulate", "--partition", "supine_straight_limbs", "--gender", "f", "--count", "1", "--seed", "4"]
    assert main(common + ["--out", str(tmp_path / "a.npz")]) == 0
    assert main(common + ["--out", str(tmp_path / "b.npz"), "--bed", str(tmp_path / "bed.json")]) == 0
    a, b = np.load(tmp_path / "a.npz"), np.load(tmp_path / "b.npz")
    np.testing.assert_array_equal(a["betas"], b["betas"])
    np.testing.assert_array_equal(a["pose"][:, 3:], b["pose"][:, 3:])  # the press only moves the body rigidly
    assert (b["pressure"] > 5).sum() < (a["pressure"] > 5).sum()
    assert main(common + ["--out", str(tmp_path / "c.npz"), "--bed", str(tmp_path / "bed.json"), "--mat", "tip"]) == 2


def test_a_rejected_attempt_is_a_value_naming_the_settles_status():
    """A settle given one step cannot rest the body: simulate_one returns Rejected with the settle's
    status and the steps it took, not a sample; the simulate command counts it by that cause."""
    import pytest

    from pressurepose.sim import get_bed
    from pressurepose.sim.settle import STATUSES
    from pressurepose.sim.settle_config import SettleConfig
    from pressurepose.sim.simulate import Rejected, simulate_one

    bed = get_bed()
    one_step = SettleConfig(max_steps=1, stiffness_n_m3=bed.stiffness_n_m3)
    out = simulate_one(BodyModel("f"), bed, "general_supine", "f", np.random.default_rng(0),
                       settle_config=one_step)
    assert isinstance(out, Rejected) and out.cause == "not_settled" and out.cause in STATUSES
    assert out.detail.startswith("1 settle step, started supine")
    with pytest.raises(TypeError, match="cause"):
        Rejected("")


def test_bodies_posed_from_real_poses_hold_them_and_the_manifest_says_so(monkeypatch):
    """A natural partition's body settles with its springs at the drawn pose (the settle is given
    that pose), a limb-sampled body with the paper's home pose (none given); the dataset's
    provenance records the difference, so a dataset of the other kind does not resume into it."""
    import pressurepose.sim.settle as settle_module
    from pressurepose.data.physics import provenance
    from pressurepose.data.schema import GenerationConfig
    from pressurepose.sim import get_bed
    from pressurepose.sim.settle_config import SettleConfig
    from pressurepose.sim.simulate import simulate_one

    seen = []
    real = settle_module.settle

    def spy(body, betas, pose, transl, *args, spring_pose=None, **kw):
        seen.append((np.array(pose), spring_pose))
        return real(body, betas, pose, transl, *args, spring_pose=spring_pose, **kw)

    monkeypatch.setattr(settle_module, "settle", spy)
    bed = get_bed()
    one_step = SettleConfig(max_steps=1, stiffness_n_m3=bed.stiffness_n_m3)
    for partition in ("natural_supine", "general_supine"):
        simulate_one(BodyModel("f"), bed, partition, "f", np.random.default_rng(0), settle_config=one_step)
    (natural, held), (_, home) = seen
    np.testing.assert_array_equal(held, natural)
    assert home is None
    assert provenance(GenerationConfig(partition="natural_lateral", gender="m"))["springs"] == "drawn pose"
    assert "springs" not in provenance(GenerationConfig(partition="general_supine", gender="m"))


def test_simulate_one_refuses_arguments_of_the_wrong_kind_before_any_work():
    """A body given by name or None, no bed, a dict as the conditions, a list for the timings and a
    preset name as the settle config were AttributeErrors in the sampler or the settle (or a
    rejected body, for the conditions); limbs_on_bed='no' was true; a dict as the sampler was
    refused as the sampler's own "config"."""
    import pytest

    from pressurepose.body.toy import toy_body_arrays
    from pressurepose.errors import BadInput
    from pressurepose.sim.bed import get_bed
    from pressurepose.sim.simulate import simulate_one

    body, bed, rng = BodyModel(toy_body_arrays()), get_bed(), np.random.default_rng(0)
    for args, kwargs, message in (((None, bed), {}, "body is NoneType; expected a BodyModel"),
                                  (("female", bed), {}, "body is str; expected a BodyModel"),
                                  ((body, None), {}, "bed is NoneType; expected a BedSpec"),
                                  ((body, bed), {"conditions": {}}, "conditions is dict; expected a Conditions or None"),
                                  ((body, bed), {"timings": []}, "timings is list; expected a dict to fill or None"),
                                  ((body, bed), {"settle_config": "paper"}, "settle_config is str; expected a SettleConfig"),
                                  ((body, bed), {"limbs_on_bed": "no"}, "limbs_on_bed is 'no'; expected True or False"),
                                  ((body, bed), {"sampler": {"hanging_limbs": True}},
                                   "sampler is dict; expected a SamplerConfig or None")):
        with pytest.raises(BadInput, match=message):
            simulate_one(*args, "general", "f", rng, **kwargs)


def test_simulate_one_refuses_a_gender_that_is_not_the_bodys():
    """A female body settled as 'm' (or a male one as 'f') was simulated with the other gender's
    mass table and label; it is refused naming both. A neutral body takes either gender."""
    import pytest

    from pressurepose.body.toy import toy_body_arrays
    from pressurepose.errors import BadInput
    from pressurepose.sim.bed import get_bed
    from pressurepose.sim.simulate import check_body_gender, simulate_one

    bed, rng = get_bed(), np.random.default_rng(0)
    for spec, gender, own in (("f", "m", "female"), ("m", "female", "male")):
        with pytest.raises(BadInput, match=f"gender is '{gender}' but the body is the {own} model.*'{own[0]}'"):
            simulate_one(BodyModel(spec), bed, "general", gender, rng)
    with pytest.raises(BadInput, match="gender 'x' is not known"):
        simulate_one(BodyModel("f"), bed, "general", "x", rng)
    neutral = BodyModel(toy_body_arrays())
    assert [check_body_gender(neutral, g) for g in ("f", "m", "male")] == ["f", "m", "m"]
    assert check_body_gender(BodyModel("f"), "female") == "f"
