"""PressureNet's output parameterisation: the CNN's 88 numbers -> body parameters within limits.

Layout of the 88 raw outputs (as the authors' code): 0:10 betas, 10:13 translation, 13:19 root
rotation pairs (x_u, x_v, x_w, y_u, y_v, y_w), 19:88 the 69 joint angles (SMPL joints 1..23, local
axis-angle x, y, z).

Each raw output is first mapped to an unconstrained value ``offset + gain * scale * raw``: the
scale is the parameter's range (paper appendix B.1: outputs are multiplied by the range of each
parameter), the gain (default 0.1) keeps an untrained network near its home pose, and the offset
is the home value (betas 0, the dataset's mean translation, root pairs (1, 0) = supine, joint
angles at the middle of their range). Mod2 adds its scaled outputs to Mod1's unconstrained values
(residuals). Then the soft limits (paper appendix B.1):

* betas: ``3 tanh(b / 3)``;
* joint angles: ``mid + (range / 2) tanh((raw - mid) 2 / range)`` with the joint's range inflated
  about its middle by 1.2, so every angle stays inside the inflated range;
* root: Euler angles atan2(y, x) of the pairs (:mod:`pressurepose.net.rotations`), converted to
  SMPL's root axis-angle;
* translation: unconstrained (metres, the body model's ``transl``).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import torch
from torch import nn

from pressurepose.body.joints import JOINT_NAMES
from pressurepose.errors import BadInput, require_numbers, require_positive
from pressurepose.net.rotations import euler_to_root_axis_angle, pairs_to_euler

NUM_BETAS = 10
BETA_LIMIT = 3.0
SL_BETAS, SL_TRANSL, SL_ROOT, SL_ANGLES = slice(0, 10), slice(10, 13), slice(13, 19), slice(19, 88)

# Ranges (degrees, SMPL local axes x, y, z) for the degrees of freedom the pose sampler leaves at 0
# (as in the paper's public code: spine, neck, ankles, wrists ...), from normal adult ranges of motion
# (AAOS / Soucie et al. 2011 / Roaas & Andersson 1982): SMPL's +x flexes the trunk, neck, knee and
# points the foot down. Spine: lumbar + thoracic flexion ~80, extension ~30, lateral bending ~35,
# rotation ~45 per side, split over spine1-3. Neck: cervical flexion ~50, extension ~60, lateral
# ~45, rotation ~80 per side, split between neck and head. Ankle: plantar flexion ~50, dorsiflexion
# ~20, inversion/eversion and abduction ~25 either way. Foot (toes): extension ~70, flexion ~40.
# Wrist: flexion/extension ~75, deviation ~25, forearm twist ~45 at the wrist. Hand: +-20. Off-axes
# of the hinge joints (knee, elbow): +-3 (their sampled range is one axis). y and z ranges are
# symmetric, so one entry serves the left and the mirrored right joint.
ANATOMICAL_RANGES_DEG: dict[str, tuple[tuple[float, float], ...]] = {
    "spine": ((-10.0, 27.0), (-15.0, 15.0), (-12.0, 12.0)),
    "neck": ((-30.0, 25.0), (-40.0, 40.0), (-22.0, 22.0)),
    "head": ((-30.0, 25.0), (-40.0, 40.0), (-22.0, 22.0)),
    "ankle": ((-20.0, 50.0), (-25.0, 25.0), (-25.0, 25.0)),
    "foot": ((-70.0, 40.0), (-10.0, 10.0), (-10.0, 10.0)),
    "wrist": ((-45.0, 45.0), (-25.0, 25.0), (-75.0, 75.0)),
    "hand": ((-20.0, 20.0), (-20.0, 20.0), (-20.0, 20.0)),
    "hinge": ((-3.0, 3.0), (-3.0, 3.0), (-3.0, 3.0)),
}


def _anatomical_key(name: str) -> str:
    for key in ("spine", "neck", "head", "ankle", "foot", "wrist", "hand"):
        if key in name:
            return key
    return "hinge"


def sampled_joint_limits() -> tuple[np.ndarray, np.ndarray]:
    """The pose sampler's joint ranges (24, 3), lower and upper, radians: the union over partitions
    (the nominal limits and the hands-behind-head partition's wider shoulders)."""
    from pressurepose.pose.limits import joint_limits

    nominal, wide = joint_limits(None), joint_limits("hands_behind_head")
    return np.minimum(nominal.lower, wide.lower), np.maximum(nominal.upper, wide.upper)


def network_joint_ranges(inflate: float = 1.2, sampled: tuple[np.ndarray, np.ndarray] | None = None,
                         ) -> tuple[np.ndarray, np.ndarray]:
    """Lower and upper limits (69,) of the network's joint angles, radians, inflated about their
    middle by ``inflate``.

    Each degree of freedom takes the sampler's range (``sampled``, default
    :func:`sampled_joint_limits`) where that range is wider than 1 degree, else the anatomical
    range of :data:`ANATOMICAL_RANGES_DEG` (also the range of a sampled axis that lies inside it
    would be too narrow for the network to represent what it sees, e.g. a hinge's off-axes).
    """
    lower, upper = sampled_joint_limits() if sampled is None else (np.asarray(sampled[0], float),
                                                                    np.asarray(sampled[1], float))
    lo, hi = lower[1:].copy(), upper[1:].copy()  # joints 1..23
    for j, name in enumerate(JOINT_NAMES[1:]):
        anat = np.deg2rad(np.array(ANATOMICAL_RANGES_DEG[_anatomical_key(name)]))
        narrow = hi[j] - lo[j] < np.deg2rad(1.0)
        lo[j] = np.where(narrow, np.minimum(anat[:, 0], lo[j]), lo[j])
        hi[j] = np.where(narrow, np.maximum(anat[:, 1], hi[j]), hi[j])
    mid, half = (lo + hi) / 2, inflate * (hi - lo) / 2
    return (mid - half).reshape(-1), (mid + half).reshape(-1)


@dataclass(frozen=True)
class OutputConfig:
    """Everything the output layer needs; stored with a checkpoint.

    angle_lower, angle_upper: inflated joint-angle limits (69,) radians.
    transl_offset, transl_scale: home translation and its range (3,) m (the dataset's mean and
    range, or the mat's centre and size). gain: see the module docstring.
    """

    angle_lower: tuple[float, ...]
    angle_upper: tuple[float, ...]
    transl_offset: tuple[float, float, float]
    transl_scale: tuple[float, float, float]
    gain: float = 0.1

    def __post_init__(self):
        """BadInput naming the field (``outputs.<name>``) for values no output layer can use."""
        n = SL_ANGLES.stop - SL_ANGLES.start  # 69 joint angles
        lo = require_numbers("outputs.angle_lower", self.angle_lower, n)
        hi = require_numbers("outputs.angle_upper", self.angle_upper, n)
        if not all(a < b for a, b in zip(lo, hi)):
            j = next(i for i, (a, b) in enumerate(zip(lo, hi)) if not a < b)
            raise BadInput(f"outputs.angle_lower[{j}] = {lo[j]!r} is not below outputs.angle_upper[{j}] = {hi[j]!r}")
        require_positive("outputs.gain", self.gain)
        for name, v in (("angle_lower", lo), ("angle_upper", hi),
                        ("transl_offset", require_numbers("outputs.transl_offset", self.transl_offset, 3)),
                        ("transl_scale", require_numbers("outputs.transl_scale", self.transl_scale, 3, positive=True)),
                        ("gain", float(self.gain))):
            object.__setattr__(self, name, v)

    @staticmethod
    def default(transl_offset, transl_scale, inflate: float = 1.2, gain: float = 0.1,
                sampled: tuple[np.ndarray, np.ndarray] | None = None) -> "OutputConfig":
        lo, hi = network_joint_ranges(inflate, sampled)
        return OutputConfig(tuple(map(float, lo)), tuple(map(float, hi)),
                            tuple(map(float, transl_offset)), tuple(map(float, transl_scale)), float(gain))


@dataclass
class BodyParams:
    """Body parameters estimated by one module (batch B).

    unconstrained (B, 88): values before the soft limits (Mod2 adds its residuals here).
    betas (B, 10); transl (B, 3) m; root_euler (B, 3) (roll, pitch, yaw) rad; global_orient (B, 3)
    and body_pose (B, 69) SMPL axis-angle, rad.
    """

    unconstrained: torch.Tensor
    betas: torch.Tensor
    transl: torch.Tensor
    root_euler: torch.Tensor
    global_orient: torch.Tensor
    body_pose: torch.Tensor

    @property
    def pose(self) -> torch.Tensor:
        """SMPL pose (B, 72), root first."""
        return torch.cat([self.global_orient, self.body_pose], -1)


class OutputLayer(nn.Module):
    """Raw CNN outputs (B, 88) [+ a base estimate's unconstrained values] -> :class:`BodyParams`."""

    def __init__(self, config: OutputConfig):
        super().__init__()
        self.config = config
        # made in numpy and turned into tensors one by one: built on the meta device (the checkpoint's
        # shape check), torch.cat would import PyTorch's compiler, more than a second of start-up
        lo = np.asarray(config.angle_lower, np.float32)
        hi = np.asarray(config.angle_upper, np.float32)
        mid, width = (lo + hi) / np.float32(2), hi - lo
        offset = np.concatenate([np.zeros(10, np.float32), np.asarray(config.transl_offset, np.float32),
                                 np.array([1, 1, 1, 0, 0, 0], np.float32), mid])
        scale = np.concatenate([np.full(10, 2 * BETA_LIMIT, np.float32), np.asarray(config.transl_scale, np.float32),
                                np.ones(6, np.float32), width])
        for name, value in (("offset", offset), ("scale", np.float32(config.gain) * scale), ("angle_mid", mid),
                            ("angle_range", width), ("angle_lower", lo), ("angle_upper", hi)):
            self.register_buffer(name, torch.tensor(value), persistent=False)

    def forward(self, raw: torch.Tensor, base: BodyParams | None = None) -> BodyParams:
        raw = raw.float()
        start = self.offset if base is None else base.unconstrained
        u = start + self.scale * raw
        betas = BETA_LIMIT * torch.tanh(u[:, SL_BETAS] / BETA_LIMIT)
        half = self.angle_range / 2
        angles = self.angle_mid + half * torch.tanh((u[:, SL_ANGLES] - self.angle_mid) / half)
        # the tanh keeps angles inside; the clamp only removes float rounding at saturation
        angles = torch.minimum(torch.maximum(angles, self.angle_lower), self.angle_upper)
        euler = pairs_to_euler(u[:, SL_ROOT])
        return BodyParams(unconstrained=u, betas=betas, transl=u[:, SL_TRANSL], root_euler=euler,
                          global_orient=euler_to_root_axis_angle(euler), body_pose=angles)
