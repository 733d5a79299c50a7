"""Domain randomisation: the bed, tissue and sensor constants and the mat's placement, per sample.

A model trained on one simulated bed reads one bed. With ``GenerationConfig(randomize=True)``
(``generate --randomize``) each sample draws its :class:`Conditions` from its own generator (so a
sample stays a pure function of its config, index and attempt) and is pressed on that bed; the
drawn values are stored with the sample (``conditions``, in :data:`CONDITION_NAMES` order). The
settle runs on the nominal bed (a settle model is compiled once per bed), so only the press, the
mat's reading and the mat's placement change.

Ranges (:class:`RandomizationRanges`) and why:

* mattress stiffness: the bed's k_A times a log-uniform factor in [0.6, 1.6]. Foam mattresses span
  soft to firm (indentation force deflection roughly 2-3x from soft to firm), and the real data
  differ: on one mat the PMD experiment I supine images (13 people) cover 1217-1531 taxels, and
  PMD experiment II's BodiTrak images were taken on a sponge and an air mattress.
* tissue modulus: log-uniform 1.5-6 kPa, a factor of two about the default 3 kPa, inside the
  1-30 kPa that in vivo indentation of relaxed muscle and fat reports. On a bed with another
  modulus (``generate --bed``, e.g. one fitted by ``calibrate``) the range is scaled to it: a
  factor of two about the bed's own.
* sensor gain: U(0.75, 1.25) on the sensor law's C1 and C2: the summed raw reading per kg of body
  weight varies with a coefficient of variation of 0.25 over the PMD experiment I images (13
  people, supine, supine star and hands crossed), on one mat; the paper notes a blanket cut the
  magnitude threefold (the network normalises each image by its sum, so gain mostly moves taxels
  across the threshold).
* sensor threshold: U(0, 4) mmHg above the bed's own (0 on the default bed); readings below it are
  0 (real mats report nothing below a noise floor; the BodiTrak's is not published, 4 mmHg is 4 %
  of its 100 mmHg range).
* mat offset: U(-5, 5) cm across and along the mattress (it must stay on the mattress: the margins
  of the BodiTrak on a twin XL are 10-11 cm). On PMD experiment I the supine bodies' centre of
  pressure lies 1.6 taxels (about 4.5 cm) off the mat's centre line on average, with an sd of 1.7
  taxels (5 cm) over people; the sampler already spreads bodies by 3 cm, and U(-5, 5) cm adds sd
  2.9 cm.
* mat rotation: U(-3, 3) degrees about the vertical: the PMD experiment I supine bodies' principal
  axes lie 3.9 +- 3.0 degrees (max 11) off the mat's columns, most of which the sampler's body yaw
  (sd 5.7 degrees) already covers. The mattress's outline is not turned with the mat (its edges
  are far from a centred body).
"""

from __future__ import annotations

import dataclasses
import math
from dataclasses import dataclass

import numpy as np

from pressurepose.errors import BadInput, require_non_negative

CONDITION_NAMES: tuple[str, ...] = ("mattress_stiffness_n_m3", "tissue_modulus_pa", "sensor_gain",
                                    "sensor_threshold_mmhg", "mat_offset_x_m", "mat_offset_y_m",
                                    "mat_rotation_rad")


@dataclass(frozen=True)
class RandomizationRanges:
    """What is drawn per sample (see the module docstring for why): factors on the bed's
    stiffness (log-uniform), the tissue modulus (Pa, log-uniform), the sensor gain and threshold
    (mmHg) (uniform), and the mat's offset (m, each axis) and rotation (rad) (uniform +-)."""

    stiffness_factor: tuple[float, float] = (0.6, 1.6)
    tissue_modulus_pa: tuple[float, float] = (1.5e3, 6.0e3)
    sensor_gain: tuple[float, float] = (0.75, 1.25)
    sensor_threshold_mmhg: tuple[float, float] = (0.0, 4.0)
    mat_offset_m: float = 0.05
    mat_rotation_rad: float = math.radians(3.0)

    def __post_init__(self):
        for name in ("stiffness_factor", "tissue_modulus_pa", "sensor_gain", "sensor_threshold_mmhg"):
            lo, hi = (float(v) for v in getattr(self, name))
            if not (math.isfinite(lo) and math.isfinite(hi) and 0 <= lo <= hi):
                raise BadInput(f"randomisation {name} is {getattr(self, name)!r}; expected (low, high), "
                               f"0 <= low <= high")
        for name in ("mat_offset_m", "mat_rotation_rad"):
            require_non_negative(f"randomisation {name}", getattr(self, name))


@dataclass(frozen=True)
class Conditions:
    """One sample's bed: the values named by :data:`CONDITION_NAMES`."""

    mattress_stiffness_n_m3: float
    tissue_modulus_pa: float
    sensor_gain: float
    sensor_threshold_mmhg: float
    mat_offset_x_m: float
    mat_offset_y_m: float
    mat_rotation_rad: float

    def as_array(self) -> np.ndarray:
        """(7,) float64 in :data:`CONDITION_NAMES` order."""
        return np.array([getattr(self, n) for n in CONDITION_NAMES], dtype=np.float64)

    def bed(self, nominal):
        """The BedSpec the sample is pressed and read on: ``nominal``'s with these constants and its
        sensing area moved by the offset on the mattress."""
        ox, oy = nominal.mat_offset_m
        return dataclasses.replace(
            nominal, stiffness_n_m3=self.mattress_stiffness_n_m3, tissue_modulus_pa=self.tissue_modulus_pa,
            sensor_c1=nominal.sensor_c1 * self.sensor_gain, sensor_c2=nominal.sensor_c2 * self.sensor_gain,
            sensor_threshold_mmhg=self.sensor_threshold_mmhg,
            mat_offset_m=(ox + self.mat_offset_x_m, oy + self.mat_offset_y_m))

    def rebased(self, old, new) -> "Conditions":
        """The conditions the same draws give about the nominal bed ``new`` instead of ``old`` (see
        :func:`draw_conditions`: stiffness and tissue modulus scale with the nominal bed's, the
        threshold is the nominal one plus the draw; gain and placement do not depend on the bed)."""
        return dataclasses.replace(
            self, mattress_stiffness_n_m3=self.mattress_stiffness_n_m3 * new.stiffness_n_m3 / old.stiffness_n_m3,
            tissue_modulus_pa=self.tissue_modulus_pa * new.tissue_modulus_pa / old.tissue_modulus_pa,
            sensor_threshold_mmhg=self.sensor_threshold_mmhg - old.sensor_threshold_mmhg + new.sensor_threshold_mmhg)

    def body_motion(self, nominal) -> np.ndarray:
        """(4, 4) rigid motion of a body settled on ``nominal`` into the frame of the moved mat
        (:meth:`bed`): turned by -rotation about the sensing area's centre, then shifted by -offset."""
        c, s = math.cos(-self.mat_rotation_rad), math.sin(-self.mat_rotation_rad)
        rot = np.array([[c, -s, 0.0], [s, c, 0.0], [0.0, 0.0, 1.0]])
        centre = np.array([nominal.mat.width_m / 2, nominal.mat.length_m / 2, 0.0])
        out = np.eye(4)
        out[:3, :3] = rot
        out[:3, 3] = centre - rot @ centre - np.array([self.mat_offset_x_m, self.mat_offset_y_m, 0.0])
        return out


def draw_conditions(rng: np.random.Generator, bed, ranges: RandomizationRanges = RandomizationRanges()) -> Conditions:
    """One sample's :class:`Conditions` about the nominal ``bed`` (a BedSpec), from ``rng``: its
    stiffness and tissue modulus times drawn factors, its threshold plus a drawn one (see the module
    docstring)."""

    def log_uniform(lo, hi):
        return float(math.exp(rng.uniform(math.log(lo), math.log(hi)))) if lo > 0 else float(rng.uniform(lo, hi))

    from pressurepose.sim.bed import TISSUE_MODULUS_PA

    k = bed.stiffness_n_m3 * log_uniform(*ranges.stiffness_factor)
    # the tissue range is about the default modulus; on another bed's it is scaled (by exactly 1 on the default)
    e = log_uniform(*ranges.tissue_modulus_pa) * (bed.tissue_modulus_pa / TISSUE_MODULUS_PA)
    gain = float(rng.uniform(*ranges.sensor_gain))
    threshold = bed.sensor_threshold_mmhg + float(rng.uniform(*ranges.sensor_threshold_mmhg))
    dx, dy = (float(v) for v in rng.uniform(-ranges.mat_offset_m, ranges.mat_offset_m, 2))
    turn = float(rng.uniform(-ranges.mat_rotation_rad, ranges.mat_rotation_rad))
    return Conditions(k, e, gain, threshold, dx, dy, turn)
