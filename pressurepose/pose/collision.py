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

from pressurepose.body.capsules import CAPSULE_NAMES, NUM_CAPSULES
from pressurepose.body.contact import CHECKED_DEFAULT, collision_pairs

# capsules no sampled limb moves (spine, neck and head are held at 0 while sampling)
FIXED_CAPSULES: tuple[str, ...] = ("pelvis", "spine", "spine1", "spine2", "neck", "head")


def limb_pairs(limb_capsules: tuple[int, ...], checked: tuple[str, ...] = CHECKED_DEFAULT,
               ) -> tuple[tuple[int, int], ...]:
    """The checked pairs (a, b) with a in one limb's capsules and b either on the same limb or on the
    part of the body no limb moves (pelvis, spine, spine1, spine2, neck, head): the pairs a limb's
    own angles decide, so the sampler can test them per limb, before the other limbs are drawn."""
    fixed = {CAPSULE_NAMES.index(n) for n in FIXED_CAPSULES}
    own = set(limb_capsules)
    return tuple((a, b) if a in own else (b, a) for a, b in collision_pairs(checked)
                 if (a in own and (b in own or b in fixed)) or (b in own and a in fixed))


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
