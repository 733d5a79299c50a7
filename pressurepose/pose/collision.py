"""Self-collision of the 20 body capsules with MuJoCo's collision detection (paper appendix A.1).

A pose is rejected when a checked capsule (by default the calves, feet, forearms and hands)
penetrates any capsule that is not adjacent to it in the kinematic tree (a capsule's joint is
the other's parent or child: forearm and upper arm, forearm and hand, ... overlap by design).
One small MuJoCo model (20 mocap bodies, one capsule each, and an explicit contact pair per
checked pair) serves every body shape: capsule sizes are written into the model before each check.
"""

from __future__ import annotations

from functools import lru_cache

import mujoco
import numpy as np

from pressurepose.body.capsules import CAPSULE_JOINTS, CAPSULE_NAMES, NUM_CAPSULES
from pressurepose.body.joints import PARENTS

# capsules no sampled limb moves (spine, neck and head are held at 0 while sampling)
FIXED_CAPSULES: tuple[str, ...] = ("pelvis", "spine", "spine1", "spine2", "neck", "head")
CHECKED_DEFAULT: tuple[str, ...] = ("left_calf", "right_calf", "left_foot", "right_foot", "left_forearm",
                                    "right_forearm", "left_hand", "right_hand")


def adjacent(a: int, b: int) -> bool:
    """True if capsules a and b ride on joints that are parent and child."""
    ja, jb = CAPSULE_JOINTS[a], CAPSULE_JOINTS[b]
    return PARENTS[ja] == jb or PARENTS[jb] == ja


def collision_pairs(checked: tuple[str, ...] = CHECKED_DEFAULT) -> tuple[tuple[int, int], ...]:
    """Sorted capsule index pairs (a < b) to test: each checked capsule against every capsule other
    than itself and those adjacent to it."""
    idx = [CAPSULE_NAMES.index(n) for n in checked]
    pairs = {tuple(sorted((c, d))) for c in idx for d in range(NUM_CAPSULES) if d != c and not adjacent(c, d)}
    return tuple(sorted(pairs))


def limb_pairs(limb_capsules: tuple[int, ...], checked: tuple[str, ...] = CHECKED_DEFAULT,
               ) -> tuple[tuple[int, int], ...]:
    """The checked pairs (a, b) with a in one limb's capsules and b either on the same limb or on the
    part of the body no limb moves (pelvis, spine, spine1, spine2, neck, head): the pairs a limb's
    own angles decide, so the sampler can test them per limb, before the other limbs are drawn."""
    fixed = {CAPSULE_NAMES.index(n) for n in FIXED_CAPSULES}
    own = set(limb_capsules)
    return tuple((a, b) if a in own else (b, a) for a, b in collision_pairs(checked)
                 if (a in own and (b in own or b in fixed)) or (b in own and a in fixed))


def segment_distance(p1: np.ndarray, q1: np.ndarray, p2: np.ndarray, q2: np.ndarray) -> np.ndarray:
    """Distance (...) between segments p1-q1 and p2-q2 (each (..., 3)): closest points by clamping
    the unconstrained solution onto the segments (Ericson, Real-Time Collision Detection 5.1.9)."""
    d1, d2, r = q1 - p1, q2 - p2, p1 - p2
    a = np.maximum(np.sum(d1 * d1, -1), 1e-18)
    e = np.maximum(np.sum(d2 * d2, -1), 1e-18)
    b, c, f = np.sum(d1 * d2, -1), np.sum(d1 * r, -1), np.sum(d2 * r, -1)
    denom = a * e - b * b
    s = np.where(denom > 1e-12 * a * e, np.clip((b * f - c * e) / np.where(denom > 0, denom, 1.0), 0, 1), 0.0)
    t = (b * s + f) / e
    s = np.where(t < 0, np.clip(-c / a, 0, 1), np.where(t > 1, np.clip((b - c) / a, 0, 1), s))
    t = np.clip(t, 0, 1)
    gap = p1 + d1 * s[..., None] - p2 - d2 * t[..., None]
    return np.sqrt(np.sum(gap * gap, -1))


def _quat_z_to(axis: np.ndarray) -> np.ndarray:
    """Unit quaternions (K, 4) (w, x, y, z) rotating +z onto unit vectors ``axis`` (K, 3)."""
    w = 1.0 + axis[:, 2]
    q = np.stack([w, -axis[:, 1], axis[:, 0], np.zeros(len(axis))], axis=1)
    flip = w < 1e-9  # axis = -z: a half turn about x
    q[flip] = [0.0, 1.0, 0.0, 0.0]
    return q / np.linalg.norm(q, axis=1, keepdims=True)


class SelfCollision:
    """MuJoCo capsule self-collision checker for a set of checked capsules (names)."""

    def __init__(self, checked: tuple[str, ...] = CHECKED_DEFAULT):
        self.pairs = collision_pairs(checked)
        bodies = "".join(
            f'<body name="b{k}" mocap="true"><geom name="g{k}" type="capsule" size="0.05 0.1" '
            f'contype="0" conaffinity="0"/></body>' for k in range(NUM_CAPSULES))
        pairs = "".join(f'<pair geom1="g{a}" geom2="g{b}"/>' for a, b in self.pairs)
        xml = f"<mujoco><worldbody>{bodies}</worldbody><contact>{pairs}</contact></mujoco>"
        self.model = mujoco.MjModel.from_xml_string(xml)
        self.data = mujoco.MjData(self.model)

    def contacts(self, ends: np.ndarray, radius: np.ndarray) -> list[tuple[int, int]]:
        """Penetrating checked pairs (capsule indices) of one posed body.

        ends: (20, 2, 3) axis-segment ends, m; radius: (20,) m.
        """
        m, d = self.model, self.data
        axis = ends[:, 1] - ends[:, 0]
        length = np.linalg.norm(axis, axis=1)
        unit = np.where(length[:, None] > 1e-12, axis / np.maximum(length, 1e-12)[:, None], [0.0, 0.0, 1.0])
        half = 0.5 * length
        m.geom_size[:, 0] = radius
        m.geom_size[:, 1] = np.maximum(half, 1e-9)
        m.geom_rbound[:] = radius + half
        m.geom_aabb[:, 3:5] = radius[:, None]
        m.geom_aabb[:, 5] = radius + half
        d.mocap_pos[:] = 0.5 * (ends[:, 0] + ends[:, 1])
        d.mocap_quat[:] = _quat_z_to(unit)
        mujoco.mj_kinematics(m, d)
        mujoco.mj_collision(m, d)
        if d.ncon == 0:
            return []
        g = d.contact.geom[: d.ncon]
        return sorted({(int(min(a, b)), int(max(a, b))) for a, b in g})

    def collides(self, ends: np.ndarray, radius: np.ndarray) -> bool:
        """True if any checked pair of one posed body penetrates (see :meth:`contacts`)."""
        return bool(self.contacts(ends, radius))


@lru_cache(maxsize=4)
def checker(checked: tuple[str, ...] = CHECKED_DEFAULT) -> SelfCollision:
    """A shared checker per checked set (models are small; one per process is enough)."""
    return SelfCollision(checked)
