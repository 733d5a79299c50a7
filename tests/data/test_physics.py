"""The physics producer: labels match the pressed body; one real sample end to end."""

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
    from pressurepose.data.producers import Rejected, attempt_rng
    from pressurepose.data.schema import GenerationConfig

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


def test_manifest_records_the_physics_constants_and_a_resume_under_others_is_refused(tmp_path, monkeypatch):
    """The sampler's constants (crown gap, collision capsules, ...), the settle's and the bed's are
    in a physics dataset's manifest; reopening it after one of them changed is refused, since its old
    and new shards would differ."""
    import dataclasses
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
