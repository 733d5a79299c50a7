"""Settings of the pose sampler, and the default bed layout it places bodies on."""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from pressurepose.errors import BadInput, require_non_negative, require_positive, require_whole
from pressurepose.pose.posefile import PoseFile

# BodiTrak BT-3510 sensing area (64 x 27 taxels at 28.6 mm) centred on a twin XL mattress (39 x 80 in),
# in the bed frame: the same outline as pressurepose.sim.bed.BedSpec().mattress_bounds
_SENSE_W, _SENSE_L = 27 * 0.0286, 64 * 0.0286
_MAT_W, _MAT_L = 39 * 0.0254, 80 * 0.0254
DEFAULT_MATTRESS = (-(_MAT_W - _SENSE_W) / 2, (_MAT_W + _SENSE_W) / 2, -(_MAT_L - _SENSE_L) / 2,
                    (_MAT_L + _SENSE_L) / 2)
DEFAULT_SENSING = (0.0, _SENSE_W, 0.0, _SENSE_L)
HEIGHT_REFERENCES = ("proximal", "bed")
PLACEMENTS = ("centred", "uniform")
SHAPES = ("normal", "uniform")


def mattress_outline(bed) -> tuple[float, float, float, float]:
    """(x_min, x_max, y_min, y_max) of a ``pressurepose.sim.bed.BedSpec``'s mattress, bed frame, m."""
    return tuple(float(v) for v in bed.mattress_bounds)


@dataclass(frozen=True)
class SamplerConfig:
    """Settings of the sampler (metres, radians).

    shapes: 'normal' (default): betas ~ N(0, beta_sd) truncated to +-beta_range (SMPL's population;
    3 % of bodies with a BMI under 17 or over 35); 'uniform' (the paper's): U(-beta_range,
    beta_range) (19 %); see :func:`pressurepose.pose.root.draw_betas`.
    placement: 'centred' (default): yaw ~ N(0, yaw_sd) within +-yaw_max, the pelvis N(0, s)
    across the mattress's centre line, s = hypot(across_sd_m cos(roll), across_sd_lateral_m
    sin(roll)) (PhysioNet PMD experiment I: the load centroid of supine people lies within 1.5 cm
    (sd) of its mean, of people on their side 8-9 cm), and the crown head_gap_m +- along_sd_m from
    its head end (0.16 m puts simulated heads at the mat's second or third row, where real heads
    print in PMD-I), then, once the limbs are drawn, slid toward the foot as far as needed (and
    the foot end allows) to keep every joint head_gap_m from the head end (arms above the head);
    'uniform' (the paper's): yaw ~ U(-yaw_max, yaw_max) (the public code's pi/6; the paper's table
    says pi/3) and the pelvis U(-shift_max, shift_max) across and along from the mattress's centre
    (see :func:`pressurepose.pose.root.draw_placement`).
    hanging_limbs: False (default): every limb starts over the mattress, its joints at least
    side_margin_m from the mattress's sides (the ``limbs_on_bed`` rule applies whatever the
    caller's flag; limbs started at the edge slide over it while settling), and a body resting with
    a limb hanging over the edge is rejected (``limb_off_bed``, :mod:`pressurepose.sim.simulate`); True: limbs may hang over the edge (the paper's
    partitions without "plo"). height_band: allowed |distal - proximal| height (the
    public code's 0.2 m; the paper's text says 10 cm).
    height_reference: what the distal joint's height is measured from. 'proximal' (default, the
    public code's rule): |distal - proximal| <= height_band. 'bed': the distal joint's height above
    the surface the body lies on is within bed_height_band (low, high) m; the default (-0.1, 0.3) is
    the proximal rule's 0.4 m band centred where a supine body's hips lie (about 0.1 m up), so
    supine bodies change little, while the upper limbs of a body on its side start near the bed
    (where the paper means them to be: "distal joints ... close to the surface of the bed") instead
    of up to 0.6 m above it (see the sampler's module docstring). Hands-behind-head arms keep their
    own band.
    clearance: start height of the lowest capsule surface above the mattress.
    collision_radius_scale: capsule radii in the self-collision tests, as a multiple of the body's
    capsules (1.2: the public sampler's SMPLify capsules are fuller than ours, see the sampler's
    module docstring; the physics uses the capsules as they are).
    mattress: (x_min, x_max, y_min, y_max) outline in the bed frame (for limbs_on_bed and the centre).
    candidates_per_round: limb candidates drawn per body in a first round, doubling each further
    round up to 16 times as many (a speed knob; it changes which samples a seed gives).
    off_bed_patience, bin_patience, max_bin_redraws, cross_patience, collision_patience: see the
    module docstring.
    poses: None, or a :class:`~pressurepose.pose.posefile.PoseFile`: every body takes its body pose
    from that file (a pose of the drawn roll's posture class, plus its noise) instead of the
    partition's limb draws, under the joint limits and collision rules (:mod:`pressurepose.pose.whole`);
    the partition then gives only the roll and must set no limb rule.
    """

    beta_range: float = 3.0
    yaw_max: float = math.pi / 6
    shift_max: float = 0.2
    shapes: str = "normal"
    beta_sd: float = 1.0
    placement: str = "centred"
    yaw_sd: float = 0.1
    across_sd_m: float = 0.03
    across_sd_lateral_m: float = 0.08
    head_gap_m: float = 0.16
    along_sd_m: float = 0.03
    hanging_limbs: bool = False
    side_margin_m: float = 0.1
    height_band: float = 0.2
    height_reference: str = "proximal"
    bed_height_band: tuple[float, float] = (-0.1, 0.3)
    clearance: float = 0.015
    mattress: tuple[float, float, float, float] = DEFAULT_MATTRESS
    candidates_per_round: int = 64
    off_bed_patience: int = 20
    bin_patience: int = 5000
    max_bin_redraws: int = 8
    cross_patience: int = 20
    collision_patience: int = 20
    collision_radius_scale: float = 1.2
    poses: PoseFile | None = None

    def __post_init__(self):
        for f in ("beta_range", "yaw_max", "shift_max", "height_band", "clearance", "beta_sd",
                  "yaw_sd", "across_sd_m", "across_sd_lateral_m", "head_gap_m", "along_sd_m", "side_margin_m"):
            require_non_negative(f"sampler {f}", getattr(self, f))
        require_positive("sampler collision_radius_scale", self.collision_radius_scale)
        if self.shapes not in SHAPES:
            raise BadInput(f"sampler shapes is {self.shapes!r}; expected one of {', '.join(SHAPES)}")
        if self.placement not in PLACEMENTS:
            raise BadInput(f"sampler placement is {self.placement!r}; expected one of {', '.join(PLACEMENTS)}")
        if not isinstance(self.hanging_limbs, (bool, np.bool_)):
            raise BadInput(f"sampler hanging_limbs is {self.hanging_limbs!r}; expected true or false")
        if self.height_reference not in HEIGHT_REFERENCES:
            raise BadInput(f"sampler height_reference is {self.height_reference!r}; expected one of "
                           f"{', '.join(HEIGHT_REFERENCES)}")
        lo_hi = tuple(float(v) for v in np.ravel(self.bed_height_band))
        if len(lo_hi) != 2 or not all(math.isfinite(v) for v in lo_hi) or not lo_hi[0] < lo_hi[1]:
            raise BadInput(f"sampler bed_height_band is {self.bed_height_band!r}; expected (low, high) metres "
                           f"with low < high")
        object.__setattr__(self, "bed_height_band", lo_hi)
        for f in ("candidates_per_round", "off_bed_patience", "bin_patience", "max_bin_redraws",
                  "cross_patience", "collision_patience"):
            require_whole(f"sampler {f}", getattr(self, f), 1)
        m = tuple(float(v) for v in self.mattress)
        if len(m) != 4 or not all(math.isfinite(v) for v in m) or not (m[0] < m[1] and m[2] < m[3]):
            raise BadInput(f"sampler mattress is {self.mattress!r}; expected (x_min, x_max, y_min, y_max) "
                           f"with x_min < x_max and y_min < y_max, metres")
        object.__setattr__(self, "mattress", m)
        if isinstance(self.poses, dict):
            object.__setattr__(self, "poses", PoseFile.from_dict(self.poses))
        if self.poses is not None and not isinstance(self.poses, PoseFile):
            raise BadInput(f"sampler poses is {self.poses!r}; expected None or a PoseFile")

    @property
    def mattress_centre(self) -> np.ndarray:
        x0, x1, y0, y1 = self.mattress
        return np.array([(x0 + x1) / 2, (y0 + y1) / 2])


# The paper's (and its public code's) sampler: shapes U(-3, 3), uniform placement, limbs may hang.
PAPER_SETTINGS = {"shapes": "uniform", "placement": "uniform", "hanging_limbs": True}


def paper_sampler(**overrides) -> SamplerConfig:
    """A :class:`SamplerConfig` with the paper's shape, placement and hanging-limb settings."""
    return SamplerConfig(**{**PAPER_SETTINGS, **overrides})
