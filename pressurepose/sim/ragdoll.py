"""The capsule ragdoll of physics simulation #1, as MuJoCo model data.

One MuJoCo body per capsule (the 20 SMPLify capsules of :mod:`pressurepose.body.capsules`), in SMPL's
kinematic tree; the root (pelvis) hangs on a free joint, knees and elbows on hinges, every other joint
is a ball. Each body carries its capsule as a geom with the capsule's mass and inertia
(:mod:`pressurepose.body.masses`), joint springs that rest at the *home pose* (arms at the sides,
legs straight) and damping 15 x stiffness (paper appendix A.2; their numbers:
:mod:`pressurepose.sim.springs`).

Frames. MuJoCo's world is the bed frame (z up). The body frames are the capsules' *rest joint
frames* moved with the body: origin at the joint, axes parallel to the z-up world axes when the body
is in its rest T-pose (the frames of ``Capsules.rest_transform``). With ``Q = Y_UP_TO_Z_UP``, an SMPL
local rotation ``R_j`` (y-up model frame) is the MuJoCo local rotation ``Q R_j Q^T``, so as rotation
vectors ``w_j = Q r_j`` (:func:`smpl_to_local`, :func:`local_to_smpl`); the root's world rotation is
``Q R_0 Q^T`` and the root body sits at the root joint's world position ``Q J_0 + transl``.

Joint limits (``pressurepose.pose.limits``) are per SMPL axis of the local axis-angle. Hinges take
theirs as MuJoCo joint ranges. A MuJoCo ball joint can only limit a cone, so ball joints get a
penalty torque outside the per-axis box instead (:func:`limit_torques`, applied by the settle loop):
the exact gradient of ``k/2 |r - clip(r, lower, upper)|^2``, stiff enough to hold a leg's weight
within a few degrees, soft enough for the explicit step.

Trunk contact. The four trunk capsules (pelvis, spine, spine1, spine2) lie across the body, and the
fitted ones reach past the sides of the body's mesh (1-6 cm for the average female and male, up to
9 cm over shapes: their round caps stand in for the hips' and shoulders' bulk). Lying on its side, a
body would rest on those caps, outside its own surface, with its centre of mass raised by as much
above a round support: of 436 lateral starts of ``general`` (two seeds, 200 bodies each per gender)
73 % rolled over. So each trunk capsule's *contact* geom is shortened to the mesh's half-width
around it (:func:`~pressurepose.body.contact.trunk_contact_lengths`; then 59 % rolled); its mass and inertia, and the capsule
the settle reports, stay the fitted capsule's.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import mujoco
import numpy as np

from pressurepose.body.capsules import (
    CAPSULE_JOINTS,
    CAPSULE_NAMES,
    NUM_CAPSULES,
    Capsules,
    capsules_for,
)
from pressurepose.body.contact import CHECKED_DEFAULT, trunk_contact_lengths
from pressurepose.body.joints import NUM_JOINTS, PARENTS
from pressurepose.body.lbs_numpy import Y_UP_TO_Z_UP, shaped_rest
from pressurepose.body.masses import (
    CapsuleMasses,
    joint_frame_mass_properties,
    segment_masses,
)
from pressurepose.body.model import canonical_gender
from pressurepose.errors import BadInput
from pressurepose.sim.springs import (
    DAMPING_PER_STIFFNESS_S,
    MEAN_MASS_KG,
    MEAN_STIFFNESS,
    NECK_JOINTS,
    RELAXED_NECK_DAMPING_S,
    RELAXED_NECK_STIFFNESS,
    RELAXED_SPINE_STIFFNESS,
    SPINE_JOINTS,
)

Q = Y_UP_TO_Z_UP

# hinge joints: SMPL joint -> SMPL local axis (knees x, elbows y), as in pressurepose.pose.limits
HINGE_AXIS = {4: 0, 5: 0, 18: 1, 19: 1}
# Collision bits: the bed's cells collide with every capsule; capsules of the distal limbs collide
# with every other capsule but their parent's and children's (MuJoCo filters parent-child pairs), as
# the pose sampler's self-collision check has it; the trunk capsules do not collide with each other
# (they overlap by design).
BED_BIT, LIMB_BIT = 1, 2
SELF_COLLIDING = CHECKED_DEFAULT  # the capsules the sampler's test and the settle's start test check


def home_pose() -> np.ndarray:
    """(72,) SMPL axis-angle of the home pose: every joint 0 except the arms lowered to the sides
    (90 degrees about SMPL's z, split 1 : 2 between collar and shoulder as the sampler splits it)."""
    pose = np.zeros((NUM_JOINTS, 3))
    for collar, shoulder, sign in ((13, 16, -1.0), (14, 17, 1.0)):  # left arm lowers with -z
        pose[collar, 2] = sign * np.pi / 2 / 3
        pose[shoulder, 2] = sign * np.pi / 2 * 2 / 3
    return pose.reshape(-1)


# ------------------------------------------------------------------------------ rotations

def smpl_to_local(r: np.ndarray) -> np.ndarray:
    """SMPL rotation vectors (..., 3) (y-up model frame) -> ragdoll (z-up body frame) vectors ``Q r``."""
    return np.asarray(r, dtype=np.float64) @ Q.T


def local_to_smpl(w: np.ndarray) -> np.ndarray:
    """Inverse of :func:`smpl_to_local`: ``Q^T w``."""
    return np.asarray(w, dtype=np.float64) @ Q


def rotvec_to_quat(v: np.ndarray) -> np.ndarray:
    """Unit quaternions (..., 4) (w, x, y, z; MuJoCo's order) of rotation vectors (..., 3)."""
    v = np.asarray(v, dtype=np.float64)
    theta = np.linalg.norm(v, axis=-1, keepdims=True)
    half = 0.5 * theta
    # sin(theta/2)/theta, with its series near 0
    s = np.where(theta > 1e-8, np.sin(half) / np.where(theta > 1e-8, theta, 1.0), 0.5 - theta**2 / 48.0)
    return np.concatenate([np.cos(half), s * v], axis=-1)


def quat_to_rotvec(q: np.ndarray) -> np.ndarray:
    """Rotation vectors (..., 3), angle in [0, pi], of quaternions (..., 4) (w, x, y, z), any norm."""
    q = np.asarray(q, dtype=np.float64)
    q = q * (np.where(q[..., :1] < 0, -1.0, 1.0) / np.sqrt((q * q).sum(-1, keepdims=True)))  # w >= 0: angle <= pi
    xyz = q[..., 1:]
    s = np.sqrt((xyz * xyz).sum(-1, keepdims=True))
    theta = 2.0 * np.arctan2(s, q[..., :1])
    scale = np.where(s > 1e-12, theta / np.where(s > 1e-12, s, 1.0), 2.0 / np.maximum(q[..., :1], 1e-12))
    return scale * xyz


def rotation_to_quat(R: np.ndarray) -> np.ndarray:
    """Unit quaternions (..., 4) (w, x, y, z) of rotation matrices (..., 3, 3)."""
    R = np.asarray(R, dtype=np.float64)
    flat = R.reshape(-1, 9)
    out = np.empty((flat.shape[0], 4))
    for i, m in enumerate(flat):
        mujoco.mju_mat2Quat(out[i], m)
    return out.reshape(R.shape[:-2] + (4,))


def right_jacobian_inv(w: np.ndarray) -> np.ndarray:
    """(..., 3, 3) inverse right Jacobian of SO(3) at rotation vectors w (..., 3): d log(R)/dt =
    J^-1 omega for the body-frame angular velocity omega (MuJoCo's ball-joint velocity)."""
    w = np.asarray(w, dtype=np.float64)
    theta = np.linalg.norm(w, axis=-1)[..., None, None]
    K = np.zeros(w.shape[:-1] + (3, 3))
    K[..., 0, 1], K[..., 0, 2], K[..., 1, 2] = -w[..., 2], w[..., 1], -w[..., 0]
    K[..., 1, 0], K[..., 2, 0], K[..., 2, 1] = w[..., 2], -w[..., 1], w[..., 0]
    t = np.where(theta > 1e-6, theta, 1.0)
    c = np.where(theta > 1e-6, 1.0 / t**2 - (1.0 + np.cos(t)) / (2.0 * t * np.sin(t)), 1.0 / 12.0)
    return np.eye(3) + 0.5 * K + c * (K @ K)


# ------------------------------------------------------------------------------ parameters

@dataclass(frozen=True, eq=False)
class RagdollParams:
    """Everything shape-dependent in the ragdoll of one body, per capsule k (SMPL joint ``joint[k]``).

    offset: (20, 3) m, the joint's rest position relative to its parent joint in z-up axes (the root's:
        relative to the model origin, i.e. ``Q J_0``).
    parent: (20,) index of the parent capsule, -1 for the root.
    capsule_center: (20, 3) m, capsule centre in the body frame; capsule_rot: (20, 3, 3), capsule
        frame axes (columns) in the body frame, the capsule along the local z; radius, length: (20,) m
        (length of the cylinder part).
    mass: (20,) kg; com: (20, 3) m, centre of mass in the body frame; inertia: (20, 3) kg m^2,
        principal moments about it, along the columns of inertia_rot (20, 3, 3); total_mass: kg.
    stiffness, damping: (20,) N m/rad and N m s/rad of each body's joint (0 for the root).
    lower, upper: (20, 3) rad, per-axis limits of the SMPL local axis-angle; limited: (20,) bool.
    home: (20, 3) SMPL axis-angle of the springs' rest pose.
    """

    offset: np.ndarray
    parent: np.ndarray
    capsule_center: np.ndarray
    capsule_rot: np.ndarray
    radius: np.ndarray
    length: np.ndarray
    contact_length: np.ndarray
    mass: np.ndarray
    com: np.ndarray
    inertia: np.ndarray
    inertia_rot: np.ndarray
    total_mass: float
    stiffness: np.ndarray
    damping: np.ndarray
    lower: np.ndarray
    upper: np.ndarray
    limited: np.ndarray
    home: np.ndarray


def capsule_parents() -> np.ndarray:
    """(20,) parent capsule of each capsule along SMPL's tree (-1 for the pelvis)."""
    index = {j: k for k, j in enumerate(CAPSULE_JOINTS)}
    out = []
    for j in CAPSULE_JOINTS:
        p = PARENTS[j]
        while p >= 0 and p not in index:
            p = PARENTS[p]
        out.append(index[p] if p >= 0 else -1)
    return np.array(out)


def ragdoll_params(body, betas, gender: str | None = None, *, caps: Capsules | None = None,
                   masses: CapsuleMasses | None = None, limits=None, relaxed_neck: bool = True,
                   spine_stiffness: float | None = RELAXED_SPINE_STIFFNESS) -> RagdollParams:
    """The ragdoll of ``body`` with shape ``betas`` (S,).

    gender: the mass table and the mean mass that scales the joint stiffness (default the body's);
    caps, masses: precomputed capsules / masses (default :func:`capsules_for`, :func:`segment_masses`);
    limits: a ``pressurepose.pose.limits.JointLimits`` (default the nominal ``joint_limits()``).
    relaxed_neck: soft neck and head joints
    (:data:`~pressurepose.sim.springs.RELAXED_NECK_STIFFNESS`) so the head rests on the bed; False:
    the paper's stiffness.
    spine_stiffness: N m/rad of the spine1-3 joints for the average body (scaled by mass like the
    others; default :data:`~pressurepose.sim.springs.RELAXED_SPINE_STIFFNESS`); None: the paper's 200.
    """
    from pressurepose.pose.limits import joint_limits

    betas = np.asarray(betas, dtype=np.float64)
    if betas.ndim != 1:
        raise BadInput(f"betas has shape {betas.shape}; expected one shape vector (S,)")
    g = canonical_gender(body.gender if gender is None else gender)
    caps = capsules_for(body, betas) if caps is None else caps
    masses = segment_masses(body, betas, g, caps=caps) if masses is None else masses
    limits = joint_limits() if limits is None else limits
    _, J = shaped_rest(body.arrays, betas[None])
    J = J[0] @ Q.T  # rest joints, z-up, no translation
    parent = capsule_parents()
    joints = np.array(CAPSULE_JOINTS)
    offset = J[joints].copy()
    offset[parent >= 0] -= J[joints[parent[parent >= 0]]]
    scale = masses.total / MEAN_MASS_KG[g]
    stiffness = scale * MEAN_STIFFNESS[joints]
    damping = DAMPING_PER_STIFFNESS_S * stiffness
    if relaxed_neck:
        neck = np.isin(joints, NECK_JOINTS)
        stiffness[neck] = scale * RELAXED_NECK_STIFFNESS
        damping[neck] = RELAXED_NECK_DAMPING_S * stiffness[neck]
    if spine_stiffness is not None:
        if isinstance(spine_stiffness, bool) or not isinstance(spine_stiffness, (int, float, np.integer, np.floating)) \
                or not math.isfinite(spine_stiffness) or spine_stiffness <= 0:
            raise BadInput(f"spine_stiffness is {spine_stiffness!r}; expected a positive number of N m/rad or None")
        spine = np.isin(joints, SPINE_JOINTS)
        stiffness[spine] = scale * float(spine_stiffness)
        damping[spine] = DAMPING_PER_STIFFNESS_S * stiffness[spine]
    com, inertia_full = joint_frame_mass_properties(masses, caps)
    principal, axes = np.linalg.eigh(inertia_full)
    axes = axes * np.where(np.linalg.det(axes) < 0, -1.0, 1.0)[:, None, None]  # proper rotations
    return RagdollParams(
        offset=offset, parent=parent, capsule_center=caps.rest_transform[:, :3, 3].copy(),
        capsule_rot=caps.rest_transform[:, :3, :3].copy(), radius=np.asarray(caps.radius, float),
        length=np.asarray(caps.length, float), contact_length=trunk_contact_lengths(body, betas, caps),
        mass=np.asarray(masses.mass, float), com=com,
        inertia=principal, inertia_rot=axes, total_mass=float(masses.total), stiffness=stiffness,
        damping=damping,
        lower=np.asarray(limits.lower, float)[joints], upper=np.asarray(limits.upper, float)[joints],
        limited=np.asarray(limits.limited, bool)[joints],
        home=home_pose().reshape(NUM_JOINTS, 3)[joints])


# ------------------------------------------------------------------------------ MuJoCo model

def body_name(k: int) -> str:
    return CAPSULE_NAMES[k]


def add_ragdoll(spec: mujoco.MjSpec, params: RagdollParams, *, self_collision: bool = True,
                friction: float = 0.5, contact_timeconst_s: float = 0.05) -> None:
    """Add the ragdoll's bodies to ``spec`` (at the start of the world body's children: the Newton
    solver factorises faster with the ragdoll's dofs first). Body, geom and joint names are the
    capsule names. Hinge springs rest at the home pose and their ranges are the hinge limits; the ball
    joints' spring rest (a quaternion, which MJCF cannot state) is set on the compiled model by
    :func:`set_spring_pose` and their per-axis limits are left to :func:`limit_torques`. Per-sample
    data (shape, masses, springs) can be rewritten on the compiled model with :func:`write_params`.
    """
    bodies: list = []
    for k in range(NUM_CAPSULES):
        parent = spec.worldbody if params.parent[k] < 0 else bodies[params.parent[k]]
        b = parent.add_body(name=body_name(k), pos=params.offset[k].tolist())
        b.explicitinertial = True
        b.mass = float(params.mass[k])
        b.ipos = params.com[k].tolist()
        b.iquat = rotation_to_quat(params.inertia_rot[k]).tolist()
        b.inertia = params.inertia[k].tolist()
        j = int(CAPSULE_JOINTS[k])
        if params.parent[k] < 0:
            b.add_freejoint(name=body_name(k))
        elif j in HINGE_AXIS:
            axis = Q[:, HINGE_AXIS[j]]  # SMPL local axis in the z-up body frame
            lo, hi = params.lower[k, HINGE_AXIS[j]], params.upper[k, HINGE_AXIS[j]]
            b.add_joint(name=body_name(k), type=mujoco.mjtJoint.mjJNT_HINGE, axis=axis.tolist(),
                        stiffness=float(params.stiffness[k]), damping=float(params.damping[k]),
                        springref=float(params.home[k, HINGE_AXIS[j]]),
                        limited=mujoco.mjtLimited.mjLIMITED_TRUE if params.limited[k] else
                        mujoco.mjtLimited.mjLIMITED_FALSE, range=[float(lo), float(hi)])
        else:
            b.add_joint(name=body_name(k), type=mujoco.mjtJoint.mjJNT_BALL, stiffness=float(params.stiffness[k]),
                        damping=float(params.damping[k]))
        limb = CAPSULE_NAMES[k] in SELF_COLLIDING
        b.add_geom(name=body_name(k), type=mujoco.mjtGeom.mjGEOM_CAPSULE,
                   size=[float(params.radius[k]), 0.5 * float(params.contact_length[k]), 0.0],
                   pos=params.capsule_center[k].tolist(), quat=rotation_to_quat(params.capsule_rot[k]).tolist(),
                   contype=LIMB_BIT if (limb and self_collision) else 0,
                   conaffinity=BED_BIT | LIMB_BIT, condim=3, friction=[friction, 0.005, 0.0001],
                   solref=[contact_timeconst_s, 1.0])
        bodies.append(b)


@dataclass(frozen=True)
class RagdollIndex:
    """Addresses of the ragdoll in a compiled model: body, geom ids (20,); joint types (20,);
    qpos and dof addresses (20,) of each body's joint."""

    body: np.ndarray
    geom: np.ndarray
    jnt: np.ndarray
    qpos: np.ndarray
    dof: np.ndarray
    ball: np.ndarray  # capsule indices with ball joints
    hinge: np.ndarray  # capsule indices with hinges

    @staticmethod
    def of(model: mujoco.MjModel) -> "RagdollIndex":
        body = np.array([model.body(body_name(k)).id for k in range(NUM_CAPSULES)])
        geom = np.array([model.geom(body_name(k)).id for k in range(NUM_CAPSULES)])
        jnt = np.array([model.joint(body_name(k)).id for k in range(NUM_CAPSULES)])
        types = model.jnt_type[jnt]
        return RagdollIndex(body=body, geom=geom, jnt=jnt, qpos=model.jnt_qposadr[jnt].copy(),
                            dof=model.jnt_dofadr[jnt].copy(),
                            ball=np.flatnonzero(types == mujoco.mjtJoint.mjJNT_BALL),
                            hinge=np.flatnonzero(types == mujoco.mjtJoint.mjJNT_HINGE))


def write_params(model: mujoco.MjModel, index: RagdollIndex, params: RagdollParams) -> None:
    """Rewrite the shape-dependent numbers of an already compiled ragdoll (the topology is fixed),
    so one compiled bed serves every body: body offsets, capsule geoms, masses, inertias, joint springs
    and limits. Call ``mujoco.mj_setConst`` afterwards (the settle code does) for the derived constants."""
    b, g = index.body, index.geom
    model.body_pos[b] = params.offset
    a = index.qpos[0]
    model.qpos0[a: a + 3] = params.offset[0]  # the free joint's reference (and resting) position
    model.qpos_spring[a: a + 3] = params.offset[0]
    model.body_quat[b] = (1.0, 0.0, 0.0, 0.0)
    model.body_mass[b] = params.mass
    model.body_ipos[b] = params.com
    model.body_iquat[b] = rotation_to_quat(params.inertia_rot)
    model.body_inertia[b] = params.inertia
    model.geom_pos[g] = params.capsule_center
    model.geom_quat[g] = rotation_to_quat(params.capsule_rot)
    half = 0.5 * params.contact_length
    model.geom_size[g] = np.stack([params.radius, half, np.zeros_like(half)], axis=1)
    model.geom_rbound[g] = params.radius + half
    model.geom_aabb[g] = np.stack([np.zeros_like(half)] * 3 + [params.radius, params.radius, params.radius + half],
                                  axis=1)
    # no frame shortcuts: geoms and inertial frames are offset from the body frames in general
    model.geom_sameframe[g] = 0
    model.body_sameframe[b] = 0
    # each body's one-node bounding-volume tree: the capsule's box in the inertial frame
    node = model.body_bvhadr[b]
    Ri = np.swapaxes(params.inertia_rot, 1, 2)
    model.bvh_aabb[node, :3] = np.einsum("kij,kj->ki", Ri, params.capsule_center - params.com)
    model.bvh_aabb[node, 3:] = np.einsum("kij,kj->ki", np.abs(Ri @ params.capsule_rot),
                                         model.geom_aabb[g, 3:])
    model.jnt_stiffness[index.jnt] = params.stiffness
    for k in range(NUM_CAPSULES):
        j = int(CAPSULE_JOINTS[k])
        n = {mujoco.mjtJoint.mjJNT_FREE: 6, mujoco.mjtJoint.mjJNT_BALL: 3, mujoco.mjtJoint.mjJNT_HINGE: 1}[
            int(model.jnt_type[index.jnt[k]])]
        model.dof_damping[index.dof[k]: index.dof[k] + n] = params.damping[k]
        if j in HINGE_AXIS:
            a = HINGE_AXIS[j]
            model.jnt_range[index.jnt[k]] = (params.lower[k, a], params.upper[k, a])
            model.jnt_limited[index.jnt[k]] = bool(params.limited[k])
    set_spring_pose(model, index, params.home)


def set_spring_pose(model: mujoco.MjModel, index: RagdollIndex, home: np.ndarray) -> None:
    """Set the springs' rest pose ``qpos_spring`` from SMPL axis-angle (20, 3) (root row ignored).
    A hinge's spring rests at its axis component (its swing, see :func:`pose_to_qpos`, is fixed)."""
    for k in index.ball:
        model.qpos_spring[index.qpos[k]: index.qpos[k] + 4] = rotvec_to_quat(smpl_to_local(home[k]))
    for k in index.hinge:
        model.qpos_spring[index.qpos[k]] = home[k, HINGE_AXIS[int(CAPSULE_JOINTS[k])]]


def limit_torques(w: np.ndarray, lower: np.ndarray, upper: np.ndarray, stiffness: np.ndarray) -> np.ndarray:
    """Penalty torques (n, 3) on ball joints outside their per-axis limits, in MuJoCo's ball-dof
    coordinates (body-frame angular velocity), from the joints' local rotation vectors w (n, 3)
    (z-up body frame), SMPL-axis limits lower/upper (n, 3) and penalty stiffness (n,) N m/rad.

    The torque is minus the gradient of ``stiffness/2 |r - clip(r, lower, upper)|^2`` with
    ``r = Q^T w`` the SMPL axis-angle, so it does no work inside the box and is conservative outside.
    """
    r = local_to_smpl(w)
    excess = r - np.clip(r, lower, upper)
    grad_w = smpl_to_local(stiffness[:, None] * excess)  # dE/dw
    return -np.einsum("nji,nj->ni", right_jacobian_inv(w), grad_w)


class BallLimits:
    """:func:`limit_torques` on a ragdoll's limited ball joints (those with a stiffness), written into
    MuJoCo's ``qfrc_applied`` before each step, for all joints at once with arrays of fixed size.

    A joint whose rotation angle is below the distance from 0 to the nearest face of its box cannot
    be outside it, so only the others are tested; a joint inside its box gets no torque (its
    ``qfrc_applied`` entries are 0). The arithmetic is :func:`quat_to_rotvec`'s and
    :func:`limit_torques`' operation for operation, so the torques are theirs to the bit.

    The penalty is explicit and the joint's damping implicit, which is stable while
    ``dt * factor / damping-per-stiffness < 2`` (the limited joints have the paper's
    :data:`~pressurepose.sim.springs.DAMPING_PER_STIFFNESS_S`).

    params: the body's :class:`RagdollParams`; index: its :class:`RagdollIndex` in the model;
    factor: penalty stiffness per joint stiffness (``SettleConfig.limit_stiffness_factor``).
    """

    def __init__(self, params: RagdollParams, index: RagdollIndex, factor: float):
        ball = index.ball[params.limited[index.ball] & (params.stiffness[index.ball] > 0)]
        n = len(ball)
        self.qpos = index.qpos[ball][:, None] + np.arange(4)  # (n, 4) addresses of the quaternions
        self.dof = (index.dof[ball][:, None] + np.arange(3)).ravel()  # (3n,) their dofs, joint-major
        self.lower, self.upper = params.lower[ball], params.upper[ball]  # (n, 3) rad, SMPL axes
        self.k = (factor * params.stiffness[ball])[:, None]  # (n, 1) N m/rad
        inside = np.minimum(-self.lower, self.upper)
        self.safe_cos = np.cos(np.clip(inside.min(axis=1), 0.0, np.pi) / 2)  # cos(half the safe angle)
        self.active = False  # whether qfrc_applied holds a torque from the last step
        self._q = np.empty((n, 4))
        self._w = np.zeros((n, 4))  # rotation vectors in columns 0-2; column 3 stays 0 for K
        self._K = np.empty((n, 9))
        # the cross-product matrix K of w, row-major: [[0, -w2, w1], [w2, 0, -w0], [-w1, w0, 0]]
        self._k_col = np.array([3, 2, 1, 2, 3, 0, 1, 0, 3])
        self._k_sign = np.array([1.0, -1.0, 1.0, 1.0, 1.0, -1.0, -1.0, 1.0, 1.0])
        self._eye = np.eye(3)

    def apply(self, qpos: np.ndarray, qfrc_applied: np.ndarray) -> None:
        """Write the torques of the state ``qpos`` (MuJoCo's ``data.qpos``) into ``qfrc_applied``
        (``data.qfrc_applied``)."""
        q = np.take(qpos, self.qpos, out=self._q)
        check = np.abs(q[:, 0]) < self.safe_cos  # MuJoCo keeps these quaternions unit
        out = None
        if check.any():
            # quat_to_rotvec
            q = q * (np.where(q[:, :1] < 0, -1.0, 1.0) / np.sqrt((q * q).sum(-1, keepdims=True)))
            xyz = q[:, 1:]
            s = np.sqrt((xyz * xyz).sum(-1, keepdims=True))
            big = s > 1e-12
            if big.all():
                scale = 2.0 * np.arctan2(s, q[:, :1]) / s
            else:
                scale = np.where(big, 2.0 * np.arctan2(s, q[:, :1]) / np.where(big, s, 1.0),
                                 2.0 / np.maximum(q[:, :1], 1e-12))
            w = np.multiply(scale, xyz, out=self._w[:, :3])
            r = w @ Q  # local_to_smpl
            # r - clip(r, lower, upper): nonzero exactly where r is outside the box
            excess = r - np.minimum(np.maximum(r, self.lower), self.upper)
            out = (excess != 0.0).any(axis=1) & check
            if not out.any():
                out = None
        if out is None:
            if self.active:
                qfrc_applied[self.dof] = 0.0
                self.active = False
            return
        # limit_torques: minus the inverse right Jacobian's transpose times the energy's gradient in w
        grad_w = (self.k * excess) @ Q.T
        theta = np.sqrt((w * w).sum(-1))[:, None, None]
        K = np.multiply(np.take(self._w, self._k_col, axis=1, out=self._K), self._k_sign, out=self._K)
        K = K.reshape(-1, 3, 3)
        near = theta > 1e-6
        if near.all():
            c = 1.0 / theta**2 - (1.0 + np.cos(theta)) / (2.0 * theta * np.sin(theta))
        else:
            t = np.where(near, theta, 1.0)
            c = np.where(near, 1.0 / t**2 - (1.0 + np.cos(t)) / (2.0 * t * np.sin(t)), 1.0 / 12.0)
        tau = -np.einsum("nji,nj->ni", self._eye + 0.5 * K + c * (K @ K), grad_w)
        if not out.all():
            tau[~out] = 0.0
        qfrc_applied[self.dof] = tau.ravel()
        self.active = True


# ------------------------------------------------------------------------------ pose <-> qpos

def _quat_mul(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """Hamilton products (..., 4) of quaternions (w, x, y, z)."""
    aw, ax, ay, az = np.moveaxis(a, -1, 0)
    bw, bx, by, bz = np.moveaxis(b, -1, 0)
    return np.stack([aw * bw - ax * bx - ay * by - az * bz, aw * bx + ax * bw + ay * bz - az * by,
                     aw * by - ax * bz + ay * bw + az * bx, aw * bz + ax * by - ay * bx + az * bw], axis=-1)


def hinge_axes() -> dict[int, np.ndarray]:
    """Capsule index -> hinge axis (3,) in the z-up body frame."""
    return {k: Q[:, HINGE_AXIS[j]] for k, j in enumerate(CAPSULE_JOINTS) if j in HINGE_AXIS}


def split_twist(w: np.ndarray, axis: np.ndarray) -> tuple[np.ndarray, float]:
    """Swing-twist split of the rotation vector w (3,): ``quat(w) = swing * twist(angle about axis)``.

    Returns the swing quaternion (4,) and the twist angle (rad, in (-pi, pi]). For a rotation about
    ``axis`` alone the swing is the identity and the angle is the rotation's own.
    """
    q = rotvec_to_quat(w)
    s = float(q[1:] @ axis)
    angle = 2.0 * np.arctan2(s, q[0])
    angle = angle - 2.0 * np.pi if angle > np.pi else angle
    twist = np.concatenate([[np.cos(angle / 2)], np.sin(angle / 2) * axis])
    swing = _quat_mul(q, twist * np.array([1.0, -1.0, -1.0, -1.0]))
    return swing / np.linalg.norm(swing), float(angle)


def pose_to_qpos(model: mujoco.MjModel, index: RagdollIndex, params: RagdollParams, pose: np.ndarray,
                 transl: np.ndarray, qpos: np.ndarray) -> None:
    """Write the ragdoll's joints into ``qpos`` (nq,) for SMPL pose (72,) and translation (3,) (z-up).

    Also writes the swing of each hinge joint (its rotation off the hinge axis, zero for sampled
    poses) into ``model.body_quat`` of the hinge's body, so any input pose is represented exactly.
    """
    r = np.asarray(pose, dtype=np.float64).reshape(NUM_JOINTS, 3)[list(CAPSULE_JOINTS)]
    w = smpl_to_local(r)
    a = index.qpos[0]
    qpos[a: a + 3] = np.asarray(transl, dtype=np.float64) + params.offset[0]
    qpos[a + 3: a + 7] = rotvec_to_quat(w[0])
    axes = hinge_axes()
    for k in range(1, NUM_CAPSULES):
        a = index.qpos[k]
        if k in axes:
            swing, angle = split_twist(w[k], axes[k])
            model.body_quat[index.body[k]] = swing
            qpos[a] = angle
        else:
            qpos[a: a + 4] = rotvec_to_quat(w[k])


def local_rotvecs(model: mujoco.MjModel, index: RagdollIndex, qpos: np.ndarray) -> np.ndarray:
    """(20, 3) local rotation vectors (z-up body frames; the root's: world) of the ragdoll at qpos."""
    axes = hinge_axes()
    w = np.zeros((NUM_CAPSULES, 3))
    for k in range(NUM_CAPSULES):
        a = index.qpos[k]
        if k == 0:
            w[k] = quat_to_rotvec(qpos[a + 3: a + 7])
        elif k in axes:
            twist = np.concatenate([[np.cos(qpos[a] / 2)], np.sin(qpos[a] / 2) * axes[k]])
            w[k] = quat_to_rotvec(_quat_mul(model.body_quat[index.body[k]], twist))
        else:
            w[k] = quat_to_rotvec(qpos[a: a + 4])
    return w


def qpos_to_pose(model: mujoco.MjModel, index: RagdollIndex, params: RagdollParams, qpos: np.ndarray,
                 pose_in: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """SMPL pose (72,) and translation (3,) of the ragdoll at qpos (inverse of :func:`pose_to_qpos`).

    Joints without a capsule (toes, fingers) keep their values from ``pose_in`` (72,); rotation
    vectors come back with angles in [0, pi] (the same rotations as any equivalent input).
    """
    pose = np.asarray(pose_in, dtype=np.float64).reshape(NUM_JOINTS, 3).copy()
    pose[list(CAPSULE_JOINTS)] = local_to_smpl(local_rotvecs(model, index, qpos))
    a = index.qpos[0]
    transl = qpos[a: a + 3] - params.offset[0]
    return pose.reshape(-1), transl
