"""The physics producer: labels match the pressed body; one real sample end to end."""

import dataclasses

import numpy as np
import pytest

from pressurepose.body import BodyModel
from pressurepose.body.lbs_numpy import rodrigues
from pressurepose.body.toy import toy_body_arrays
from pressurepose.sim.simulate import apply_rigid_motion


def test_rigid_motion_folds_into_root_parameters():
    body = BodyModel(toy_body_arrays())
    rng = np.random.default_rng(0)
    betas, pose, transl = rng.normal(size=10), rng.normal(scale=0.4, size=72), rng.normal(size=3)
    T = np.eye(4)
    T[:3, :3] = rodrigues(np.array([0.03, -0.02, 0.4]))
    T[:3, 3] = [0.1, -0.05, -0.02]
    v0, _ = body.forward(betas, pose, transl)
    pose2, transl2 = apply_rigid_motion(body, betas, pose, transl, T)
    v1, _ = body.forward(betas, pose2, transl2)
    np.testing.assert_allclose(v1[0], v0[0] @ T[:3, :3].T + T[:3, 3], atol=1e-10)
    np.testing.assert_array_equal(pose2[3:], pose[3:])


@pytest.mark.slow
def test_one_physics_sample_balances_its_weight():
    from pressurepose.data.physics import physics_producer
    from pressurepose.data.producers import attempt_rng
    from pressurepose.data.schema import GenerationConfig
    from pressurepose.sim.simulate import Rejected

    cfg = GenerationConfig(partition="general_supine", gender="f", count=1, seed=3, producer="physics")
    for attempt in range(5):
        s = physics_producer(cfg, attempt_rng(cfg, 0, attempt))
        if not isinstance(s, Rejected):
            break
    assert not isinstance(s, Rejected), s
    s.validate((64, 27))
    body = BodyModel("female")
    v, j = body.forward(s.betas, s.pose, s.transl)
    np.testing.assert_allclose(j[0], s.joints, atol=1e-9)
    # the sensing area sees most of a supine body's weight, never more than all of it
    assert 0.6 * s.mass * 9.81 < s.force.sum() <= 1.001 * s.mass * 9.81
    assert s.contact.any() and np.all(s.pressure >= 0)
    # where the mat reads contact the body is below the unloaded bed top, and over its lowest point
    assert s.depth[s.contact].max() < 0
    assert v[0, :, 2].min() == pytest.approx(s.depth.min(), abs=0.02)
    # every taxel the body loads names the body site that carries it; the others none
    np.testing.assert_array_equal(s.sites >= 0, s.force > 0)


def test_manifest_records_the_physics_constants_and_a_resume_under_others_is_refused(tmp_path, monkeypatch):
    """The sampler's constants (crown gap, collision capsules, ...), the settle's and the bed's are
    in a physics dataset's manifest; reopening it after one of them changed is refused, since its old
    and new shards would differ."""
    import json

    import pytest

    from pressurepose.data import physics
    from pressurepose.data.pipeline import open_output
    from pressurepose.data.schema import GenerationConfig
    from pressurepose.data.store import MANIFEST, Manifest
    from pressurepose.errors import BadInput
    from pressurepose.pose.config import SamplerConfig

    config = GenerationConfig(partition="general_supine", gender="f", count=2, seed=3)
    open_output(tmp_path, config)
    prov = json.loads((tmp_path / MANIFEST).read_text())["provenance"]
    assert prov["sampler"]["head_gap_m"] == SamplerConfig().head_gap_m
    assert prov["sampler"]["collision_radius_scale"] == SamplerConfig().collision_radius_scale
    assert prov["settle"]["timestep_s"] > 0 and prov["bed"]["mat"]["name"] == "boditrak_bt3510"
    assert Manifest.load(tmp_path).provenance == prov
    assert open_output(tmp_path, config).provenance == prov  # same constants: resumes

    moved = dataclasses.replace(SamplerConfig(), head_gap_m=0.1)
    monkeypatch.setattr(physics, "sampler_config", lambda c: moved)
    with pytest.raises(BadInput, match=r"sampler.head_gap_m 0.16 -> 0.1"):
        open_output(tmp_path, config)


def test_a_manifest_recording_the_retired_max_limb_sink_reads_and_resumes(tmp_path):
    """Some manifests record the sampler's max_limb_sink (None: the opt-in limb test off, as every
    generated dataset had it). Such a manifest reads and its dataset resumes; one recording the
    test on reads, but a resume is refused, naming the setting."""
    import json

    from pressurepose.data.pipeline import open_output
    from pressurepose.data.schema import GenerationConfig
    from pressurepose.data.store import MANIFEST, Manifest
    from pressurepose.errors import BadInput

    config = GenerationConfig(partition="general_supine", gender="f", count=2, seed=3)
    open_output(tmp_path, config)
    raw = json.loads((tmp_path / MANIFEST).read_text())
    now = raw["provenance"]
    assert "max_limb_sink" not in now["sampler"]
    raw["provenance"] = {**now, "sampler": {**now["sampler"], "max_limb_sink": None}}
    (tmp_path / MANIFEST).write_text(json.dumps(raw))
    assert Manifest.load(tmp_path).provenance == now
    assert open_output(tmp_path, config).provenance == now
    raw["provenance"]["sampler"]["max_limb_sink"] = 0.05
    (tmp_path / MANIFEST).write_text(json.dumps(raw))
    assert Manifest.load(tmp_path).provenance["sampler"]["max_limb_sink"] == 0.05
    with pytest.raises(BadInput, match=r"sampler.max_limb_sink 0.05 -> None"):
        open_output(tmp_path, config)


def test_a_manifest_recording_the_retired_friction_cone_reads_and_resumes(tmp_path):
    """Manifests made before the settle's friction cone stopped being a setting record it ('elliptic',
    the only cone now). Such a manifest reads and its dataset resumes; one made with pyramidal cones is
    refused, naming the setting."""
    import json

    from pressurepose.data.pipeline import open_output
    from pressurepose.data.schema import GenerationConfig
    from pressurepose.data.store import MANIFEST, Manifest
    from pressurepose.errors import BadInput

    config = GenerationConfig(partition="general_supine", gender="f", count=2, seed=3)
    open_output(tmp_path, config)
    raw = json.loads((tmp_path / MANIFEST).read_text())
    now = raw["provenance"]
    assert "cone" not in now["settle"]
    raw["provenance"] = {**now, "settle": {**now["settle"], "cone": "elliptic"}}
    (tmp_path / MANIFEST).write_text(json.dumps(raw))
    assert Manifest.load(tmp_path).provenance == now
    assert open_output(tmp_path, config).provenance == now
    raw["provenance"]["settle"]["cone"] = "pyramidal"
    (tmp_path / MANIFEST).write_text(json.dumps(raw))
    with pytest.raises(BadInput, match=r"settle.cone"):
        open_output(tmp_path, config)


def test_a_wedge_partitions_provenance_holds_the_wedges_constants(tmp_path, monkeypatch):
    from pressurepose.data import physics
    from pressurepose.data.schema import GenerationConfig
    from pressurepose.pose import partitions

    plain = physics.provenance(GenerationConfig(partition="general_lateral", gender="f", count=2, seed=3))
    propped = physics.provenance(GenerationConfig(partition="propped_lateral", gender="f", count=2, seed=3))
    assert "wedge" not in plain
    assert propped["wedge"]["length_m"] == partitions.WEDGE_LENGTH_M
    assert propped["wedge"]["trunk"] == list(partitions.WEDGE_TRUNK)
    monkeypatch.setattr(partitions, "WEDGE_LENGTH_M", 0.5)
    assert physics.provenance(GenerationConfig(partition="propped_lateral", gender="f", count=2, seed=3)) != propped


def test_a_config_carries_its_bed(tmp_path):
    """A dataset made on another bed keeps the bed in its config and provenance; without one the
    config (and its digest) is what it was before beds could be given; the same seed draws the same
    bodies on both beds."""
    import json

    from pressurepose.data.pipeline import open_output
    from pressurepose.data.schema import GenerationConfig
    from pressurepose.data.store import MANIFEST
    from pressurepose.errors import BadInput
    from pressurepose.sim.bed import get_bed

    plain = GenerationConfig(partition="general_supine", gender="f", count=2, seed=3)
    assert "bed" not in plain.to_dict() and plain.bed_spec() == get_bed()
    soft = get_bed(stiffness_n_m3=4e4, tissue_bone_fraction={"pelvis": 0.8})
    config = GenerationConfig(partition="general_supine", gender="f", count=2, seed=3, bed=soft.to_dict())
    assert config.bed_spec() == soft and config.stream_key == plain.stream_key
    assert GenerationConfig.from_json(config.to_json()) == config and config.digest != plain.digest
    open_output(tmp_path, config)
    m = json.loads((tmp_path / MANIFEST).read_text())
    assert m["config"]["bed"]["stiffness_n_m3"] == 4e4 and m["provenance"]["bed"]["stiffness_n_m3"] == 4e4
    assert m["provenance"]["bed"]["tissue_bone_fraction"]["pelvis"] == 0.8
    with pytest.raises(BadInput, match="different config"):
        open_output(tmp_path, plain)
    with pytest.raises(BadInput, match="is not the preset 'slp'"):
        GenerationConfig(partition="general", gender="f", mat="slp", bed=soft.to_dict())
    with pytest.raises(BadInput, match="JSON"):
        GenerationConfig(partition="general", gender="f", bed="{")


def test_a_config_carries_its_settle(tmp_path):
    """`settle` picks the settle's constants ('relaxed' by default, omitted from the config so that
    configs keep their digests; 'paper': the paper's springs), is in the provenance, and changes no
    draw: one seed gives paired datasets."""
    import json

    from pressurepose.data import physics
    from pressurepose.data.pipeline import open_output
    from pressurepose.data.schema import GenerationConfig
    from pressurepose.data.store import MANIFEST
    from pressurepose.errors import BadInput
    from pressurepose.sim.settle_config import SettleConfig

    plain = GenerationConfig(partition="general_supine", gender="f", count=2, seed=3)
    paper = GenerationConfig(partition="general_supine", gender="f", count=2, seed=3, settle="paper")
    assert "settle" not in plain.to_dict() and physics.settle_config(plain) == SettleConfig()
    assert physics.settle_config(paper) == SettleConfig(relaxed_neck=False, spine_stiffness=None)
    assert paper.stream_key == plain.stream_key and paper.digest != plain.digest
    assert GenerationConfig.from_json(paper.to_json()) == paper
    open_output(tmp_path, paper)
    m = json.loads((tmp_path / MANIFEST).read_text())
    assert m["config"]["settle"] == "paper"
    assert m["provenance"]["settle"]["spine_stiffness"] is None and m["provenance"]["settle"]["relaxed_neck"] is False
    assert physics.provenance(plain)["settle"]["spine_stiffness"] == SettleConfig().spine_stiffness
    with pytest.raises(BadInput, match="settle = 'stiff'; expected one of relaxed, paper"):
        GenerationConfig(partition="general", gender="f", settle="stiff")


def test_a_config_carries_its_height_reference(tmp_path):
    """`height_reference` ('proximal' by default, left out of the record so that configs made before
    it keep their digests and seed streams; 'bed': distal joints start near the bed) reaches the
    sampler and its provenance, has a random stream of its own, and a dataset begun under one
    reference does not resume under the other."""
    from pressurepose.data import physics
    from pressurepose.data.pipeline import open_output
    from pressurepose.data.schema import PAPER_SAMPLING, GenerationConfig
    from pressurepose.errors import BadInput

    plain = GenerationConfig(partition="general", gender="f")
    bed = GenerationConfig(partition="general", gender="f", height_reference="bed")
    # computed on the code before configs had a height reference: the default keeps its identity
    assert plain.digest == "703ace57f412728ff438e36d42c399ca1413cab0e5bcf46b6286dc282be977e6"
    assert plain.stream_key == 3721073151
    paper = GenerationConfig(partition="general", gender="f", **PAPER_SAMPLING)
    assert paper.digest == "58cb7a92c21554e0deb05e51878b0b34df019fbdf85ea0c4773fdcad4ff4bc3a"
    assert paper.stream_key == 1618030767
    assert "height_reference" not in plain.to_dict() and bed.to_dict()["height_reference"] == "bed"
    assert GenerationConfig.from_json(bed.to_json()) == bed and GenerationConfig.from_json(plain.to_json()) == plain
    assert bed.digest != plain.digest and bed.stream_key != plain.stream_key
    paper_bed = GenerationConfig(partition="general", gender="f", **{**PAPER_SAMPLING, "height_reference": "bed"})
    assert paper_bed.stream_key not in (paper.stream_key, plain.stream_key, bed.stream_key)
    assert physics.sampler_config(plain).height_reference == "proximal"
    assert physics.sampler_config(bed).height_reference == "bed"
    assert physics.provenance(bed)["sampler"]["height_reference"] == "bed"
    with pytest.raises(BadInput, match="height_reference = 'floor'; expected one of proximal, bed"):
        GenerationConfig(partition="general", gender="f", height_reference="floor")
    small = dict(partition="general_supine", gender="f", count=2, seed=3)
    open_output(tmp_path, GenerationConfig(**small, height_reference="bed"))
    with pytest.raises(BadInput, match=r"different config \(height_reference: 'bed' on disk vs 'proximal' now\)"):
        open_output(tmp_path, GenerationConfig(**small))
    assert open_output(tmp_path, GenerationConfig(**small, height_reference="bed")).config.height_reference == "bed"


@pytest.mark.slow
def test_generate_with_the_papers_settle(tmp_path):
    """`generate --settle paper` draws the same bodies as the default and rests them with the paper's
    stiff springs: the supine trunk bends less at the spine."""
    from pressurepose.body.joints import JOINT_NAMES
    from pressurepose.cli import main
    from pressurepose.data.dataset import DatasetReader

    common = ["generate", "--partition", "supine_straight_limbs", "--gender", "f", "--count", "2", "--seed", "3",
              "--no-progress"]
    assert main(common + ["--out", str(tmp_path / "relaxed")]) == 0
    assert main(common + ["--out", str(tmp_path / "paper"), "--settle", "paper"]) == 0
    a, b = (DatasetReader(tmp_path / k).load_arrays(("betas", "pose"), label_dtype=np.float64)
            for k in ("relaxed", "paper"))
    np.testing.assert_array_equal(a["betas"], b["betas"])  # paired: the same bodies drawn
    spine = [JOINT_NAMES.index(n) for n in ("spine1", "spine2", "spine3")]
    bend = {k: np.linalg.norm(v["pose"].reshape(-1, 24, 3)[:, spine], axis=-1).sum() for k, v in (("relaxed", a),
                                                                                                  ("paper", b))}
    assert bend["relaxed"] > bend["paper"]
    from pressurepose.data.info import format_summary, summarize

    assert "settled with: the paper's stiff neck, the paper's stiff spine, step 0.01 s, 0.02 s from 150 steps " \
        "after touching" in format_summary(
        summarize(tmp_path / "paper", examples=0))


def test_info_says_how_bodies_were_settled():
    from pressurepose.data.info import settle_line
    from pressurepose.sim.settle_config import SettleConfig, settle_preset
    from pressurepose.sim.springs import RELAXED_SPINE_STIFFNESS

    coarse = "step 0.01 s, 0.02 s from 150 steps after touching"
    assert settle_line(dataclasses.asdict(SettleConfig())) == \
        f"relaxed neck, relaxed spine ({RELAXED_SPINE_STIFFNESS:g} N m/rad), {coarse}"
    assert settle_line(dataclasses.asdict(settle_preset("paper"))) == \
        f"the paper's stiff neck, the paper's stiff spine, {coarse}"
    assert settle_line(dataclasses.asdict(SettleConfig(coarse_factor=1.0))).endswith(", step 0.01 s throughout")
    assert settle_line(None) == ""
    assert settle_line({"relaxed_neck": True}) == ""  # not a settle's record


@pytest.mark.slow
def test_generate_on_a_bed_file(tmp_path):
    """`generate --bed FILE`: the same bodies drawn as on the default bed, pressed on a mattress four
    times stiffer, print a smaller imprint."""
    import json

    from pressurepose.cli import main
    from pressurepose.data.dataset import DatasetReader
    from pressurepose.sim.bed import get_bed

    (tmp_path / "bed.json").write_text(json.dumps({"bed": get_bed(stiffness_n_m3=4 * get_bed().stiffness_n_m3)
                                                   .to_dict()}))
    common = ["generate", "--partition", "supine_straight_limbs", "--gender", "m", "--count", "2", "--seed", "5",
              "--no-progress"]
    assert main(common + ["--out", str(tmp_path / "a")]) == 0
    assert main(common + ["--out", str(tmp_path / "b"), "--bed", str(tmp_path / "bed.json")]) == 0
    a = DatasetReader(tmp_path / "a").load_arrays(("pressure", "betas"))
    b = DatasetReader(tmp_path / "b").load_arrays(("pressure", "betas"))
    np.testing.assert_array_equal(a["betas"], b["betas"])
    assert ((b["pressure"] > 5).sum((1, 2)) < (a["pressure"] > 5).sum((1, 2))).all()
    from pressurepose.data.info import format_summary, summarize

    assert "made on a given bed" in format_summary(summarize(tmp_path / "b", examples=0))
    assert "given bed" not in format_summary(summarize(tmp_path / "a", examples=0))
    assert main(common + ["--out", str(tmp_path / "c"), "--bed", str(tmp_path / "bed.json"), "--mat", "slp"]) == 2


def test_the_provenance_records_every_setting_of_the_settle():
    """A dataset's manifest keeps the whole settle config; a resume compares it key by key, so the
    keys are the dataset format's."""
    from pressurepose.data import physics
    from pressurepose.data.schema import GenerationConfig
    from pressurepose.sim.settle_config import SettleConfig

    record = physics.provenance(GenerationConfig(partition="general_lateral", gender="f", count=2, seed=3))
    assert record["settle"] == dataclasses.asdict(SettleConfig())
    assert sorted(record["settle"]) == sorted((
        "timestep_s", "max_steps", "zero_every", "rest_speed_m_s", "rest_accel_m_s2", "rest_hold_steps",
        "drop_clearance_m", "cell_m", "taxels_per_cell", "stiffness_n_m3", "coupling", "self_collision",
        "limit_stiffness_factor", "iterations", "ls_iterations", "tolerance", "max_speed_m_s",
        "fall_depth_m", "self_collision_tol_m", "posture_check_steps", "relaxed_neck", "spine_stiffness",
        "coarse_factor", "coarse_after_steps"))
