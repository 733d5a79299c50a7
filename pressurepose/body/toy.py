"""A small closed-form 24-joint body in SMPL format, for fast tests and examples.

Each joint owns one box running from the joint toward its child (a cube at end joints), skinned
rigidly to that joint, with rest joints near SMPL's mean T-pose (``TOY_REST_JOINTS`` are in the
z-up project frame; the arrays are stored in SMPL's y-up model frame, as every body model is). It has 192 vertices, exact
joint regression (each joint is the mean of its box's four base corners) and simple shape
directions: beta 0 scales the whole body by 5 % per unit, beta 1 widens it across (x) by 5 %, the
others are small fixed deformations. It is not a human surface: use the shipped models for that.
"""

from __future__ import annotations

import numpy as np

from pressurepose.body.joints import NUM_BETAS, NUM_JOINTS, PARENTS
from pressurepose.body.lbs_numpy import Y_UP_TO_Z_UP
from pressurepose.body.smpl_io import SmplArrays

# Approximate rest joints of SMPL's mean body, in the project frame (z up, facing -y, left = +x), m.
TOY_REST_JOINTS = np.array([
    [0.000, -0.028, -0.223], [0.070, -0.021, -0.314], [-0.068, -0.023, -0.314], [-0.004, -0.001, -0.114],
    [0.103, -0.010, -0.700], [-0.106, -0.015, -0.704], [0.002, -0.008, 0.028], [0.090, 0.033, -1.120],
    [-0.089, 0.029, -1.123], [0.002, -0.025, 0.082], [0.116, -0.088, -1.179], [-0.112, -0.092, -1.179],
    [-0.001, 0.014, 0.291], [0.074, 0.006, 0.197], [-0.075, 0.010, 0.197], [0.005, -0.038, 0.358],
    [0.170, 0.021, 0.221], [-0.170, 0.023, 0.222], [0.424, 0.041, 0.210], [-0.427, 0.040, 0.207],
    [0.677, 0.047, 0.219], [-0.681, 0.047, 0.219], [0.759, 0.059, 0.210], [-0.763, 0.059, 0.210],
])

_BOX_FACES = np.array([  # outward-facing triangles of a box with corners indexed by bits (u, v, w)
    [0, 2, 1], [1, 2, 3], [4, 5, 6], [5, 7, 6], [0, 1, 4], [1, 5, 4],
    [2, 6, 3], [3, 6, 7], [0, 4, 2], [2, 4, 6], [1, 3, 5], [3, 7, 5],
])


def _box(start: np.ndarray, end: np.ndarray, half_width: float) -> tuple[np.ndarray, np.ndarray]:
    """8 corners (base corners first) and 12 outward triangles of a box from start to end."""
    axis = end - start
    length = np.linalg.norm(axis)
    a = axis / length
    ref = np.array([0.0, 0.0, 1.0]) if abs(a[2]) < 0.9 else np.array([1.0, 0.0, 0.0])
    u = np.cross(a, ref)
    u /= np.linalg.norm(u)
    v = np.cross(a, u)
    corners = np.array([start + (2 * ((i >> 0) & 1) - 1) * half_width * u
                        + (2 * ((i >> 1) & 1) - 1) * half_width * v + ((i >> 2) & 1) * axis
                        for i in range(8)])
    faces = _BOX_FACES.copy()
    # make the winding outward whatever the handedness of (u, v, a)
    if np.dot(np.cross(u, v), a) < 0:
        faces = faces[:, ::-1]
    return corners, faces


def toy_body_arrays() -> SmplArrays:
    """The toy body as :class:`SmplArrays` (192 vertices, 24 joints, 10 betas, 288 faces)."""
    children = {j: [c for c in range(NUM_JOINTS) if PARENTS[c] == j] for j in range(NUM_JOINTS)}
    verts, faces, weights, jreg = [], [], [], np.zeros((NUM_JOINTS, 8 * NUM_JOINTS))
    for j in range(NUM_JOINTS):
        start = TOY_REST_JOINTS[j]
        if children[j]:
            end = TOY_REST_JOINTS[children[j]].mean(0)
            if np.linalg.norm(end - start) < 0.03:
                end = start + np.array([0.0, 0.0, 0.05])
        else:
            end = start + 0.06 * (start - TOY_REST_JOINTS[PARENTS[j]]) / np.linalg.norm(
                start - TOY_REST_JOINTS[PARENTS[j]])
        c, f = _box(start, end, 0.03)
        faces.append(f + 8 * j)
        verts.append(c)
        w = np.zeros((8, NUM_JOINTS))
        w[:, j] = 1.0
        weights.append(w)
        jreg[j, 8 * j: 8 * j + 4] = 0.25
    v = np.concatenate(verts) @ Y_UP_TO_Z_UP  # stored in SMPL's y-up model frame, like SMPL
    n_v = len(v)
    shapedirs = np.zeros((n_v, 3, NUM_BETAS))
    shapedirs[:, :, 0] = 0.05 * v
    shapedirs[:, 0, 1] = 0.05 * v[:, 0]  # x is across the body in both frames
    rng = np.random.default_rng(0)
    shapedirs[:, :, 2:] = 0.002 * rng.standard_normal((n_v, 3, NUM_BETAS - 2))
    return SmplArrays(
        v_template=v,
        shapedirs=shapedirs,
        posedirs=np.zeros((n_v, 3, 9 * (NUM_JOINTS - 1))),
        J_regressor=jreg,
        weights=np.concatenate(weights),
        parents=np.array(PARENTS),
        faces=np.concatenate(faces),
        meta={"gender": "neutral", "source": "toy"},
    )
