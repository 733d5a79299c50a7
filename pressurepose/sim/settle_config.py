"""The settings of physics simulation #1 (the settle), checked, and the named settles datasets are
made with. Imports no simulator: a dataset's or a command's settle is checked without MuJoCo.

* :class:`SettleConfig`: every setting of the settle (defaults: the paper's procedure, section 3.2
  and appendix A.2, with a relaxed neck and spine and a coarser step late in the settle).
* :func:`settle_preset`: the config of a named settle (:data:`SETTLES`).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from pressurepose.body.contact import START_OVERLAP_TOL_M
from pressurepose.body.joints import JOINT_NAMES
from pressurepose.errors import BadInput, require_between, require_non_negative, require_positive, require_whole
from pressurepose.sim.springs import LIMIT_STIFFNESS_FACTOR, RELAXED_SPINE_STIFFNESS

# joints of the limbs that must rest over the mattress unless limbs may hang (SamplerConfig.hanging_limbs)
LIMB_JOINTS = tuple(JOINT_NAMES.index(f"{side}_{j}") for side in ("left", "right")
                    for j in ("knee", "ankle", "foot", "elbow", "wrist", "hand"))
# a limb joint this far below the mattress's top beyond its edge hangs (a resting limb's joints lie
# above the body's lowest surface, which sinks at most ~7 cm into the foam)
HANG_DEPTH_M = 0.1


def hanging(points: np.ndarray, bounds: tuple[float, float, float, float], depth_m: float) -> bool:
    """Whether any of ``points`` (K, 3) bed frame, m, lies beyond the mattress outline ``bounds``
    (x0, x1, y0, y1) m and more than ``depth_m`` below the mattress's top (z = 0): a hanging limb."""
    x0, x1, y0, y1 = bounds
    beyond = (points[:, 0] < x0) | (points[:, 0] > x1) | (points[:, 1] < y0) | (points[:, 1] > y1)
    return bool(np.any(beyond & (points[:, 2] < -depth_m)))
# the settles a dataset can be made with (``GenerationConfig.settle``, ``--settle``; :func:`settle_preset`)
SETTLES: tuple[str, ...] = ("relaxed", "paper")


@dataclass(frozen=True)
class SettleConfig:
    """Settings of physics simulation #1 (defaults: the paper's procedure, section 3.2 and
    appendix A.2, except ``relaxed_neck``, ``spine_stiffness`` and the coarse step).

    timestep_s, max_steps, zero_every: step length, step budget, velocity-zeroing period before the
        pelvis touches. rest_speed_m_s, rest_accel_m_s2, rest_hold_steps: the resting criterion and
        how many consecutive steps it must hold. drop_clearance_m: the lowest capsule point's start
        height above the mattress.
    cell_m, taxels_per_cell: cell size of the mattress grid, by default 2 x 2 taxels (3-4x faster
        than one cell per taxel; the two grids rest bodies a median 2-3 cm apart, trunks closer than
        limbs). stiffness_n_m3: the settle model's foundation modulus; by default fitted so that
        body-part capsules sink into these cells as deep as into the bed's press model
        (:func:`pressurepose.sim.settle_stiffness.calibrate_stiffness`, appendix A.5; a few seconds,
        once per bed, config and source version on a machine:
        :func:`~pressurepose.sim.settle_stiffness.settle_stiffness` keeps it on disk).
        coupling: tie neighbouring cells with the bed's shear stiffness.
    self_collision: limbs (forearms, hands, calves, feet) collide with the other capsules.
    limit_stiffness_factor: ball-joint limit penalty, multiple of the joint stiffness.
    iterations, ls_iterations, tolerance: Newton solver settings.
    max_speed_m_s: faster capsule points mean the simulation blew up; fall_depth_m: a pelvis this far
        below the mattress top has fallen off; self_collision_tol_m: start overlap allowed between limbs.
    posture_check_steps: how often (steps) the posture class is checked while settling.
    relaxed_neck: soft neck and head joints so the head rests on the bed (default; False: the
        paper's stiffness, see :data:`pressurepose.sim.springs.RELAXED_NECK_STIFFNESS`).
    spine_stiffness: N m/rad of the spine joints for the average body (default a relaxed spine,
        :data:`pressurepose.sim.springs.RELAXED_SPINE_STIFFNESS`; None: the paper's 200).
    coarse_factor, coarse_after_steps: the settle's step grows to ``coarse_factor x timestep_s``
        ``coarse_after_steps`` steps after the pelvis touches the bed (1: never). The drop and the
        first rocking run at ``timestep_s``; the slow end of the settle, where limbs creep on their
        dampers, at the longer step. The resting criterion stays in m/s and seconds (the hold
        becomes ``rest_hold_steps / coarse_factor`` steps) and the step budget in seconds. The
        cells keep the mass chosen for ``timestep_s`` (spring-mass frequency times the coarse step:
        ``coarse_factor x`` CELL_OMEGA_DT, inside the stable range). Rests differ from the fine
        step's no more than those of two starts 2 mm apart do (docs/throughput.md).
    """

    timestep_s: float = 0.01
    max_steps: int = 2000
    zero_every: int = 4
    rest_speed_m_s: float = 0.05
    rest_accel_m_s2: float = 0.5
    rest_hold_steps: int = 20
    drop_clearance_m: float = 0.005
    cell_m: float | None = None
    taxels_per_cell: int = 2
    stiffness_n_m3: float | None = None
    coupling: bool = True
    self_collision: bool = True
    limit_stiffness_factor: float = LIMIT_STIFFNESS_FACTOR
    iterations: int = 50
    ls_iterations: int = 20
    tolerance: float = 1e-8
    max_speed_m_s: float = 5.0
    fall_depth_m: float = 0.25
    self_collision_tol_m: float = START_OVERLAP_TOL_M
    posture_check_steps: int = 10
    relaxed_neck: bool = True
    spine_stiffness: float | None = RELAXED_SPINE_STIFFNESS
    coarse_factor: float = 2.0
    coarse_after_steps: int = 150

    def __post_init__(self):
        for name in ("max_steps", "zero_every", "rest_hold_steps", "iterations", "ls_iterations",
                     "taxels_per_cell", "posture_check_steps", "coarse_after_steps"):
            require_whole(f"settle {name}", getattr(self, name), 1)
        for name in ("timestep_s", "rest_speed_m_s", "rest_accel_m_s2", "tolerance", "max_speed_m_s",
                     "fall_depth_m", "limit_stiffness_factor"):
            require_positive(f"settle {name}", getattr(self, name))
        if self.spine_stiffness is not None:
            require_positive("settle spine_stiffness (N m/rad; None: the paper's)", self.spine_stiffness)
        require_between("settle coarse_factor (1: no coarse step)", self.coarse_factor, 1, 4)
        for name in ("drop_clearance_m", "self_collision_tol_m"):
            require_non_negative(f"settle {name}", getattr(self, name))

def settle_preset(name: str) -> SettleConfig:
    """The :class:`SettleConfig` of a named settle: 'relaxed' (the defaults: neck and spine relax so
    bodies rest as people lie) or 'paper' (the paper's joint springs throughout)."""
    if name == "relaxed":
        return SettleConfig()
    if name == "paper":
        return SettleConfig(relaxed_neck=False, spine_stiffness=None)
    raise BadInput(f"settle {name!r} is not known; expected one of {', '.join(SETTLES)}")
