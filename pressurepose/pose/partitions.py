"""The PressurePose posture partitions (paper appendix A.7 and its public code), as data.

Cartesian bins (paper appendix A.1): the distal joint of each limb (ankle, wrist) is placed along
the bed's long axis (the body lies along it, yawed up to 30 deg) relative to its proximal joint
(hip, shoulder), in steps of a quarter of the limb's length. Bins are numbered from the head end
toward the feet:

* legs, 4 bins: the ankle is less than 1/4, 1/4-1/2, 1/2-3/4, more than 3/4 leg length footward
  of the hip (bin 0 also takes an ankle level with or above the hip);
* arms, 8 bins: the wrist is more than 3/4, 3/4-1/2, 1/2-1/4, 1/4-0 arm length headward of the
  shoulder (bins 0-3), then 0-1/4, ..., more than 3/4 footward (bins 4-7).

Every partition exists with and without ``limbs_on_bed`` (the paper's "prevent limb overhang").
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from pressurepose.errors import BadInput

LEG_BINS = 4
ARM_BINS = 8
# The wedge of a wedge partition, as the sampler must know it to keep limbs out of it: it lies
# against these trunk capsules and runs WEDGE_LENGTH_M footward from the trunk's top (from the
# shoulders to the knees; PMD's wedge imprints run about 1.1-1.3 m). pressurepose.sim.wedge builds it.
WEDGE_TRUNK: tuple[str, ...] = ("pelvis", "spine", "spine1", "spine2")
WEDGE_LENGTH_M = 1.1


@dataclass(frozen=True)
class Partition:
    """One posture partition.

    roll: (low, high) of the root roll about the body's long axis, rad (equal ends: fixed);
    0 is supine, +-pi prone, -pi/2 lying on the right side. either_side: the drawn roll's sign is
    drawn too (even odds), so the partition covers (low, high) and (-high, -low).
    leg_bins, arm_bins: the bins a limb's distal joint may be assigned (drawn uniformly).
    straight_limbs: knees and elbows held at 0.
    hands_behind_head: shoulder limits widened, wrists headward of, medial to and 0-0.4 m below the
    shoulders and within ``wrist_to_head`` of the head joint, and the hands exempt from the
    self-collision check (they rest against the head).
    crossed_legs: the left ankle lies on the right ankle's side of it (toward the body's right).
    arm_height_band: (low, high) of the wrist height minus the shoulder height, m (None: the
    sampler's general band).
    wedge: a foam wedge props the body's back while it settles and presses on the mat with it
    (:mod:`pressurepose.sim.wedge`; its trunk capsules and length: ``WEDGE_TRUNK``, ``WEDGE_LENGTH_M``).
    """

    name: str
    description: str
    roll: tuple[float, float] = (0.0, 0.0)
    either_side: bool = False
    leg_bins: tuple[int, ...] = tuple(range(LEG_BINS))
    arm_bins: tuple[int, ...] = tuple(range(ARM_BINS))
    straight_limbs: bool = False
    hands_behind_head: bool = False
    crossed_legs: bool = False
    arm_height_band: tuple[float, float] | None = None
    wrist_to_head: float | None = None
    wedge: bool = False


PARTITIONS: dict[str, Partition] = {p.name: p for p in (
    Partition("general", "roll uniform over the full circle (supine, lateral, prone and between); "
              "legs over 4 bins, arms over 8", roll=(-np.pi, np.pi)),
    Partition("general_supine", "supine; legs over 4 bins, arms over 8"),
    Partition("hands_behind_head", "supine; legs over 4 bins; wrists headward of and medial to the "
              "shoulders, behind them (toward the bed) and within 0.25 m of the head joint",
              arm_bins=(0, 1, 2, 3), hands_behind_head=True, arm_height_band=(-0.4, 0.0), wrist_to_head=0.25),
    Partition("prone_hands_up", "prone (roll pi); legs over 4 bins; wrists headward of the shoulders",
              roll=(np.pi, np.pi), arm_bins=(0, 1, 2, 3)),
    Partition("supine_crossed_legs", "supine; the left ankle crosses to the right of the right ankle; "
              "legs over bins 1-3 (feet away from the hips), arms over 8 bins",
              leg_bins=(1, 2, 3), crossed_legs=True),
    Partition("supine_straight_limbs", "supine; knees and elbows straight; legs in bin 3 (the only one "
              "a straight leg reaches within the height band), arms over 8 bins",
              leg_bins=(3,), straight_limbs=True),
    # not one of the paper's: in `general` most bodies drawn on their side roll onto their back or
    # front while settling, so side-lying rests are a small share of the paper's mix
    Partition("general_lateral", "on either side (roll 60-120 deg each way; not a paper partition); legs "
              "over 4 bins, arms over 8", roll=(np.pi / 3, 2 * np.pi / 3), either_side=True),
    # not one of the paper's: half-turned bodies propped by a wedge, as nurses position patients
    # (PMD experiment I's "30 deg / 60 deg (wedge)" postures)
    Partition("propped_lateral", "half turned onto either side (roll 25-70 deg each way) with a foam wedge "
              "behind the back (not a paper partition); legs over 4 bins, arms over 8",
              roll=(np.radians(25.0), np.radians(70.0)), either_side=True, wedge=True),
)}
# short names the CLI also accepts
ALIASES: dict[str, str] = {"supine": "general_supine", "crossed_legs": "supine_crossed_legs",
                           "straight_limbs": "supine_straight_limbs"}


def get_partition(name) -> Partition:
    """A partition by name (or alias); a Partition passes through; BadInput naming the valid names."""
    if isinstance(name, Partition):
        return name
    key = str(name).strip().lower()
    key = ALIASES.get(key, key)
    if key not in PARTITIONS:
        aliases = ", ".join(f"{a} = {c}" for a, c in ALIASES.items())
        raise BadInput(f"partition {name!r} is not known; expected one of {', '.join(PARTITIONS)} "
                       f"(aliases: {aliases})")
    return PARTITIONS[key]


def leg_bin(footward: np.ndarray, leg_length) -> np.ndarray:
    """Leg bin (int array) of ankles ``footward`` m along the bed from the hip (footward +)."""
    return np.clip(np.floor(4.0 * np.asarray(footward) / leg_length), 0, LEG_BINS - 1).astype(np.int64)


def arm_bin(footward: np.ndarray, arm_length) -> np.ndarray:
    """Arm bin (int array) of wrists ``footward`` m along the bed from the shoulder."""
    return np.clip(np.floor(4.0 * np.asarray(footward) / arm_length) + 4, 0, ARM_BINS - 1).astype(np.int64)
