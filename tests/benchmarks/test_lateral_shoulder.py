"""The side-lying shoulder diagnostics against bodies and bones whose answers are known."""

import numpy as np
import pytest

from benchmarks.bench_lateral_shoulder import down_arm_angle, variant_bones
from pressurepose.body.capsules import CAPSULE_NAMES
from pressurepose.sim.tissue import Bones, tissue_depth


def _lying_on_right_side(elbow_dir):
    """Joints (1, 24, 3) of a body along +y lying on its right side: the right shoulder is the
    lower one; the lower elbow 0.3 m from it along ``elbow_dir``, the upper elbow straight up."""
    j = np.zeros((1, 24, 3))
    j[0, 0] = [0.0, 0.0, 0.10]        # pelvis
    j[0, 12] = [0.0, 0.5, 0.10]       # neck: the trunk's axis is +y (headward)
    j[0, 16] = [0.0, 0.45, 0.25]      # left shoulder, on top
    j[0, 17] = [0.0, 0.45, 0.05]      # right shoulder, below
    j[0, 18] = j[0, 16] + [0.0, 0.0, 0.3]
    j[0, 19] = j[0, 17] + 0.3 * np.asarray(elbow_dir, dtype=float) / np.linalg.norm(elbow_dir)
    return j


@pytest.mark.parametrize("direction, angle", [((0, 1, 0), 0.0), ((1, 0, 0), 90.0), ((0, -1, 0), 180.0),
                                              ((1, -1, 0), 135.0)])
def test_the_lower_arms_angle_to_the_trunk(direction, angle):
    assert down_arm_angle(_lying_on_right_side(direction))[0] == pytest.approx(angle, abs=1e-6)


def test_the_lower_arm_is_found_by_height_on_either_side():
    j = _lying_on_right_side((0, -1, 0))  # right arm down along the side: 180
    flipped = j.copy()
    flipped[0, [16, 17, 18, 19]] = j[0, [17, 16, 19, 18]]  # the same body on its left side
    assert down_arm_angle(flipped)[0] == pytest.approx(180.0)
    with pytest.raises(ValueError, match=r"expected \(N, 24, 3\)"):
        down_arm_angle(np.zeros((2, 23, 3)))


def _bones():
    ends = np.zeros((len(CAPSULE_NAMES), 2, 3))
    ends[:, 0, 0], ends[:, 1, 0] = -0.1, 0.1  # every capsule across x at y = 10 m apart
    ends[:, :, 1] = 10.0 * np.arange(len(CAPSULE_NAMES))[:, None]
    return Bones(ends, np.full(len(CAPSULE_NAMES), 0.02))


def test_shortening_keeps_the_midpoint_and_cuts_the_axis():
    b = _bones()
    k = CAPSULE_NAMES.index("spine")
    v = variant_bones(b, np.zeros((24, 3)), 1.0, {"spine": 0.3}, 0.0)
    assert np.allclose(v.ends[k].mean(0), b.ends[k].mean(0))
    assert np.linalg.norm(v.ends[k, 1] - v.ends[k, 0]) == pytest.approx(0.3 * 0.2)
    others = np.arange(len(CAPSULE_NAMES)) != k
    assert np.array_equal(v.ends[others], b.ends[others]) and np.array_equal(v.radius, b.radius)
    # the side of the waist lies farther from bone: 0.1 m out along the axis, 0.03 below it
    side = np.array([[0.1, b.ends[k, 0, 1], -0.03]])
    assert tissue_depth(side, b)[0] == pytest.approx(0.03 - 0.02)
    assert tissue_depth(side, v)[0] == pytest.approx(np.hypot(0.1 - 0.03, 0.03) - 0.02)
    assert variant_bones(b, np.zeros((24, 3)), 1.0, {}, 0.0).ends.tolist() == b.ends.tolist()


def test_humeral_heads_are_spheres_at_the_shoulders_scaled_with_the_body():
    b = _bones()
    joints = np.zeros((24, 3))
    joints[16], joints[17] = [0.2, 500.0, 0.0], [-0.2, 500.0, 0.0]  # far from every capsule
    v = variant_bones(b, joints, 1.1, {}, 0.035)
    assert v.ends.shape == (len(CAPSULE_NAMES) + 2, 2, 3)
    assert np.allclose(v.ends[-2:, 0], joints[[16, 17]]) and np.allclose(v.ends[-2:, 1], joints[[16, 17]])
    assert np.allclose(v.radius[-2:], 0.035 * 1.1)
    skin = np.array([[0.2, 500.0, -0.06]])  # 6 cm under the left shoulder joint
    assert tissue_depth(skin, v)[0] == pytest.approx(0.06 - 0.0385)


def test_a_supralinear_mat_keeps_the_load_and_favours_peaks():
    from benchmarks.bench_lateral_shoulder import supralinear

    img = np.zeros((2, 64, 27))
    img[0, 10, 5], img[0, 40, 5] = 40.0, 10.0
    out = supralinear(img, 2.0)
    assert np.allclose(supralinear(img, 1.0), img)
    assert out[0].sum() == pytest.approx(50.0) and np.all(out[1] == 0)  # an empty image stays empty
    assert out[0, 10, 5] / out[0, 40, 5] == pytest.approx(16.0)  # (40/10)**2
    assert supralinear(img * 10, 2.0).max() == 100.0  # clipped as the real mat is
    with pytest.raises(ValueError, match="non-negative"):
        supralinear(-img, 1.5)
