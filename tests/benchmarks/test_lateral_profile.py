"""The side-lying profile diagnostics against images and bodies whose answers are known."""

import numpy as np
import pytest

from benchmarks.bench_lateral_profile import first_rows, repose
from pressurepose.body import BodyModel
from pressurepose.body.toy import toy_body_arrays
from tests.eval.test_realism import _column


def test_a_shrug_lifts_the_lower_shoulder_toward_the_head_and_a_flex_moves_the_head_only():
    """On the toy body standing (z up, the head along +z): raising the lower collar moves that
    shoulder toward the head and leaves the other alone; flexing moves the head joint forward (-y),
    nothing below the neck."""
    body = BodyModel(toy_body_arrays())
    pose, betas = np.zeros(72), np.zeros(10)
    _, j0 = body.forward(betas, pose)
    j = j0[0].copy()
    j[16, 2] -= 1.0  # call the left shoulder the lower one (only the shoulders' heights are read)
    _, j2 = body.forward(betas, repose(pose, j, "shrug", 30.0))
    assert j2[0, 16, 2] > j0[0, 16, 2] + 0.01
    np.testing.assert_allclose(j2[0, 17], j0[0, 17], atol=1e-12)
    j[16, 2] += 2.0  # now the right one is lower
    _, j2 = body.forward(betas, repose(pose, j, "shrug", 30.0))
    assert j2[0, 17, 2] > j0[0, 17, 2] + 0.01
    np.testing.assert_allclose(j2[0, 16], j0[0, 16], atol=1e-12)
    _, j3 = body.forward(betas, repose(pose, j, "flex", 40.0))
    assert j3[0, 15, 1] < j0[0, 15, 1] - 0.01
    np.testing.assert_allclose(j3[0, :15], j0[0, :15], atol=1e-12)
    with pytest.raises(ValueError, match="'shrug', 'tilt' or 'flex'"):
        repose(pose, j, "twist", 10.0)


def test_first_rows_finds_the_head_end_as_recorded():
    imgs = np.stack([_column(0, 40, 10), _column(7, 40, 20)])
    imgs[1, 3, 0] = 0.5  # a faint reading above the body is not its head end
    assert first_rows(imgs).tolist() == [0, 7]


def test_head_to_shoulder_finds_the_head_centroid_and_the_shoulder_peak():
    from benchmarks.bench_lateral_profile import head_to_shoulder
    from pressurepose.mat import get_mat

    mat = get_mat("boditrak_bt3510")
    height = mat.rows * mat.pitch_row_m  # a row is 1/64 of the stature
    img = _column(11, 43, 4 + 13)  # the body from row 11, its heavy row 13 rows below the head end
    img[4:7, 12:15] = 20.0  # a head of three rows from row 4, centred 1.5 rows below the head end; a neck gap
    hs = head_to_shoulder(img[None], mat, [height])[0]
    np.testing.assert_allclose(hs, [1.5 / 64, 13.5 / 64, 12 / 64])
    assert np.isnan(head_to_shoulder(np.zeros((1, mat.rows, mat.cols)), mat, [height])).all()


def test_a_tilt_bends_the_head_toward_the_lower_shoulder():
    body = BodyModel(toy_body_arrays())
    pose, betas = np.zeros(72), np.zeros(10)
    _, j0 = body.forward(betas, pose)
    j = j0[0].copy()
    j[16, 2] -= 1.0  # the left shoulder is the lower one: the head bends toward the left (+x)
    _, j2 = body.forward(betas, repose(pose, j, "tilt", 40.0))
    assert j2[0, 15, 0] > j0[0, 15, 0] + 0.01
    np.testing.assert_allclose(j2[0, :12], j0[0, :12], atol=1e-12)


def test_a_glide_moves_the_lower_shoulder_girdle_toward_the_head_by_its_length():
    """On the toy body standing (z up, the head along +z): a 5 cm glide lifts the lower collar, its
    shoulder, elbow, wrist and hand by 5 cm along +z and leaves every other joint; combined with the
    neck's flexion it also moves the head."""
    from benchmarks.bench_lateral_profile import glide_offsets, posed_variant

    body = BodyModel(toy_body_arrays())
    pose, betas = np.zeros(72), np.zeros(10)
    _, j0 = body.forward(betas, pose)
    j = j0[0].copy()
    j[17, 2] -= 1.0  # the right shoulder is the lower one
    p, off = posed_variant(pose, j, "glide", 5.0)
    np.testing.assert_array_equal(p, pose)
    _, j2 = body.forward(betas, p, offsets=off)
    right = [14, 17, 19, 21, 23]
    np.testing.assert_allclose(j2[0, right] - j0[0, right], np.broadcast_to([0, 0, 0.05], (5, 3)), atol=1e-12)
    others = [k for k in range(24) if k not in right]
    np.testing.assert_allclose(j2[0, others], j0[0, others], atol=1e-12)
    p, off = posed_variant(pose, j, "flex40_glide", 5.0)
    _, j3 = body.forward(betas, p, offsets=off)
    assert j3[0, 15, 1] < j0[0, 15, 1] - 0.01
    np.testing.assert_allclose(j3[0, right], j2[0, right], atol=1e-12)
    with pytest.raises(ValueError, match=r"\(24, 3\)"):
        glide_offsets(np.zeros((23, 3)), 5.0)


def test_standout_reads_the_chest_higher_by_as_much_as_the_lower_shoulder_girdle_sinks():
    """The toy body (a T-pose of boxes) lying on its side rests on its lower hand. Moving the lower
    collar, and with it the arm and that hand, 5 cm toward the bed leaves the shoulder's height above
    the lowest point as it was and raises the chest's by exactly 5 cm; moving the body changes nothing."""
    from scipy.spatial.transform import Rotation

    from benchmarks.bench_lateral_profile import standout

    body = BodyModel(toy_body_arrays())
    pose, betas = np.zeros(72), np.zeros(10)
    pose[:3] = (Rotation.from_euler("x", -90, degrees=True) * Rotation.from_euler("y", -90, degrees=True)).as_rotvec()
    _, j = body.forward(betas, pose)
    assert j[0, 17, 2] < j[0, 16, 2]  # the right shoulder is the lower one
    shoulder, chest = standout(body, betas, pose, None)
    assert chest > shoulder > 0
    np.testing.assert_allclose(standout(body, betas, pose, np.array([0.3, -1.0, 2.0])), (shoulder, chest), atol=1e-12)
    offsets = np.zeros((24, 3))
    offsets[14, 0] = -0.05  # the right collar 5 cm along spine3's -x: straight down into the bed here
    _, j2 = body.forward(betas, pose, offsets=offsets)
    np.testing.assert_allclose(j2[0, 14] - j[0, 14], [0, 0, -0.05], atol=1e-12)
    np.testing.assert_allclose(standout(body, betas, pose, None, offsets), (shoulder, chest + 0.05), atol=1e-12)


def test_head_aligned_lines_images_up_by_their_head_end_and_the_figure_is_written(tmp_path):
    from benchmarks.bench_lateral_profile import head_aligned, side_by_side_figure
    from pressurepose.mat import get_mat

    mat = get_mat("boditrak_bt3510")
    imgs = np.stack([_column(3, 40, 10), _column(12, 50, 20)])
    out = head_aligned(imgs, mat, rows=30)
    assert out.shape == (2, 30, mat.cols)
    np.testing.assert_array_equal(out[0], imgs[0, 3:33])
    np.testing.assert_array_equal(out[1], imgs[1, 12:42])
    path = tmp_path / "side.png"
    side_by_side_figure(np.concatenate([imgs] * 3), np.concatenate([imgs] * 3), mat, path, n=2)
    assert path.stat().st_size > 1000


def test_widen_moves_the_lower_shoulder_girdle_away_from_the_mid_plane():
    from benchmarks.bench_lateral_profile import posed_variant

    body = BodyModel(toy_body_arrays())
    pose, betas = np.zeros(72), np.zeros(10)
    _, j0 = body.forward(betas, pose)
    for lower, chain, sign in ((16, [13, 16, 18, 20, 22], 1.0), (17, [14, 17, 19, 21, 23], -1.0)):
        j = j0[0].copy()
        j[lower, 2] -= 1.0
        p, off = posed_variant(pose, j, "widen", 4.0)
        _, j2 = body.forward(betas, p, offsets=off)
        # standing, the model's +x (the body's left) is the bed frame's +x: the left girdle moves +x, the right -x
        np.testing.assert_allclose(j2[0, chain] - j0[0, chain], np.broadcast_to([sign * 0.04, 0, 0], (5, 3)),
                                   atol=1e-12)


def test_side_lying_is_the_lateral_posture_classes_away_from_their_edges():
    from benchmarks.bench_lateral_profile import side_lying
    from pressurepose.pose.posture import posture_classes, roll_angle

    poses = np.random.default_rng(0).normal(0, 1.5, (400, 72))
    roll = np.degrees(roll_angle(poses))
    clear = np.abs(np.abs(np.abs(roll) - 90.0) - 45.0) > 1.0  # not within a degree of a class edge
    lateral = np.isin(posture_classes(poses), ("left_lateral", "right_lateral"))
    assert 50 < lateral.sum() < 350
    np.testing.assert_array_equal(side_lying(poses)[clear], lateral[clear])
