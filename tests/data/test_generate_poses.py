"""`sample --poses` and `generate --poses`: bodies drawn from a user's own pose file."""

import json

import numpy as np
import pytest

from pressurepose.body.joints import joint_index
from pressurepose.cli import main
from pressurepose.data.schema import GenerationConfig
from pressurepose.pose.posefile import PoseFile
from pressurepose.pose.root import root_axis_angle, world_rotation


def pose_file(path):
    """Two supine poses that fit the default bed untouched: arms by the sides, knees a little bent."""
    p = np.zeros((2, 72))
    p[:, :3] = root_axis_angle(world_rotation(np.zeros(2), np.zeros(2)))
    p[:, 3 * joint_index("left_shoulder") + 2] = np.radians(-70)
    p[:, 3 * joint_index("right_shoulder") + 2] = np.radians(70)
    p[:, 3 * joint_index("left_knee")] = np.radians([10, 40])
    np.savez(path, pose=p)
    return p


def test_sample_poses_draws_near_the_files_poses(tmp_path, capsys):
    p = pose_file(tmp_path / "mine.npz")
    rc = main(["sample", "--partition", "general_supine", "--gender", "f", "--count", "8", "--seed", "2",
               "--poses", str(tmp_path / "mine.npz"), "--pose-noise", "2", "--out", str(tmp_path / "s.npz")])
    assert rc == 0, capsys.readouterr().err
    drawn = np.load(tmp_path / "s.npz")["pose"]
    # each body is one of the file's poses plus 2 deg noise: mean |noise| 1.6 deg, nudges aside
    near = np.degrees(np.abs(drawn[:, None, 3:] - p[None, :, 3:]).mean(-1).min(1))
    assert np.median(near) < 3.0
    knee = drawn[:, 3 * joint_index("left_knee")]
    assert np.all(np.abs(knee - np.radians(25)) > np.radians(5))  # 10 or 40, not in between
    rc = main(["sample", "--partition", "general_supine", "--gender", "f", "--count", "2", "--seed", "2",
               "--pose-noise", "2", "--out", str(tmp_path / "t.npz")])
    assert rc == 2 and "go with --poses" in capsys.readouterr().err
    rc = main(["sample", "--partition", "hands_behind_head", "--gender", "f", "--count", "2", "--seed", "2",
               "--poses", str(tmp_path / "mine.npz"), "--out", str(tmp_path / "t.npz")])
    assert rc == 2 and "limb rules" in capsys.readouterr().err


def test_config_carries_the_pose_file_and_old_digests_stay(tmp_path):
    pose_file(tmp_path / "mine.npz")
    plain = GenerationConfig(partition="general_supine", gender="f")
    assert "poses" not in plain.to_dict()  # a config without a pose file keeps the digest it had
    record = PoseFile.of(tmp_path / "mine.npz", noise_deg=4.0)
    with_poses = GenerationConfig(partition="general_supine", gender="f", poses=record)
    d = with_poses.to_dict()
    assert d["poses"]["sha256"] == record.sha256 and d["poses"]["noise_deg"] == 4.0
    back = GenerationConfig.from_json(with_poses.to_json())
    assert back == with_poses and back.pose_file() == record and back.digest != plain.digest
    from pressurepose.data.physics import provenance, sampler_config

    assert sampler_config(with_poses).poses == record
    assert "poses" not in provenance(plain)["sampler"]
    assert provenance(with_poses)["springs"] == "drawn pose" and "springs" not in provenance(plain)


@pytest.mark.slow
def test_generate_with_poses_makes_resumes_and_refuses_a_changed_file(tmp_path, capsys):
    pose_file(tmp_path / "mine.npz")
    args = ["generate", "--partition", "general_supine", "--gender", "f", "--count", "2", "--seed", "1",
            "--poses", str(tmp_path / "mine.npz"), "--out", str(tmp_path / "d"), "--no-progress"]
    assert main(args) == 0, capsys.readouterr().err
    assert "2/2 samples, made 1 shard(s)" in capsys.readouterr().out
    manifest = json.loads((tmp_path / "d" / "manifest.json").read_text())
    assert manifest["config"]["poses"]["path"] == str((tmp_path / "mine.npz").resolve())
    from pressurepose.data.dataset import DatasetReader

    poses = np.array([s.pose for s in DatasetReader(tmp_path / "d")])
    assert poses.shape == (2, 72)
    assert main(args) == 0 and "made 0 shard(s), kept 1" in capsys.readouterr().out  # the same config resumes
    p = np.load(tmp_path / "mine.npz")["pose"]
    np.savez(tmp_path / "mine.npz", pose=p[:1])  # the file changed under the same name
    assert main(args) == 2
    err = capsys.readouterr().err
    assert "different config" in err and "poses" in err and "another --out" in err
