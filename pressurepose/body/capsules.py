"""The 20-capsule body approximation in the SMPLify layout: fitting, regressors from betas, posing.

Frames and conventions
----------------------
All positions are metres in the project's z-up frame (x = body's left, the rest body facing -y).

A capsule is a segment of length ``length`` (the cylinder part, caps excluded) swept by a sphere of
``radius``. Its **capsule frame** has the segment along the local z axis, centred at the origin:
the segment runs from (0, 0, -length/2) to (0, 0, +length/2). The local x axis is the part of a
fixed reference direction perpendicular to the axis (the body's forward direction, -y, for every
capsule except the feet, whose reference is up, +z); local y = z cross x.

``rest_transform[k]`` (4 x 4) maps capsule-frame coordinates to the **rest joint frame** of the
capsule's joint ``j = joint[k]``: origin at the joint's shaped rest position, axes parallel to the
z-up world axes (at rest every joint rotation is the identity). So for a body posed with z-up world
joint rotations ``W_j`` (3 x 3) and joint positions ``p_j``::

    world point = p_j + W_j @ (R_k @ x_capsule + t_k),   [R_k | t_k] = rest_transform[k]

i.e. the capsule's world frame is ``[W_j | p_j] @ rest_transform[k]``. ``W_j = Q R_j Q^T`` where
``R_j`` is the joint's world rotation in SMPL's own y-up model frame (``lbs_numpy.forward_kinematics``)
and ``Q = Y_UP_TO_Z_UP``. The torch layer's ``BodyOutput.rotations`` are ``Q R_j`` (not conjugated), so
there ``W_j = rotations[:, j] @ Q.T``.

Regressors (SMPLify form)
-------------------------
A regressor file (``.npz``) holds ``betas2lens`` and ``betas2rads``, each (R + 1, 20): with the
betas zero-padded to R values and a 1 appended, ``pad = [betas, 0, ..., 0, 1]``::

    lengths = pad @ betas2lens      radii = pad @ betas2rads        (metres)

which is exactly SMPLify's ``regressors_locked_normalized_{female,male,hybrid}.npz`` form (R = 300 there),
so such a file can be passed to :func:`capsules_for`. The files shipped here add the placement,
regressed the same way: ``betas2centers`` (R + 1, 60), the capsule centre relative to its joint in the
rest joint frame (20 x 3, row-major), and ``betas2axes`` (R + 1, 60), the capsule axis direction
(normalised after the product). A file without them (SMPLify's) is placed as SMPLify does: axis along
the capsule's nominal direction (:data:`NOMINAL_AXES`), the segment starting at the joint, except the
pelvis and spine capsules, which are centred on their joint.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from pressurepose.body import lbs_numpy
from pressurepose.body.lbs_numpy import Y_UP_TO_Z_UP
from pressurepose.errors import BadInput
from pressurepose.files import load_npz, save_npz_atomic

CAPSULE_NAMES: tuple[str, ...] = (
    "pelvis", "left_thigh", "right_thigh", "spine", "left_calf", "right_calf", "spine1", "left_foot",
    "right_foot", "spine2", "neck", "left_shoulder", "right_shoulder", "head", "left_upper_arm",
    "right_upper_arm", "left_forearm", "right_forearm", "left_hand", "right_hand",
)
CAPSULE_JOINTS: tuple[int, ...] = (0, 1, 2, 3, 4, 5, 6, 7, 8, 9, 12, 13, 14, 15, 16, 17, 18, 19, 20, 21)
NUM_CAPSULES = 20

# SMPL joints without a capsule whose skinned vertices join their parent's capsule: toes -> feet,
# hands (fingers) -> hand capsules on the wrists.
MERGED_INTO: dict[int, int] = {10: 7, 11: 8, 22: 20, 23: 21}

_LEFT, _RIGHT, _UP, _DOWN, _FORWARD = (1.0, 0, 0), (-1.0, 0, 0), (0, 0, 1.0), (0, 0, -1.0), (0, -1.0, 0)
# Expected axis direction of each capsule on a T-posed body (z-up frame): the axis of the torso
# capsules (across the body) and the head (up), and the placement for regressor files without one.
NOMINAL_AXES = np.array([
    _LEFT, _DOWN, _DOWN, _LEFT, _DOWN, _DOWN, _LEFT, _FORWARD, _FORWARD, _LEFT,
    _UP, _LEFT, _RIGHT, _UP, _LEFT, _RIGHT, _LEFT, _RIGHT, _LEFT, _RIGHT,
])
# The fitted axis of a limb capsule runs along its bone, from its joint to this child joint; -1: the
# nominal axis (pelvis and spine capsules lie across the body, the head capsule stands up).
AXIS_TARGETS: tuple[int, ...] = (-1, 4, 5, -1, 7, 8, -1, 10, 11, -1, 15, 16, 17, -1, 18, 19, 20, 21, 22, 23)
# capsules centred on their joint when placed SMPLify's way (the others start at the joint)
_CENTRED_ON_JOINT = (0, 3, 6, 9)
# reference direction that fixes each capsule frame's local x axis (see module docstring)
_FRAME_REFERENCE = np.array([_UP if n == _FORWARD else _FORWARD for n in map(tuple, NOMINAL_AXES)])

# Moment fit (see fit_capsules). A region open at both ends (a tube: limbs, torso slices) has
# E[rho^2] = r^2 about its axis; the head is closed at the top, more like a sphere surface, for which
# E[rho^2] = 2/3 r^2. Both have extent sqrt(12 var(s)) along the axis. The cylinder is shorter than the
# extent by CAP_INSET x r at each end: 0.5 for tubes (the caps reach half a radius past the region, into
# the neighbours), 1 for the head (its cap ends where the head ends).
_IS_HEAD = np.arange(NUM_CAPSULES) == CAPSULE_NAMES.index("head")
RADIUS_FACTOR = np.where(_IS_HEAD, np.sqrt(1.5), 1.0)
CAP_INSET = np.where(_IS_HEAD, 1.0, 0.5)


@dataclass(frozen=True, eq=False)
class Capsules:
    """Capsules of one body shape (see the module docstring for frames).

    radius: (20,) m; length: (20,) m, the cylinder part; rest_transform: (20, 4, 4) capsule frame ->
    rest joint frame; joint: (20,) int, the SMPL joint each capsule rides on; names: capsule names.
    """

    radius: np.ndarray
    length: np.ndarray
    rest_transform: np.ndarray
    joint: np.ndarray = field(default_factory=lambda: np.array(CAPSULE_JOINTS))
    names: tuple[str, ...] = CAPSULE_NAMES

    @property
    def volume(self) -> np.ndarray:
        """(20,) m^3: cylinder plus the two hemispherical caps."""
        r, L = self.radius, self.length
        return np.pi * r**2 * L + 4.0 / 3.0 * np.pi * r**3

    @property
    def center(self) -> np.ndarray:
        """(20, 3) capsule centres in their rest joint frames."""
        return self.rest_transform[:, :3, 3]

    @property
    def axis(self) -> np.ndarray:
        """(20, 3) unit axis directions in their rest joint frames."""
        return self.rest_transform[:, :3, 2]


@dataclass(frozen=True, eq=False)
class CapsuleRegressors:
    """Linear maps from betas to capsules (SMPLify form, see the module docstring).

    betas2lens, betas2rads: (R + 1, 20); betas2centers, betas2axes: (R + 1, 60) or None (then placed
    SMPLify's way); model_identity: ``BodyModel.identity`` of the model they were fitted to ('' if unknown).
    """

    betas2lens: np.ndarray
    betas2rads: np.ndarray
    betas2centers: np.ndarray | None = None
    betas2axes: np.ndarray | None = None
    model_identity: str = ""
    meta: dict = field(default_factory=dict)

    @property
    def num_betas(self) -> int:
        return self.betas2lens.shape[0] - 1


# --------------------------------------------------------------------------- helpers


def check_betas(body, betas) -> np.ndarray:
    """One shape vector (S,) with 1 <= S <= body.num_betas, finite; BadInput otherwise."""
    b = np.asarray(betas, dtype=np.float64)
    if b.ndim == 2 and b.shape[0] == 1:
        b = b[0]
    if b.ndim != 1 or not 1 <= b.shape[0] <= body.num_betas:
        raise BadInput(f"betas has shape {b.shape}; expected one shape vector (S,) with 1 <= S <= "
                       f"{body.num_betas}")
    if not np.all(np.isfinite(b)):
        raise BadInput("betas contains NaN or infinite values")
    return b


def capsule_frame(axis: np.ndarray) -> np.ndarray:
    """Rotations (20, 3, 3) whose columns are the capsule frames' x, y, z axes (z = ``axis``, (20, 3))."""
    z = axis / np.linalg.norm(axis, axis=-1, keepdims=True)
    x = _FRAME_REFERENCE - np.einsum("ki,ki->k", _FRAME_REFERENCE, z)[:, None] * z
    n = np.linalg.norm(x, axis=-1, keepdims=True)
    if np.any(n < 1e-9):
        raise BadInput("a capsule axis is parallel to its frame reference direction; the body model's "
                       "rest pose is not a T-pose")
    x = x / n
    return np.stack([x, np.cross(z, x), z], axis=-1)


def make_capsules(center: np.ndarray, axis: np.ndarray, radius: np.ndarray, length: np.ndarray) -> Capsules:
    """Capsules from centres and axes (20, 3) in the rest joint frames, radii and lengths (20,)."""
    T = np.zeros((NUM_CAPSULES, 4, 4))
    T[:, :3, :3] = capsule_frame(np.asarray(axis, dtype=np.float64))
    T[:, :3, 3] = center
    T[:, 3, 3] = 1.0
    return Capsules(radius=np.asarray(radius, dtype=np.float64), length=np.asarray(length, dtype=np.float64),
                    rest_transform=T)


def capsule_regions(body) -> np.ndarray:
    """(V,) capsule index of each vertex: the capsule of the joint with its largest skinning weight."""
    dominant = np.argmax(body.arrays.weights, axis=1)
    joint_to_capsule = np.full(body.num_joints, -1)
    joint_to_capsule[list(CAPSULE_JOINTS)] = np.arange(NUM_CAPSULES)
    for child, parent in MERGED_INTO.items():
        joint_to_capsule[child] = joint_to_capsule[parent]
    if body.num_joints != 24 or np.any(joint_to_capsule < 0):
        raise BadInput(f"body model has {body.num_joints} joints; capsules need SMPL's 24")
    return joint_to_capsule[dominant]


# --------------------------------------------------------------------------- direct fit


def vertex_areas(verts: np.ndarray, faces: np.ndarray) -> np.ndarray:
    """(V,) surface area (m^2) around each vertex: a third of each adjacent triangle's area."""
    a, b, c = verts[faces[:, 0]], verts[faces[:, 1]], verts[faces[:, 2]]
    tri = 0.5 * np.linalg.norm(np.cross(b - a, c - a), axis=1)
    return np.bincount(faces.ravel(), weights=np.repeat(tri / 3.0, 3), minlength=len(verts))


def _fit_raw(body, betas: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """Centres (20, 3) relative to their joints, unit axes (20, 3), radii (20,) and cylinder lengths
    (20,) before clipping at 0 (a smooth function of betas, which is what the regressors fit)."""
    verts, joints = body.rest(betas[None])
    verts, joints = verts[0], joints[0]
    regions = capsule_regions(body)
    # areas of the mean shape (rotation does not change them): weights fixed across shapes keep the
    # moments polynomial in betas, which the linear regressors then follow closely
    area = vertex_areas(body.arrays.v_template, body.faces)
    center, axis = np.zeros((NUM_CAPSULES, 3)), np.zeros((NUM_CAPSULES, 3))
    radius, length = np.zeros(NUM_CAPSULES), np.zeros(NUM_CAPSULES)
    for k, j in enumerate(CAPSULE_JOINTS):
        pts = verts[regions == k]
        w = area[regions == k] / area[regions == k].sum()
        if len(pts) < 4:
            raise BadInput(f"body model skins only {len(pts)} vertices mainly to joint {j} "
                           f"({CAPSULE_NAMES[k]}); a capsule needs at least 4")
        t = AXIS_TARGETS[k]
        d = NOMINAL_AXES[k] if t < 0 else joints[t] - joints[j]
        n = np.linalg.norm(d)
        if n < 1e-6:
            raise BadInput(f"joints {j} and {t} of the body model coincide; capsule {CAPSULE_NAMES[k]} "
                           "has no axis")
        d = d / n
        mu = w @ pts
        X = pts - mu
        var_axial = w @ (X @ d) ** 2
        var_perp = w @ np.sum(X * X, axis=1) - var_axial
        r = RADIUS_FACTOR[k] * np.sqrt(var_perp)
        center[k] = mu - joints[j]
        axis[k] = d
        radius[k] = r
        length[k] = np.sqrt(12.0 * var_axial) - 2.0 * CAP_INSET[k] * r
    return center, axis, radius, length


def fit_capsules(body, betas) -> Capsules:
    """Capsules fitted directly to the shaped rest mesh of ``body`` for one shape ``betas`` (S,).

    Each capsule is fitted to its region: the vertices whose dominant skinning weight is its joint
    (toes merged into the feet, fingers into the hands), each weighted by the surface area around it
    on the mean-shape mesh (so the fit does not depend on how densely the mesh is sampled). The axis
    runs along the bone (joint to child joint; across the body for the pelvis and spine capsules, up
    for the head) through the region's centroid; radius and length match the region's second moments
    about that axis: radius = sqrt(mean squared distance from the axis) (x sqrt(3/2) for the head, a
    closed end), extent along the axis sqrt(12 var), cylinder = extent - 2 CAP_INSET radius (at least
    0). Moments make the fit a smooth function of betas, so the linear regressors reproduce it closely.
    """
    betas = check_betas(body, betas)
    center, axis, radius, length = _fit_raw(body, betas)
    return make_capsules(center, axis, radius, np.maximum(length, 0.0))


# --------------------------------------------------------------------------- regressors


def regressor_path(gender: str) -> Path:
    """Path of the shipped regressor file for a gender (female, male, neutral)."""
    from pressurepose.body.model import asset_path, canonical_gender

    return asset_path(f"capsules_{canonical_gender(gender)}.npz")


def load_regressors(path: str | Path) -> CapsuleRegressors:
    """Read a regressor ``.npz`` (ours or SMPLify's); BadInput if it is not one."""
    path = Path(path)
    data = load_npz(path, "capsule regressor file")
    for key in ("betas2lens", "betas2rads"):
        if key not in data:
            raise BadInput(f"capsule regressor file {str(path)!r} has no {key!r} array")
    lens, rads = data["betas2lens"].astype(np.float64), data["betas2rads"].astype(np.float64)
    if lens.ndim != 2 or lens.shape[1] != NUM_CAPSULES or lens.shape[0] < 2 or rads.shape != lens.shape:
        raise BadInput(f"capsule regressor file {str(path)!r}: betas2lens {lens.shape} and betas2rads "
                       f"{rads.shape} must both be (R + 1, 20)")
    place = []
    for key in ("betas2centers", "betas2axes"):
        a = data.get(key)
        if a is not None and a.shape != (lens.shape[0], 3 * NUM_CAPSULES):
            raise BadInput(f"capsule regressor file {str(path)!r}: {key} has shape {a.shape}; expected "
                           f"({lens.shape[0]}, 60)")
        place.append(None if a is None else a.astype(np.float64))
    if (place[0] is None) != (place[1] is None):
        raise BadInput(f"capsule regressor file {str(path)!r} has only one of betas2centers/betas2axes")
    arrays = (lens, rads) + tuple(p for p in place if p is not None)
    if not all(np.all(np.isfinite(a)) for a in arrays):
        raise BadInput(f"capsule regressor file {str(path)!r} contains NaN or infinite values")
    identity = str(data["model_identity"]) if "model_identity" in data else ""
    meta = {k: data[k] for k in data if k.startswith("fit_")}
    return CapsuleRegressors(lens, rads, place[0], place[1], identity, meta)


def save_regressors(reg: CapsuleRegressors, path: str | Path) -> None:
    """Write regressors as ``.npz`` (no pickles), readable by :func:`load_regressors`."""
    arrays = {"betas2lens": reg.betas2lens, "betas2rads": reg.betas2rads,
              "model_identity": np.array(reg.model_identity), "capsule_names": np.array(CAPSULE_NAMES),
              "capsule_joints": np.array(CAPSULE_JOINTS)}
    if reg.betas2centers is not None:
        arrays.update(betas2centers=reg.betas2centers, betas2axes=reg.betas2axes)
    arrays.update({k: np.asarray(v) for k, v in reg.meta.items()})
    save_npz_atomic(path, **arrays)


def fit_regressors(body, num_samples: int = 200, seed: int = 0, beta_range: float = 3.0,
                   num_betas: int | None = None) -> tuple[CapsuleRegressors, np.ndarray]:
    """Least-squares regressors from direct fits over betas ~ U(-beta_range, beta_range) (seeded).

    The first ``num_betas`` (default all S) betas are sampled, the rest stay 0 (and get zero
    coefficients). Returns the regressors ((S + 1) rows) and the sampled betas (num_samples, S).
    ``reg.meta`` holds the fit's RMS and max residuals (metres; axes: unit vector difference).
    """
    rng = np.random.default_rng(seed)
    n = body.num_betas if num_betas is None else int(num_betas)
    if not 1 <= n <= body.num_betas:
        raise BadInput(f"num_betas {num_betas!r} must be between 1 and {body.num_betas}")
    betas = np.zeros((num_samples, body.num_betas))
    betas[:, :n] = rng.uniform(-beta_range, beta_range, (num_samples, n))
    fits = [_fit_raw(body, b) for b in betas]  # lengths not yet clipped at 0: smooth in betas
    A = np.hstack([betas, np.ones((num_samples, 1))])
    targets = {
        "lens": np.stack([f[3] for f in fits]),
        "rads": np.stack([f[2] for f in fits]),
        "centers": np.stack([f[0].ravel() for f in fits]),
        "axes": np.stack([f[1].ravel() for f in fits]),
    }
    coef, meta = {}, {"fit_num_samples": num_samples, "fit_seed": seed, "fit_beta_range": beta_range,
                      "fit_num_betas": n}
    for name, Y in targets.items():
        coef[name], *_ = np.linalg.lstsq(A, Y, rcond=None)
        res = A @ coef[name] - Y
        meta[f"fit_rms_{name}"] = float(np.sqrt(np.mean(res**2)))
        meta[f"fit_max_{name}"] = float(np.abs(res).max())
    reg = CapsuleRegressors(coef["lens"], coef["rads"], coef["centers"], coef["axes"], body.identity, meta)
    return reg, betas


def regressed_capsules(reg: CapsuleRegressors, betas: np.ndarray, rest_joints: np.ndarray | None = None,
                       ) -> Capsules:
    """Capsules for one shape from regressors: ``pad = [betas, 0..., 1]``, values = ``pad @ betas2*``.

    betas: (S,) with S <= reg.num_betas. Radii are floored at 1 mm and lengths at 0.
    """
    betas = np.asarray(betas, dtype=np.float64)
    if betas.ndim != 1 or betas.shape[0] > reg.num_betas:
        raise BadInput(f"betas has shape {betas.shape}; these capsule regressors take at most "
                       f"{reg.num_betas} betas")
    pad = np.concatenate([betas, np.zeros(reg.num_betas - betas.shape[0]), [1.0]])
    length = np.maximum(pad @ reg.betas2lens, 0.0)
    radius = np.maximum(pad @ reg.betas2rads, 1e-3)
    if reg.betas2centers is not None:
        center = (pad @ reg.betas2centers).reshape(NUM_CAPSULES, 3)
        axis = (pad @ reg.betas2axes).reshape(NUM_CAPSULES, 3)
        axis = axis / np.linalg.norm(axis, axis=1, keepdims=True)
    else:
        axis = NOMINAL_AXES.copy()
        center = 0.5 * length[:, None] * axis
        center[list(_CENTRED_ON_JOINT)] = 0.0
    return make_capsules(center, axis, radius, length)


def capsules_for(body, betas, regressors: CapsuleRegressors | str | Path | None = None) -> Capsules:
    """Capsules of ``body`` for one shape ``betas`` (S,) from linear regressors (a matrix product).

    regressors: a :class:`CapsuleRegressors`, the path of a regressor ``.npz`` (ours or SMPLify's),
    or None for the shipped file of the body's gender. With None, a body that is not the model the
    shipped file was fitted to (a user's SMPL file, the toy body) gets :func:`fit_capsules` instead.
    """
    betas = check_betas(body, betas)
    if regressors is None:
        path = regressor_path(body.gender)
        reg = _load_cached(str(path), path.stat().st_mtime) if path.is_file() else None
        if reg is None or reg.model_identity != body.identity:
            return fit_capsules(body, betas)
    elif isinstance(regressors, CapsuleRegressors):
        reg = regressors
    else:
        reg = load_regressors(regressors)
    return regressed_capsules(reg, betas)


_CACHE: dict[tuple[str, float], CapsuleRegressors] = {}


def _load_cached(path: str, mtime: float) -> CapsuleRegressors:
    key = (path, mtime)
    if key not in _CACHE:
        _CACHE[key] = load_regressors(path)
    return _CACHE[key]


# --------------------------------------------------------------------------- posing


def capsule_endpoints(caps: Capsules, joint_pos: np.ndarray, joint_rot: np.ndarray) -> np.ndarray:
    """World axis-segment ends (B, 20, 2, 3) from z-up world joint positions (B, 24, 3) and rotations
    (B, 24, 3, 3). End 0 is at local z = -length/2, end 1 at +length/2."""
    W = joint_rot[:, caps.joint]
    centre = joint_pos[:, caps.joint] + np.einsum("bkij,kj->bki", W, caps.center)
    axis = np.einsum("bkij,kj->bki", W, caps.axis)
    half = 0.5 * caps.length[None, :, None, None] * np.array([-1.0, 1.0])[None, None, :, None]
    return centre[:, :, None, :] + half * axis[:, :, None, :]


def joint_frames(body, betas, pose, transl=None) -> tuple[np.ndarray, np.ndarray]:
    """World joint positions (B, 24, 3) and z-up world rotations W_j (B, 24, 3, 3) of posed bodies,
    by the body model's own forward kinematics (betas (S,) or (B, S), pose (B, 72), transl (B, 3))."""
    pose = np.atleast_2d(np.asarray(pose, dtype=np.float64))
    b = np.asarray(betas, dtype=np.float64)
    if b.ndim == 1:
        b = np.broadcast_to(b, (pose.shape[0], b.shape[0]))
    betas, pose, transl = body.check_params(b, pose, transl)
    _, J = lbs_numpy.shaped_rest(body.arrays, betas)
    rot = lbs_numpy.rodrigues(pose.reshape(pose.shape[0], body.num_joints, 3))
    G = lbs_numpy.forward_kinematics(rot, J, body.parents)
    Q = Y_UP_TO_Z_UP
    W = Q @ G[..., :3, :3] @ Q.T
    pos = G[..., :3, 3] @ Q.T
    if transl is not None:
        pos = pos + transl[:, None, :]
    return pos, W


def posed_capsules(body, caps: Capsules, betas, pose, transl=None) -> tuple[np.ndarray, np.ndarray]:
    """Capsules of posed bodies: axis-segment ends (B, 20, 2, 3) in the z-up world, radii (20,).

    betas: the shape (S,) the capsules were made for (or (B, S)); pose: (B, 72) SMPL axis-angle;
    transl: (B, 3) or None. Uses the body model's forward kinematics, so it agrees with the mesh.
    """
    pos, W = joint_frames(body, betas, pose, transl)
    return capsule_endpoints(caps, pos, W), caps.radius


def point_capsule_distance(points: np.ndarray, ends: np.ndarray) -> np.ndarray:
    """Distance (N, K) from points (N, 3) to the axis segments ends (K, 2, 3) (subtract the radius for
    the distance to the capsule surface)."""
    a, b = ends[:, 0], ends[:, 1]
    ab = b - a
    ab2 = np.maximum(np.einsum("ki,ki->k", ab, ab), 1e-18)
    t = np.clip(np.einsum("nki,ki->nk", points[:, None, :] - a[None], ab) / ab2, 0.0, 1.0)
    closest = a[None] + t[..., None] * ab[None]
    return np.linalg.norm(points[:, None, :] - closest, axis=-1)
