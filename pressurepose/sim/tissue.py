"""Soft tissue over bone: how far the body's surface yields where it lies on the bed.

The press (:mod:`pressurepose.sim.press`) treats each cell of the body's lower surface as a layer
of tissue of depth ``t`` over rigid bone, a spring of stiffness ``E A / t`` (``E`` the bed's
``tissue_modulus_pa``, ``A`` the cell's area) in series with the mattress under it. So the
compliance a cell adds is ``t / (E A)`` (m/N), and a stack of tissue and Winkler foundation is one
spring ``1 / (1 / (k_A A) + t / (E A))``.

Tissue depth comes from the body itself: the bone of each of the 20 ragdoll capsules
(:mod:`pressurepose.body.capsules`) is a core of radius ``f`` times the capsule's radius *of the
mean body of the same stature* (a skeleton scales with height, not with weight), ``f`` the fraction
of its body part (``BedSpec.tissue_bone_fraction``, :data:`CAPSULE_PART`), around the capsule's
axis; a surface point's tissue depth is its distance to the nearest bone, clipped to
``[TISSUE_MIN_M, TISSUE_MAX_M]``. A heavier body has wider capsules over the same bone,
so thicker tissue; where the mesh bulges past its capsule (the buttocks) the tissue is thicker
still.

The fractions put the bone where anatomy has it for a body lying on the part (adult soft-tissue
depths, supine): about 5 mm of scalp over the back of the skull (head 0.93 of the head capsule's
radius), 1-2 cm over the shoulder blades (shoulder capsules 0.85), 3-4 cm of the back's muscles
beside the spine (the trunk capsules' axes run across the body at mid-depth, so one fraction
covers the whole width of the back: 0.7, which makes the midline over the spinous processes too
thick), 4-5 cm of buttock over the pelvis (0.6; the sacrum, again too thick), 1.5-2 cm of heel
pad (feet 0.6), 5-6 cm of muscle under a thigh
(femur near the axis: 0.25), 3-4 cm under a calf (0.35), 2-3 cm under the upper arm (0.45) and
1-2 cm at the forearm and hand (0.55, 0.6). They are anatomy's depths put on this mesh, not
measurements of it; a bed file may set other fractions (``BedSpec.tissue_bone_fraction``).
"""

from __future__ import annotations

from dataclasses import dataclass
from functools import lru_cache

import numpy as np

from pressurepose.body.capsules import (
    CAPSULE_NAMES,
    capsules_for,
    point_capsule_distance,
    posed_capsules,
)
from pressurepose.errors import BadInput
from pressurepose.sim.bed import BONE_PARTS, TISSUE_BONE_FRACTION, bone_fractions

# the body part (pressurepose.sim.bed.BONE_PARTS) whose bone fraction each capsule takes
CAPSULE_PART: dict[str, str] = {
    "pelvis": "pelvis", "spine": "spine", "spine1": "spine", "spine2": "spine",
    "left_shoulder": "shoulder", "right_shoulder": "shoulder", "neck": "neck", "head": "head",
    "left_thigh": "thigh", "right_thigh": "thigh", "left_calf": "calf", "right_calf": "calf",
    "left_foot": "foot", "right_foot": "foot", "left_upper_arm": "upper_arm", "right_upper_arm": "upper_arm",
    "left_forearm": "forearm", "right_forearm": "forearm", "left_hand": "hand", "right_hand": "hand",
}
_PART_OF_CAPSULE = np.array([BONE_PARTS.index(CAPSULE_PART[n]) for n in CAPSULE_NAMES])
TISSUE_MIN_M = 0.003   # skin
TISSUE_MAX_M = 0.15


@dataclass(frozen=True, eq=False)
class Bones:
    """The body's bones as K segments: ``ends`` (K, 2, 3) bed frame, metres, and ``radius`` (K,) m."""

    ends: np.ndarray
    radius: np.ndarray

    def __post_init__(self):
        ends, radius = np.asarray(self.ends, dtype=np.float64), np.asarray(self.radius, dtype=np.float64)
        if ends.ndim != 3 or ends.shape[1:] != (2, 3) or radius.shape != (len(ends),) or not len(ends):
            raise BadInput(f"bones have ends {ends.shape} and radius {radius.shape}; expected (K, 2, 3) and (K,)")
        if not (np.all(np.isfinite(ends)) and np.all(np.isfinite(radius)) and np.all(radius >= 0)):
            raise BadInput("bones must have finite ends and finite non-negative radii")
        object.__setattr__(self, "ends", ends)
        object.__setattr__(self, "radius", radius)

    def moved(self, transform: np.ndarray) -> "Bones":
        """The bones after a rigid motion ``transform`` (4, 4)."""
        return Bones(self.ends @ transform[:3, :3].T + transform[:3, 3], self.radius)


def tissue_depth(points: np.ndarray, bones: Bones) -> np.ndarray:
    """Depth (n,) m of tissue at surface points (n, 3): the distance to the nearest bone, clipped to
    [TISSUE_MIN_M, TISSUE_MAX_M]."""
    points = np.asarray(points, dtype=np.float64).reshape(-1, 3)
    if not len(points):
        return np.zeros(0)
    d = point_capsule_distance(points, bones.ends) - bones.radius[None, :]
    return np.clip(d.min(axis=1), TISSUE_MIN_M, TISSUE_MAX_M)


@lru_cache(maxsize=4)
def _mean_radii(body) -> tuple[np.ndarray, float]:
    zero = np.zeros(body.num_betas)
    return capsules_for(body, zero).radius.copy(), float(body.height(zero)[0])


@dataclass(frozen=True, eq=False)
class BoneCores:
    """A posed body's capsule axes ``ends`` (20, 2, 3) m, the mean body's capsule radii ``mean_radius``
    (20,) m and the body's stature over the mean body's ``scale``: its bones before the fractions."""

    ends: np.ndarray
    mean_radius: np.ndarray
    scale: float

    def bones(self, fraction=TISSUE_BONE_FRACTION) -> Bones:
        """The bones with each capsule's part's fraction (``fraction``: a ``BedSpec.tissue_bone_fraction``,
        a tuple in BONE_PARTS order or a dict of some parts)."""
        frac = np.asarray(bone_fractions(fraction))[_PART_OF_CAPSULE]
        return Bones(self.ends, frac * self.mean_radius * self.scale)


def bone_cores(body, betas, pose, transl) -> BoneCores:
    """The :class:`BoneCores` of a posed body (betas (S,), pose (72,), transl (3,) as
    ``BodyModel.forward``)."""
    betas = np.asarray(betas, dtype=np.float64)
    caps = capsules_for(body, betas)
    ends, _ = posed_capsules(body, caps, betas, np.asarray(pose, dtype=np.float64)[None],
                             np.asarray(transl, dtype=np.float64)[None])
    mean_r, mean_h = _mean_radii(body)
    return BoneCores(ends[0], mean_r, float(body.height(betas)[0]) / mean_h)


def body_bones(body, betas, pose, transl, fraction=TISSUE_BONE_FRACTION) -> Bones:
    """The bones of a posed body (betas (S,), pose (72,), transl (3,) as ``BodyModel.forward``) with
    the bone fractions ``fraction`` (a bed's ``tissue_bone_fraction``)."""
    return bone_cores(body, betas, pose, transl).bones(fraction)
