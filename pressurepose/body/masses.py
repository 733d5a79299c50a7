"""Per-capsule masses and inertias for the capsule ragdoll.

Total mass = rest mesh volume x 1000 kg/m^3 (``BodyModel.mass``). It is split into body segments by
Tozeren's fractions (Human Body Dynamics, 1999; paper appendix A.2; limb fractions are per side),
normalised to sum to 1 (the female table sums to 99.8 %); the neutral body uses the mean of the
female and male tables. Capsules map onto segments as follows:

============ ==================================================================
segment      capsules
============ ==================================================================
trunk        pelvis, spine, spine1, spine2, left_shoulder, right_shoulder (collars)
head_neck    neck, head
thigh        left_thigh / right_thigh
shank        left_calf / right_calf
foot         left_foot / right_foot
upper_arm    left_upper_arm / right_upper_arm
forearm      left_forearm / right_forearm
hand         left_hand / right_hand
============ ==================================================================

Within a segment of several capsules the mass is split by **shared volume**: the rest-pose capsules are
voxelised (2 mm as in the paper with ``voxel=PAPER_VOXEL``; 5 mm by default at run time, which moves
no capsule mass by more than about 1.5 % on the shipped models) and a voxel inside k capsules (of any
segment) gives 1/k of its volume to each. Each capsule's mass is then spread uniformly over its own
solid (cylinder + two hemispheres), so its centre of mass is the capsule centre (``com`` = 0 in the
capsule frame) and its inertia about the centre, in the capsule frame (axis = local z), is the
analytic one of :func:`capsule_inertia`. :func:`joint_frame_mass_properties` turns both into the
capsule's rest joint frame (what a rigid body riding on the joint needs).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from pressurepose.body.capsules import (
    NUM_CAPSULES,
    Capsules,
    capsule_endpoints,
    capsules_for,
    check_betas,
)
from pressurepose.body.mesh import mesh_volume
from pressurepose.body.model import canonical_gender
from pressurepose.errors import BadInput

SEGMENT_FRACTIONS: dict[str, dict[str, float]] = {  # % of body mass, Tozeren 1999 (paper appendix A.2)
    "female": {"trunk": 50.8, "head_neck": 9.4, "thigh": 8.3, "shank": 5.5, "foot": 1.2,
               "upper_arm": 2.7, "forearm": 1.6, "hand": 0.5},
    "male": {"trunk": 48.3, "head_neck": 7.1, "thigh": 10.5, "shank": 4.5, "foot": 1.5,
             "upper_arm": 3.3, "forearm": 1.9, "hand": 0.6},
}
CAPSULE_SEGMENTS: tuple[str, ...] = (
    "trunk", "thigh", "thigh", "trunk", "shank", "shank", "trunk", "foot", "foot", "trunk",
    "head_neck", "trunk", "trunk", "head_neck", "upper_arm", "upper_arm", "forearm", "forearm",
    "hand", "hand",
)
PAPER_VOXEL = 0.002  # the paper's voxel size for sharing overlaps (m)
# Default at run time: on the shipped models it moves no capsule mass by more than about 1.5 % from the
# 2 mm result and is about 8 times faster (benchmarks/bench_body.py, docs/RESULTS.md).
RUNTIME_VOXEL = 0.005


@dataclass(frozen=True, eq=False)
class CapsuleMasses:
    """Mass properties of the 20 capsules of one body.

    mass: (20,) kg; inertia: (20, 3, 3) kg m^2 about each capsule's centre in its capsule frame;
    com: (20, 3) m, centre of mass in the capsule frame; total: body mass, kg (= mass.sum());
    voxel: the voxel size (m) used to share overlapping volume.
    """

    mass: np.ndarray
    inertia: np.ndarray
    com: np.ndarray
    total: float
    voxel: float


def _segment_groups() -> np.ndarray:
    """(20,) id of each capsule's segment instance: the trunk and head_neck one each, limbs one per side."""
    names = [s if s in ("trunk", "head_neck") else f"{s}:{k}" for k, s in enumerate(CAPSULE_SEGMENTS)]
    return np.unique(names, return_inverse=True)[1]


def segment_fractions(gender: str) -> np.ndarray:
    """(20,) share of body mass of each capsule's segment (per side for limbs), summing to 1 over segments."""
    g = canonical_gender(gender)
    tables = [SEGMENT_FRACTIONS[g]] if g in SEGMENT_FRACTIONS else list(SEGMENT_FRACTIONS.values())
    frac = {s: np.mean([t[s] for t in tables]) for s in tables[0]}
    per_capsule = np.array([frac[s] for s in CAPSULE_SEGMENTS])
    # every segment counted once per side: trunk and head_neck once, limbs twice
    total = sum(frac[s] * (1 if s in ("trunk", "head_neck") else 2) for s in frac)
    return per_capsule / total


def capsule_inertia(mass, radius, length) -> np.ndarray:
    """Inertia (..., 3, 3) of uniform solid capsules about their centre, axis along local z.

    mass kg, radius and length (cylinder part) m, broadcastable. Cylinder plus two hemispheres, each
    hemisphere moved from its own centre of mass (3 r / 8 from its flat face) by the parallel-axis theorem.
    """
    m, r, L = np.broadcast_arrays(*(np.asarray(a, dtype=np.float64) for a in (mass, radius, length)))
    v_cyl = np.pi * r**2 * L
    v_hemi = 2.0 / 3.0 * np.pi * r**3
    rho = m / (v_cyl + 2.0 * v_hemi)
    m_cyl, m_hemi = rho * v_cyl, rho * v_hemi
    i_axial = 0.5 * m_cyl * r**2 + 2.0 * (2.0 / 5.0) * m_hemi * r**2
    # hemisphere about its own centre of mass (perpendicular): 2/5 m r^2 - m (3r/8)^2 = 83/320 m r^2
    d = 0.5 * L + 3.0 / 8.0 * r
    i_perp = m_cyl * (L**2 / 12.0 + r**2 / 4.0) + 2.0 * m_hemi * (83.0 / 320.0 * r**2 + d**2)
    out = np.zeros(m.shape + (3, 3))
    out[..., 0, 0] = out[..., 1, 1] = i_perp
    out[..., 2, 2] = i_axial
    return out


def _inside(ends: np.ndarray, radius: float, axes: tuple[np.ndarray, np.ndarray, np.ndarray]) -> np.ndarray:
    """Boolean grid (nx, ny, nz): which points of the separable grid ``axes`` lie in the capsule."""
    a, b = ends
    L = float(np.linalg.norm(b - a))
    u = ((b - a) / L if L > 0 else np.zeros(3)).astype(np.float32)
    # float32: coordinates relative to the capsule end, so rounding is far below a voxel
    x, y, z = ((axes[i] - a[i]).astype(np.float32) for i in range(3))
    proj = x[:, None, None] * u[0] + y[None, :, None] * u[1] + z[None, None, :] * u[2]
    r2 = (x * x)[:, None, None] + (y * y)[None, :, None] + (z * z)[None, None, :]
    s = np.clip(proj, 0.0, L)
    return r2 - 2.0 * s * proj + s * s <= radius * radius


def shared_volumes(ends: np.ndarray, radius: np.ndarray, voxel: float = PAPER_VOXEL,
                   which=None) -> np.ndarray:
    """Volume (len(which),) m^3 of capsules ``which`` with overlaps shared out.

    ends: (K, 2, 3) axis-segment ends, radius: (K,), in one frame; which: capsule indices (default
    all). Voxel centres lie on the lattice (i + 1/2) voxel; a voxel inside k of the K capsules gives
    voxel^3 / k to each. Only the box around the ``which`` capsules is voxelised.
    """
    ends = np.asarray(ends, dtype=np.float64)
    radius = np.asarray(radius, dtype=np.float64)
    if not voxel > 0:
        raise BadInput(f"voxel size {voxel!r} must be positive (metres)")
    which = list(range(len(radius))) if which is None else list(which)
    lo_k = ends.min(1) - radius[:, None]
    hi_k = ends.max(1) + radius[:, None]
    i_lo = np.floor(lo_k / voxel).astype(np.int64)
    i_hi = np.ceil(hi_k / voxel).astype(np.int64)
    g_lo, g_hi = i_lo[which].min(0), i_hi[which].max(0)
    count = np.zeros(tuple(g_hi - g_lo), dtype=np.uint8)
    masks = {}
    for k in range(len(radius)):
        lo, hi = np.maximum(i_lo[k], g_lo), np.minimum(i_hi[k], g_hi)
        if np.any(hi <= lo):
            continue
        axes = tuple((np.arange(lo[i], hi[i]) + 0.5) * voxel for i in range(3))
        m = _inside(ends[k], radius[k], axes)
        sl = tuple(slice(lo[i] - g_lo[i], hi[i] - g_lo[i]) for i in range(3))
        count[sl] += m
        if k in which:
            masks[k] = (sl, m)
    out = np.zeros(len(which))
    for n, k in enumerate(which):
        sl, m = masks[k]
        out[n] = np.sum(1.0 / count[sl][m]) * voxel**3
    return out


def joint_frame_mass_properties(masses: CapsuleMasses, caps: Capsules) -> tuple[np.ndarray, np.ndarray]:
    """Centre of mass (20, 3) and inertia about it (20, 3, 3) in each capsule's rest joint frame
    (origin at the joint, axes along the z-up world axes at rest): what a rigid body riding on the
    joint needs, e.g. a MuJoCo body whose frame is the joint's."""
    R = caps.rest_transform[:, :3, :3]
    com = caps.center + np.einsum("kij,kj->ki", R, masses.com)
    return com, R @ masses.inertia @ np.swapaxes(R, 1, 2)


def segment_masses(body, betas, gender: str | None = None, voxel: float = RUNTIME_VOXEL,
                   caps: Capsules | None = None) -> CapsuleMasses:
    """Masses and inertias of the 20 capsules of ``body`` with shape ``betas`` (S,).

    gender: segment-fraction table (f, m or n; default the body's); voxel: voxel size (m) for sharing
    overlapping volume within the trunk and head+neck segments (``PAPER_VOXEL`` = 2 mm for the paper's
    grid; the default ``RUNTIME_VOXEL`` = 5 mm is about 8 times faster and within about 1.5 % of it); caps: the
    capsules (default :func:`capsules_for`). The masses sum to ``body.mass(betas)``.
    """
    betas = check_betas(body, betas)
    caps = capsules_for(body, betas) if caps is None else caps
    verts, joints = body.rest(betas[None])
    total = 1000.0 * float(mesh_volume(verts, body.faces)[0])  # = body.mass(betas), one pass fewer
    if not total > 0:
        raise BadInput(f"body volume for these betas is {total / 1000.0:.4g} m^3; the mesh must be closed "
                       "and outward-facing")
    frac = segment_fractions(body.gender if gender is None else gender)
    group = _segment_groups()
    shared = [k for k in range(NUM_CAPSULES) if np.sum(group == group[k]) > 1]
    vol = np.ones(NUM_CAPSULES)
    eye = np.broadcast_to(np.eye(3), (1, body.num_joints, 3, 3))
    vol[shared] = shared_volumes(capsule_endpoints(caps, joints, eye)[0], caps.radius, voxel, shared)
    group_vol = np.array([vol[group == g].sum() for g in group])
    mass = total * frac * vol / group_vol
    return CapsuleMasses(mass=mass, inertia=capsule_inertia(mass, caps.radius, caps.length),
                         com=np.zeros((NUM_CAPSULES, 3)), total=total, voxel=float(voxel))
