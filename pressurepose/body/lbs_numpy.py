"""SMPL forward pass in numpy: shape and pose blend shapes, joint regression, skinning.

Pure functions over arrays. Units: metres and radians. Batched over a leading axis B.

Frames: model arrays and pose parameters are SMPL's own (y up, x = body's left, facing +z), so
official SMPL files and SMPL pose data need no conversion. The outputs of :func:`forward` and
:func:`rest_joints` are rotated by the fixed ``Y_UP_TO_Z_UP`` (+90 deg about x) into the project
frame: z up, x = body's left, the rest body facing -y.
"""

from __future__ import annotations

import numpy as np

from pressurepose.body.smpl_io import SmplArrays

# (x, y, z) -> (x, -z, y): SMPL's y-up model frame to the project's z-up frame.
Y_UP_TO_Z_UP = np.array([[1.0, 0.0, 0.0], [0.0, 0.0, -1.0], [0.0, 1.0, 0.0]])


def rodrigues(axis_angle: np.ndarray) -> np.ndarray:
    """Rotation matrices from axis-angle vectors.

    axis_angle: (..., 3) radians. Returns (..., 3, 3). Exact at zero angle.
    """
    aa = np.asarray(axis_angle, dtype=np.float64)
    theta = np.linalg.norm(aa, axis=-1, keepdims=True)
    safe = np.where(theta < 1e-12, 1.0, theta)
    k = aa / safe
    kx, ky, kz = k[..., 0], k[..., 1], k[..., 2]
    zero = np.zeros_like(kx)
    K = np.stack([zero, -kz, ky, kz, zero, -kx, -ky, kx, zero], axis=-1).reshape(aa.shape[:-1] + (3, 3))
    s = np.sin(theta)[..., None]
    c = np.cos(theta)[..., None]
    eye = np.broadcast_to(np.eye(3), K.shape)
    return eye + s * K + (1.0 - c) * (K @ K)


def rotation_to_axis_angle(R: np.ndarray) -> np.ndarray:
    """Axis-angle (..., 3) from rotation matrices (..., 3, 3); robust near 0 and pi."""
    from scipy.spatial.transform import Rotation

    R = np.asarray(R, dtype=np.float64)
    flat = Rotation.from_matrix(R.reshape(-1, 3, 3)).as_rotvec()
    return flat.reshape(R.shape[:-2] + (3,))


def shaped_rest(model: SmplArrays, betas: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Shaped rest vertices (B, V, 3) and joints (B, J, 3) in the model's own (SMPL, y-up) frame."""
    betas = np.atleast_2d(np.asarray(betas, dtype=np.float64))
    s = betas.shape[1]
    v_shaped = model.v_template[None] + np.einsum("vcs,bs->bvc", model.shapedirs[:, :, :s], betas)
    joints = np.einsum("jv,bvc->bjc", model.J_regressor, v_shaped)
    return v_shaped, joints


def rest_joints(model: SmplArrays, betas: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Shaped T-pose vertices (B, V, 3) and joints (B, J, 3) in the project's z-up frame."""
    v, j = shaped_rest(model, betas)
    return v @ Y_UP_TO_Z_UP.T, j @ Y_UP_TO_Z_UP.T


def forward_kinematics(rot: np.ndarray, joints: np.ndarray, parents: np.ndarray) -> np.ndarray:
    """World transforms of each joint.

    rot: (B, J, 3, 3) local rotations; joints: (B, J, 3) rest joint positions; parents: (J,).
    Returns G: (B, J, 4, 4), the world transform of each joint frame (rest frame = identity).
    """
    b, n_j = joints.shape[:2]
    rel = joints.copy()
    rel[:, 1:] -= joints[:, parents[1:]]
    local = np.zeros((b, n_j, 4, 4))
    local[..., :3, :3] = rot
    local[..., :3, 3] = rel
    local[..., 3, 3] = 1.0
    G = np.empty_like(local)
    G[:, 0] = local[:, 0]
    for j in range(1, n_j):
        G[:, j] = G[:, parents[j]] @ local[:, j]
    return G


def forward(model: SmplArrays, betas: np.ndarray, pose: np.ndarray,
            transl: np.ndarray | None = None) -> tuple[np.ndarray, np.ndarray]:
    """SMPL forward pass.

    betas: (B, S) with S <= model.num_betas; pose: (B, 3 J) SMPL axis-angle, the first 3 the global
    orientation; transl: (B, 3) metres or None. Returns
    vertices (B, V, 3) and joints (B, J, 3) in the z-up project frame:
    ``Y_UP_TO_Z_UP @ skinned + transl``.
    """
    betas = np.atleast_2d(np.asarray(betas, dtype=np.float64))
    pose = np.atleast_2d(np.asarray(pose, dtype=np.float64))
    b, n_j = pose.shape[0], model.num_joints
    v_shaped, J = shaped_rest(model, betas)
    rot = rodrigues(pose.reshape(b, n_j, 3))
    pose_feature = (rot[:, 1:] - np.eye(3)).reshape(b, -1)
    v_posed = v_shaped + np.einsum("vcp,bp->bvc", model.posedirs, pose_feature)
    G = forward_kinematics(rot, J, model.parents)
    A = G.copy()
    A[..., :3, 3] -= np.einsum("bjcd,bjd->bjc", G[..., :3, :3], J)
    T = np.einsum("vj,bjcd->bvcd", model.weights, A)
    verts = np.einsum("bvcd,bvd->bvc", T[..., :3, :3], v_posed) + T[..., :3, 3]
    verts = verts @ Y_UP_TO_Z_UP.T
    joints = G[..., :3, 3] @ Y_UP_TO_Z_UP.T
    if transl is not None:
        t = np.atleast_2d(np.asarray(transl, dtype=np.float64))[:, None, :]
        verts = verts + t
        joints = joints + t
    return verts, joints
