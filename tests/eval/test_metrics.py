import numpy as np
import pytest
import torch

from pressurepose.body.joints import JOINT_NAMES
from pressurepose.eval.metrics import (
    baseline_body,
    baseline_pose,
    downsample_points,
    mpjpe,
    v2v,
    vertex_point_error,
)
from pressurepose.mat import custom_mat
from tests.net.synth import toy_body

torch.set_num_threads(1)


def test_mpjpe_and_v2v_hand_computed():
    true = np.zeros((2, 24, 3))
    pred = true.copy()
    pred[0, :, 0] = 0.03
    pred[0, :, 1] = 0.04  # 5 cm everywhere
    pred[1, :12, 2] = 0.10  # 10 cm on half the joints
    np.testing.assert_allclose(mpjpe(pred, true), [0.05, 0.05])
    np.testing.assert_allclose(v2v(pred[:, :5], true[:, :5]), [0.05, 0.10])
    with pytest.raises(ValueError):
        v2v(pred[:, :5], true[:, :6])


def test_baseline_is_supine_centred_straight_and_on_the_bed():
    body = toy_body()
    grid = custom_mat(64, 27, 0.0286, 0.0286)
    betas, pose, transl = baseline_body(body.forward, grid)
    assert np.all(betas == 0) and np.array_equal(pose, baseline_pose())
    verts, joints = body.forward(betas, pose, transl)
    v, j = verts[0], joints[0]
    w, length = grid.size_m
    np.testing.assert_allclose((v.min(0) + v.max(0))[:2] / 2, [w / 2, length / 2], atol=1e-9)
    assert abs(v[:, 2].min()) < 1e-9
    idx = JOINT_NAMES.index
    # supine with the head at row 0 (small y), feet toward the foot end
    assert j[idx("head"), 1] < j[idx("pelvis"), 1] < j[idx("left_ankle"), 1]
    # straight limbs: knee and elbow angles are zero, arms along the body (wrists toward the feet,
    # close to the trunk), legs straight along y
    assert np.all(pose[3 * idx("left_knee"):3 * idx("left_knee") + 3] == 0)
    for side in ("left", "right"):
        sh, wr = j[idx(f"{side}_shoulder")], j[idx(f"{side}_wrist")]
        assert wr[1] - sh[1] > 0.4 and abs(wr[0] - sh[0]) < 0.15
        hip, ank = j[idx(f"{side}_hip")], j[idx(f"{side}_ankle")]
        assert ank[1] - hip[1] > 0.7 and abs(ank[0] - hip[0]) < 0.1


def _plane(z, n=21, size=0.4, up=True):
    xs = np.linspace(0, size, n)
    gx, gy = np.meshgrid(xs, xs, indexing="ij")
    verts = np.stack([gx.ravel(), gy.ravel(), np.full(n * n, z)], 1)
    faces = []
    for i in range(n - 1):
        for k in range(n - 1):
            a, b, c, d = i * n + k, (i + 1) * n + k, (i + 1) * n + k + 1, i * n + k + 1
            faces += [[a, b, c], [a, c, d]] if up else [[a, c, b], [a, d, c]]
    return verts, np.array(faces)


def test_3dvpe_on_synthetic_point_clouds():
    rng = np.random.default_rng(0)
    verts, faces = _plane(0.10)
    camera = np.array([0.2, 0.2, 1.66])
    bounds = (0.0, 0.4, 0.0, 0.4)
    # a dense cloud 2 cm above the mesh: both halves of 3DVPE are 2 cm
    pts = np.concatenate([rng.uniform(0, 0.4, (20000, 2)), np.full((20000, 1), 0.12)], 1)
    r = vertex_point_error(verts, faces, pts, camera, bounds)
    # (distances to vertices 2 cm apart, not to the surface: slightly over 2 cm)
    assert abs(r.mesh_to_cloud - 0.02) < 2e-3 and 0.02 <= r.cloud_to_mesh < 0.022
    assert abs(r.value - 0.02) < 2e-3
    assert r.points_used <= 41 * 41  # downsampled to about 1 cm
    # a face-down sheet below (not seen by the camera) is ignored; points off the mat too
    v2, f2 = _plane(0.0, up=False)
    both_v = np.concatenate([verts, v2])
    both_f = np.concatenate([faces, f2 + len(verts)])
    off = np.concatenate([rng.uniform(0.5, 0.9, (500, 2)), np.full((500, 1), 0.5)], 1)
    r2 = vertex_point_error(both_v, both_f, np.concatenate([pts, off]), camera, bounds)
    assert abs(r2.value - r.value) < 1e-12 and r2.vertices_used == r.vertices_used


def test_3dvpe_area_weighting_undoes_uneven_vertex_density():
    rng = np.random.default_rng(1)
    fine_v, fine_f = _plane(0.10, n=41, size=0.2)    # 0.5 cm spacing on x, y in [0, 0.2]
    coarse_v, coarse_f = _plane(0.10, n=11, size=0.2)  # 2 cm spacing, moved to x in [0.2, 0.4]
    coarse_v[:, 0] += 0.2
    verts = np.concatenate([fine_v, coarse_v])
    faces = np.concatenate([fine_f, coarse_f + len(fine_v)])
    xy = rng.uniform(0, 0.4, (40000, 2))
    xy[:, 1] *= 0.5
    z = np.where(xy[:, 0] < 0.2, 0.11, 0.13)  # 1 cm above the fine half, 3 cm above the coarse half
    r = vertex_point_error(verts, faces, np.column_stack([xy, z]), np.array([0.2, 0.1, 1.66]),
                           (0.0, 0.4, 0.0, 0.2))
    # equal areas at 1 and 3 cm: 2 cm; an unweighted mean over vertices would give about 1.1 cm
    assert abs(r.mesh_to_cloud - 0.02) < 2e-3


def test_downsample_points():
    pts = np.array([[0.001, 0.001, 0.0], [0.004, 0.002, 0.0], [0.015, 0.0, 0.0]])
    out = downsample_points(pts, 0.01)
    assert len(out) == 2
    np.testing.assert_allclose(sorted(out[:, 0]), [0.0025, 0.015])
