"""Joint angle limits of the pose sampler, as data (the paper's public code, which takes them from
Boone 1979, Roaas 1982 and Soucie 2011).

Angles are the components of SMPL's own local axis-angle vectors (``pose[3 j: 3 j + 3]``, SMPL's
y-up model frame: x = body's left, y = up, z = forward). Each component is sampled uniformly and
independently within its range. On the T-posed body:

* hips: x flexes (negative: thigh forward), y twists the leg, z abducts (left +, right -).
* knees: one axis, x (positive bends the calf backward).
* shoulders: x twists the arm, y swings it forward (left -, right +), z raises it (left +, right -).
  The sampled shoulder rotation is split: 1/3 goes to the collar joint, 2/3 to the shoulder joint
  (same axis, so the arm's total rotation is the sampled vector).
* elbows: one axis, y (left negative, right positive bends the forearm forward).

Spine, neck, head, ankles, feet, wrists and hands are held at 0 by the sampler; the public
code gives no ranges for them. ``hands_behind_head`` widens the shoulder ranges by 45 deg on the side
that lifts the arm over the head (x upper bound, and z upper bound left / lower bound right).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from pressurepose.body.joints import NUM_JOINTS, joint_index

# degrees, (x, y, z) component ranges of the local axis-angle
HIP_DEG = {
    "left_hip": ((-90.0, 17.8), (-33.7, 32.6), (-30.5, 38.6)),
    "right_hip": ((-90.0, 17.8), (-32.6, 33.7), (-38.6, 30.5)),
}
KNEE_DEG = {"left_knee": (-1.3, 139.9), "right_knee": (-1.3, 139.9)}  # x axis only
# total shoulder rotation (collar + shoulder joint), split by SHOULDER_SPLIT
SHOULDER_DEG = {
    "left_shoulder": ((-88.9, 81.4), (-140.7, 43.7), (-90.0, 80.4)),
    "right_shoulder": ((-88.9, 81.4), (-43.7, 140.7), (-80.4, 90.0)),
}
ELBOW_DEG = {"left_elbow": (-147.3, 2.8), "right_elbow": (-2.8, 147.3)}  # y axis only
HINGE_AXIS = {"left_knee": 0, "right_knee": 0, "left_elbow": 1, "right_elbow": 1}
SHOULDER_SPLIT = 1.0 / 3.0  # share of the shoulder rotation given to the collar joint
HANDS_BEHIND_HEAD_WIDENING_DEG = 45.0
COLLAR_OF = {"left_shoulder": "left_collar", "right_shoulder": "right_collar"}


@dataclass(frozen=True, eq=False)
class JointLimits:
    """Per-joint, per-axis angle limits (radians) of SMPL's 24 local axis-angle vectors.

    lower, upper: (24, 3). Rows of joints the public code limits (hips, knees, collars, shoulders,
    elbows) hold their ranges, with the collar and shoulder rows holding 1/3 and 2/3 of the total
    shoulder range; every other row is [0, 0] (held at 0 while sampling; no published range).
    Row 0 (the global orientation) is not limited here and holds [0, 0].
    limited: (24,) bool, True for the joints with published ranges.
    hinge_axis: (24,) int, the single axis of hinge joints (knees 0 = x, elbows 1 = y), -1 otherwise.
    shoulder_lower, shoulder_upper: (2, 3) the total (collar + shoulder) ranges, left then right;
    the sampler draws these and splits them with ``shoulder_split`` (collar share).
    """

    lower: np.ndarray
    upper: np.ndarray
    limited: np.ndarray
    hinge_axis: np.ndarray
    shoulder_lower: np.ndarray
    shoulder_upper: np.ndarray
    shoulder_split: float = SHOULDER_SPLIT
    hands_behind_head: bool = False

    def within(self, pose: np.ndarray, tol: float = 1e-9) -> np.ndarray:
        """(B,) True where every local rotation of pose (B, 72) is within [lower, upper] (root
        ignored) and each collar/shoulder pair is in the 1 : 2 split of an in-range total."""
        p = np.atleast_2d(np.asarray(pose, dtype=np.float64)).reshape(-1, NUM_JOINTS, 3)
        ok = np.all((p[:, 1:] >= self.lower[1:] - tol) & (p[:, 1:] <= self.upper[1:] + tol), axis=(1, 2))
        for side, name in enumerate(("left_shoulder", "right_shoulder")):
            c, s = p[:, joint_index(COLLAR_OF[name])], p[:, joint_index(name)]
            total = c + s
            ok &= np.all(np.abs(c - self.shoulder_split * total) <= 1e-6, axis=1)
            ok &= np.all((total >= self.shoulder_lower[side] - tol) & (total <= self.shoulder_upper[side] + tol),
                         axis=1)
        return ok


def joint_limits(partition: str | None = None) -> JointLimits:
    """The sampler's joint limits; ``partition`` 'hands_behind_head' (or a partition object with
    ``hands_behind_head`` set) widens the shoulders. Other partitions use the nominal limits."""
    hbh = bool(getattr(partition, "hands_behind_head", False)) or partition == "hands_behind_head"
    lo = np.zeros((NUM_JOINTS, 3))
    hi = np.zeros((NUM_JOINTS, 3))
    limited = np.zeros(NUM_JOINTS, dtype=bool)
    hinge = np.full(NUM_JOINTS, -1)
    for name, ranges in HIP_DEG.items():
        j = joint_index(name)
        lo[j], hi[j] = np.deg2rad(np.array(ranges).T)
        limited[j] = True
    for table in (KNEE_DEG, ELBOW_DEG):
        for name, (a, b) in table.items():
            j, axis = joint_index(name), HINGE_AXIS[name]
            lo[j, axis], hi[j, axis] = np.deg2rad(a), np.deg2rad(b)
            limited[j] = True
            hinge[j] = axis
    sh_lo, sh_hi = np.zeros((2, 3)), np.zeros((2, 3))
    for side, (name, ranges) in enumerate(SHOULDER_DEG.items()):
        a, b = np.array(ranges, dtype=np.float64).T
        if hbh:
            w = HANDS_BEHIND_HEAD_WIDENING_DEG
            b[0] += w  # x upper bound, both sides
            if side == 0:
                b[2] += w  # left arm lifts with +z
            else:
                a[2] -= w  # right arm lifts with -z
        sh_lo[side], sh_hi[side] = np.deg2rad(a), np.deg2rad(b)
        for joint, share in ((COLLAR_OF[name], SHOULDER_SPLIT), (name, 1.0 - SHOULDER_SPLIT)):
            j = joint_index(joint)
            lo[j], hi[j] = share * sh_lo[side], share * sh_hi[side]
            limited[j] = True
    for arr in (lo, hi, limited, hinge, sh_lo, sh_hi):
        arr.setflags(write=False)
    return JointLimits(lo, hi, limited, hinge, sh_lo, sh_hi, SHOULDER_SPLIT, hbh)

