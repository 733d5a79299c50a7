"""SMPL pose files read into the bed frame: postures whose answer is known, the layouts, bad files."""

import os
from pathlib import Path

import numpy as np
import pytest

from pressurepose.body.lbs_numpy import rotation_to_axis_angle
from pressurepose.errors import BadInput
from pressurepose.pose import posefile
from pressurepose.pose.posefile import PoseFile, read_poses
from pressurepose.pose.posture import posture_class, roll_angle
from pressurepose.pose.root import body_axes, root_rotation

# camera frame: x image-right, y toward the feet, z into the bed. Columns: where the SMPL model's
# left (+x), head (+y) and front (+z) point.
SUPINE_CAM = np.array([[1.0, 0, 0], [0, -1, 0], [0, 0, -1]])  # front toward the camera (-z), head -y
LEFT_DOWN_CAM = np.column_stack([[0, 0, 1.0], [0, -1.0, 0], [1.0, 0, 0]])  # left into the bed (+z)
RIGHT_DOWN_CAM = np.column_stack([[0, 0, -1.0], [0, -1.0, 0], [-1.0, 0, 0]])  # left toward the camera


def fits_file(path: Path, rotations, **extra) -> Path:
    """A fit-layout file (global_orient, body_pose) with the given camera-frame root rotations."""
    n = len(rotations)
    body = np.zeros((n, 69))
    body[:, 3 * 3] = 0.5  # left knee bent: the body pose passes through unchanged
    arrays = dict(global_orient=rotation_to_axis_angle(np.array(rotations)), body_pose=body, **extra)
    np.savez(path, **arrays)
    return path


def test_camera_frame_postures_come_out_as_they_lie(tmp_path):
    for r in (SUPINE_CAM, LEFT_DOWN_CAM, RIGHT_DOWN_CAM):
        assert np.isclose(np.linalg.det(r), 1.0)
    ps = read_poses(fits_file(tmp_path / "f.npz", [SUPINE_CAM, LEFT_DOWN_CAM, RIGHT_DOWN_CAM]))
    axes = body_axes(root_rotation(ps.pose[:, :3]))
    # supine: faces up, head toward the head end (-y in the bed frame)
    np.testing.assert_allclose(axes["face"][0], [0, 0, 1], atol=1e-9)
    np.testing.assert_allclose(axes["head"][0], [0, -1, 0], atol=1e-9)
    assert posture_class(ps.pose[0]) == "supine"
    # on the left side: the left side points down into the bed
    np.testing.assert_allclose(axes["left"][1], [0, 0, -1], atol=1e-9)
    assert posture_class(ps.pose[1]) == "left_lateral" and np.isclose(roll_angle(ps.pose[1]), np.pi / 2)
    np.testing.assert_allclose(axes["left"][2], [0, 0, 1], atol=1e-9)
    assert posture_class(ps.pose[2]) == "right_lateral"
    assert list(ps.postures) == ["supine", "left_lateral", "right_lateral"]
    np.testing.assert_array_equal(ps.pose[:, 3:], np.load(tmp_path / "f.npz")["body_pose"])


def test_frame_choice_and_the_files_own_frame(tmp_path):
    f = fits_file(tmp_path / "f.npz", [SUPINE_CAM])
    as_bed = read_poses(f, frame="bed")
    np.testing.assert_allclose(as_bed.pose[0, :3], np.load(f)["global_orient"][0])  # untouched
    assert posture_class(as_bed.pose[0]) != "supine"  # a camera-frame supine root read as bed frame is not
    g = fits_file(tmp_path / "g.npz", [SUPINE_CAM], frame=np.array("bed"))
    np.testing.assert_allclose(read_poses(g).pose, as_bed.pose)
    with pytest.raises(BadInput, match="frame"):
        read_poses(fits_file(tmp_path / "h.npz", [SUPINE_CAM], frame=np.array("sideways")))
    with pytest.raises(BadInput, match="frame"):
        read_poses(f, frame="sky")


def test_plain_pose_layout_is_the_bed_frame_and_optional_arrays_come_along(tmp_path):
    ps = read_poses(fits_file(tmp_path / "f.npz", [SUPINE_CAM, LEFT_DOWN_CAM], transl=np.array([[0.1, 0.2, 2.0]] * 2),
                              betas=np.ones((2, 10)), subject=np.array([3, 4]), gender=np.array(["f", "M"]),
                              posture=np.array(["supine", "left"])))
    np.testing.assert_allclose(ps.transl[0], [-0.1, 0.2, -2.0])  # turned 180 deg about y
    assert ps.subject.tolist() == [3, 4] and ps.gender.tolist() == ["f", "m"]
    assert ps.labels.tolist() == ["supine", "left"]
    np.savez(tmp_path / "plain.npz", pose=ps.pose)
    again = read_poses(tmp_path / "plain.npz")
    np.testing.assert_array_equal(again.pose, ps.pose)
    assert again.betas is None and again.subject is None
    assert len(ps.select(ps.subject == 4)) == 1 and ps.select(ps.subject == 4).labels.tolist() == ["left"]


@pytest.mark.parametrize("arrays, match", [
    ({"pose": np.zeros((2, 71))}, "pose has shape"),
    ({"pose": np.zeros(72)}, "pose has shape"),
    ({"pose": np.zeros((0, 72))}, "no poses"),
    ({"pose": np.full((1, 72), np.nan)}, "pose contains NaN"),
    ({"pose": np.array([["a"] * 72])}, "pose holds"),
    ({"global_orient": np.zeros((2, 3))}, "neither pose"),
    ({"global_orient": np.zeros((2, 3)), "body_pose": np.zeros((3, 69))}, "body_pose has shape"),
    ({"pose": np.zeros((2, 72)), "transl": np.zeros((2, 2))}, "transl has shape"),
    ({"pose": np.zeros((2, 72)), "subject": np.array([1.5, 2])}, "subject holds fractions"),
    ({"pose": np.zeros((2, 72)), "gender": np.array(["f", "x"])}, "gender holds"),
    ({"pose": np.zeros((2, 72)), "posture": np.array([1, 2])}, "posture is"),
])
def test_bad_files_name_the_file_and_the_field(tmp_path, arrays, match):
    path = tmp_path / "bad.npz"
    np.savez(path, **arrays)
    with pytest.raises(BadInput, match=match) as exc:
        read_poses(path)
    assert "bad.npz" in str(exc.value)


def test_unreadable_files(tmp_path):
    with pytest.raises(BadInput, match="does not exist"):
        read_poses(tmp_path / "none.npz")
    (tmp_path / "text.npz").write_text("pose = 1")
    with pytest.raises(BadInput, match="text.npz"):
        read_poses(tmp_path / "text.npz")
    np.savez(tmp_path / "obj.npz", pose=np.array([{"a": 1}], dtype=object))
    with pytest.raises(BadInput, match="obj.npz"):  # read without unpickling
        read_poses(tmp_path / "obj.npz")


def test_pose_file_record_refuses_a_changed_file(tmp_path):
    path = tmp_path / "p.npz"
    np.savez(path, pose=np.zeros((2, 72)))
    record = PoseFile.of(path, noise_deg=2.0)
    assert record.path == str(path.resolve()) and len(record.sha256) == 64
    d = {"path": record.path, "sha256": record.sha256, "frame": "auto", "noise_deg": 2.0}
    assert PoseFile.from_dict(d) == record
    assert len(record.poses()) == 2
    np.savez(path, pose=np.ones((2, 72)))
    np.testing.assert_array_equal(record.poses().pose, 0.0)  # a process that read it keeps what it read
    posefile._load.cache_clear()  # as a new worker process
    with pytest.raises(BadInput, match="has changed"):
        record.poses()
    with pytest.raises(BadInput, match="noise"):
        PoseFile(record.path, record.sha256, noise_deg=-1.0)
    with pytest.raises(BadInput, match="record"):
        PoseFile.from_dict({"path": record.path})


FITS = os.environ.get("PRESSUREPOSE_SLP_FITS", "")


@pytest.mark.skipif(not FITS or not Path(FITS).is_file(), reason="no SMPL fits to SLP ($PRESSUREPOSE_SLP_FITS)")
def test_the_slp_fits_lie_as_labelled():
    ps = read_poses(FITS)
    assert len(ps) == 3600 and ps.pose.shape == (3600, 72)
    classes = ps.postures
    for label, cls in (("supine", "supine"), ("left", "left_lateral"), ("right", "right_lateral")):
        share = np.mean(classes[ps.labels == label] == cls)
        assert share > 0.85, (label, share)
