"""The ragdoll's joint springs (paper appendix A.2), as numbers without the simulator.

Each joint of the capsule ragdoll (:mod:`pressurepose.sim.ragdoll`) is a spring that rests at the
home pose (a body posed from real lying poses: at its drawn pose, ``settle(spring_pose=...)``), with
the paper's stiffness for the average body (scaled by body mass) and damping
``DAMPING_PER_STIFFNESS_S`` x stiffness. Two departures from the paper are the settle's defaults
(``SettleConfig.relaxed_neck``, ``SettleConfig.spine_stiffness``): a relaxed neck and a relaxed spine.
Ball joints are held inside their limits by a penalty torque of ``LIMIT_STIFFNESS_FACTOR`` x the
joint's stiffness.
"""

from __future__ import annotations

import numpy as np

from pressurepose.body.joints import JOINT_NAMES

# Mean body mass the joint stiffnesses are quoted for (Tozeren's averages, as in the paper's public code;
# appendix A.2); neutral = their mean.
MEAN_MASS_KG = {"female": 62.5, "male": 78.4, "neutral": (62.5 + 78.4) / 2}
# Joint stiffness of the average body, N m / rad, by SMPL joint (paper appendix A.2). Collars count as
# shoulders: the sampler splits one shoulder rotation 1 : 2 between collar and shoulder joint.
_STIFFNESS_BY_NAME = {
    "left_hip": 6.0, "right_hip": 6.0, "left_knee": 3.0, "right_knee": 3.0, "left_ankle": 6.0,
    "right_ankle": 6.0, "spine1": 200.0, "spine2": 200.0, "spine3": 200.0, "neck": 200.0, "head": 200.0,
    "left_collar": 4.0, "right_collar": 4.0, "left_shoulder": 4.0, "right_shoulder": 4.0,
    "left_elbow": 2.0, "right_elbow": 2.0, "left_wrist": 4.0, "right_wrist": 4.0,
}
MEAN_STIFFNESS = np.array([_STIFFNESS_BY_NAME.get(n, 0.0) for n in JOINT_NAMES])
DAMPING_PER_STIFFNESS_S = 15.0
# A relaxed neck (default; ``relaxed_neck=False`` keeps the paper's 200 N m/rad): the neck and head
# joints of the average body get this stiffness (N m/rad, scaled by mass like the others) and
# damping of RELAXED_NECK_DAMPING_S x stiffness. The paper's springs hold the head in its standing
# pose, and a supine head's back lies 2-5 cm above where the upper back has sunk to, so half the
# supine heads left no imprint (real, PMD-I: 99 %). A head of ~4.5 kg on a ~0.1 m lever pulls
# with ~4 N m: soft enough springs let it fall onto the bed within the settle's first 0.5 s, and less
# damping (15 x stiffness would be a 15 s time constant) lets it get there before the resting test.
RELAXED_NECK_STIFFNESS = 10.0
RELAXED_NECK_DAMPING_S = 0.3
NECK_JOINTS = (JOINT_NAMES.index("neck"), JOINT_NAMES.index("head"))
# A relaxed spine (default; the paper's 200 N m/rad with ``spine_stiffness=None``): the spine1-3
# joints of the average body get this stiffness (N m/rad, scaled by mass; damping 15 x stiffness as
# the paper's). The paper's springs hold the trunk in its standing curvature, so a supine trunk
# rests as one rigid piece and carries its weight on the shoulders and calves as much as on the
# pelvis (simulated pelvis band 24 % of the load against 29-31 % on PMD experiment I's supine
# people). Lying people do not hold their spine: with springs ten times softer the trunk bends and
# the heavy pelvis sinks deepest, as on real mats (docs/physics.md, "Relaxed spine"; the value was
# chosen among 200, 40, 20, 10 and 4 on PMD experiment I's region shares).
RELAXED_SPINE_STIFFNESS = 20.0
SPINE_JOINTS = tuple(JOINT_NAMES.index(n) for n in ("spine1", "spine2", "spine3"))
# Penalty stiffness of the ball-joint limits, as a multiple of the joint's own stiffness. The settle
# step treats joint damping (15 x stiffness) implicitly and this torque explicitly, which is stable
# while dt * limit_stiffness / damping < 2, i.e. factor < 3000 at dt = 0.01 s; 300 holds a whole
# leg's weight (~60 N m on a hip of stiffness 6) within 2 degrees of the limit.
LIMIT_STIFFNESS_FACTOR = 300.0
