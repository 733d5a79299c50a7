"""Error metrics of the paper (section 5.4, Table 2) and its mean-pose baseline.

* MPJPE: mean Euclidean error over the 24 joints, per sample.
* v2v: mean Euclidean error over all mesh vertices (estimate and truth share a topology).
* 3DVPE (3D vertex-point error) between a mesh and a point cloud seen by a camera above the bed:
  the mean of (a) the distance of each camera-facing mesh vertex to its nearest cloud point,
  weighted by the mean area of the vertex's faces, and (b) the distance of each cloud point to its
  nearest camera-facing vertex; the cloud is downsampled to 1 cm and both are clipped to the mat.
* The baseline "BL": a body of mean shape (betas 0), supine, centred on the mat, legs straight and
  arms straight along the body, compared with every true pose.

Numpy functions; metres in, metres out (reports convert to cm).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

ARM_DOWN_DEG = 80.0  # shoulder rotation of the baseline's straight arms (90 would press them into the hips)


def mpjpe(pred: np.ndarray, true: np.ndarray) -> np.ndarray:
    """Mean per-joint position error (N,), metres; pred and true (N, J, 3)."""
    return np.linalg.norm(np.asarray(pred, np.float64) - np.asarray(true, np.float64), axis=-1).mean(-1)


def v2v(pred_verts: np.ndarray, true_verts: np.ndarray) -> np.ndarray:
    """Mean vertex-to-vertex error (N,), metres; (N, V, 3) meshes of one topology."""
    p, t = np.asarray(pred_verts), np.asarray(true_verts)
    if p.shape != t.shape:
        raise ValueError(f"v2v needs meshes of one topology; got {p.shape} and {t.shape}")
    return mpjpe(p, t)


# ---------------------------------------------------------------------------------------- baseline
def baseline_pose() -> np.ndarray:
    """(72,) SMPL pose of the baseline: supine with the head at row 0, limbs straight, arms along
    the body."""
    import torch

    from pressurepose.body.joints import JOINT_NAMES
    from pressurepose.net.rotations import euler_to_root_axis_angle

    pose = np.zeros(72)
    pose[:3] = euler_to_root_axis_angle(torch.zeros(3, dtype=torch.float64)).numpy()
    a = np.deg2rad(ARM_DOWN_DEG)  # SMPL shoulder z: + raises the left arm, - the right (pose.limits)
    pose[3 * JOINT_NAMES.index("left_shoulder") + 2] = -a
    pose[3 * JOINT_NAMES.index("right_shoulder") + 2] = a
    return pose


def baseline_body(forward, grid, num_betas: int = 10) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """The baseline body on ``grid`` (a MatSpec): (betas (S,), pose (72,), transl (3,)) with the
    mesh's bounding box centred on the mat and its lowest point on the unloaded mattress (z = 0).

    forward: ``(betas (1, S), pose (1, 72), transl (1, 3)) -> (verts (1, V, 3), joints)``, e.g. a
    BodyModel's ``forward``."""
    betas = np.zeros(num_betas)
    pose = baseline_pose()
    verts, _ = forward(betas[None], pose[None], np.zeros((1, 3)))
    v = verts[0]
    width, length = grid.size_m
    centre = (v.min(0) + v.max(0)) / 2
    transl = np.array([width / 2 - centre[0], length / 2 - centre[1], -v[:, 2].min()])
    return betas, pose, transl


# ---------------------------------------------------------------------------------------- 3DVPE
def downsample_points(points: np.ndarray, voxel: float = 0.01) -> np.ndarray:
    """Mean point of each occupied ``voxel``-sized cube, (P', 3)."""
    pts = np.asarray(points, np.float64)
    if len(pts) == 0:
        return pts
    keys = np.floor(pts / voxel).astype(np.int64)
    _, inverse, counts = np.unique(keys, axis=0, return_inverse=True, return_counts=True)
    sums = np.zeros((len(counts), 3))
    np.add.at(sums, inverse.reshape(-1), pts)
    return sums / counts[:, None]


@dataclass
class VertexPointError:
    """3DVPE and its two halves (metres): ``mesh_to_cloud`` (area-weighted), ``cloud_to_mesh``."""

    value: float
    mesh_to_cloud: float
    cloud_to_mesh: float
    vertices_used: int
    points_used: int


def vertex_point_error(verts: np.ndarray, faces: np.ndarray, points: np.ndarray, camera: np.ndarray,
                       bounds: tuple[float, float, float, float], voxel: float = 0.01) -> VertexPointError:
    """3DVPE of one mesh (verts (V, 3), faces (F, 3), outward winding) against a point cloud
    (P, 3) seen from ``camera`` (3,), all in the bed frame; ``bounds`` = (x_min, x_max, y_min,
    y_max) of the mat to clip both to; ``voxel``: the cloud's downsampling (paper 1 cm)."""
    from scipy.spatial import cKDTree

    v = np.asarray(verts, np.float64)
    f = np.asarray(faces, np.int64)
    tri = v[f]
    normal = np.cross(tri[:, 1] - tri[:, 0], tri[:, 2] - tri[:, 0])
    area = 0.5 * np.linalg.norm(normal, axis=1)
    facing = np.einsum("fc,fc->f", normal, np.asarray(camera, np.float64) - tri.mean(1)) > 0
    n_faces = np.zeros(len(v))
    area_sum = np.zeros(len(v))
    np.add.at(n_faces, f.reshape(-1), 1.0)
    np.add.at(area_sum, f.reshape(-1), np.repeat(area, 3))
    seen = np.zeros(len(v), bool)
    seen[f[facing].reshape(-1)] = True

    def inside(p):
        x0, x1, y0, y1 = bounds
        return (p[:, 0] >= x0) & (p[:, 0] <= x1) & (p[:, 1] >= y0) & (p[:, 1] <= y1)

    keep = seen & inside(v)
    cloud = downsample_points(np.asarray(points, np.float64), voxel)
    cloud = cloud[inside(cloud)] if len(cloud) else cloud
    if keep.sum() == 0 or len(cloud) == 0:
        raise ValueError("3DVPE needs camera-facing mesh vertices and cloud points on the mat")
    weight = area_sum[keep] / np.maximum(n_faces[keep], 1)
    d_mesh, _ = cKDTree(cloud).query(v[keep])
    d_cloud, _ = cKDTree(v[keep]).query(cloud)
    m2c = float(np.sum(weight * d_mesh) / np.sum(weight))
    c2m = float(np.mean(d_cloud))
    return VertexPointError((m2c + c2m) / 2, m2c, c2m, int(keep.sum()), len(cloud))
