"""The training noise model (paper section 5.2; figures from its public code): synthetic images made to
look like a real sensor's.

Per image: multiply by N(1, 0.2); add per-taxel N(0, 14) mmHg to the non-zero taxels; clip to
[0, clip_max]; keep the clean image's contact mask (zero taxels stay zero, and the contact channel
is the clean mask); blur with a per-image sigma ~ N(0.5, 0.2) taxels (clamped at 0), which replaces
the fixed blur of clean images.

Not in the paper, off by default: a mat shorter than the body (``cut_feet_p``). With that
probability an image loses the last 1 to ``cut_feet_rows`` rows of its contact at the foot end
(pressure and contact mask; the labels keep the whole body), as when a mat ends at the heels or
calves: PMD experiment I's 1.79 m FSA mat is shorter than its taller subjects, while simulated
bodies lie inside the sensing area.
"""

from __future__ import annotations

from dataclasses import dataclass

import torch

from pressurepose.errors import BadInput
from pressurepose.net.transforms import contact_map, to_device_async


@dataclass(frozen=True)
class NoiseConfig:
    """Parameters of :func:`add_noise` (units: mmHg for pressures, taxels for blur)."""

    mult_std: float = 0.2
    add_std: float = 14.0
    clip_max: float = 100.0
    blur_mean: float = 0.5
    blur_std: float = 0.2
    cut_feet_p: float = 0.0
    cut_feet_rows: int = 8

    def __post_init__(self):
        if not 0 <= self.cut_feet_p <= 1 or isinstance(self.cut_feet_rows, bool) or self.cut_feet_rows < 1:
            raise BadInput(f"cut_feet_p = {self.cut_feet_p} must be in [0, 1] and cut_feet_rows = "
                             f"{self.cut_feet_rows} >= 1")


def _randn(shape, generator: torch.Generator, like: torch.Tensor | None) -> torch.Tensor:
    """Standard normal draws (float32) from ``generator``, on ``like``'s device and dtype (None: left
    on the generator's device). The copy does not wait for the GPU to finish its queued work."""
    z = torch.randn(shape, generator=generator, device=generator.device, dtype=torch.float32)
    return z if like is None else to_device_async(z, like.device, like.dtype)


def add_noise(pressure: torch.Tensor, generator: torch.Generator, config: NoiseConfig = NoiseConfig(),
              ) -> tuple[torch.Tensor, torch.Tensor, torch.Tensor]:
    """Noisy copies of pressure images (B, R, C).

    Returns (noisy (B, R, C), contact mask of the clean images (B, R, C), blur sigmas (B,), on the
    generator's device) to be passed on to :func:`pressurepose.net.transforms.input_channels`. Draws
    only from ``generator``.
    """
    b = pressure.shape[0]
    mask = contact_map(pressure)
    scale = 1.0 + config.mult_std * _randn((b, 1, 1), generator, pressure)
    additive = config.add_std * _randn(pressure.shape, generator, pressure)
    noisy = ((pressure * scale + additive * mask).clamp(0.0, config.clip_max)) * mask
    # left on the generator's device: the blur reads the largest sigma for its kernel size, which on a
    # GPU tensor would wait for the GPU every step
    sigma = (config.blur_mean + config.blur_std * _randn((b,), generator, None).to(pressure.dtype)).clamp_min(0.0)
    if config.cut_feet_p > 0:  # drawn after the rest, so the paper's noise is the same with or without
        keep = _keep_rows(mask, generator, config)
        noisy, mask = noisy * keep, mask * keep
    return noisy, mask, sigma


def _keep_rows(mask: torch.Tensor, generator: torch.Generator, config: NoiseConfig) -> torch.Tensor:
    """(B, R, 1) 0 on the rows a mat shorter than the body would miss: for a share ``cut_feet_p``
    of the images, the last k rows of contact (k uniform in 1..cut_feet_rows) and every row after."""
    b, r = mask.shape[:2]
    u = torch.rand((2, b), generator=generator, device=generator.device).to(mask.device)
    k = 1 + (u[1] * config.cut_feet_rows).long().clamp_max(config.cut_feet_rows - 1)
    rows = torch.arange(r, device=mask.device)
    touched = mask.amax(dim=2) > 0  # (B, R)
    last = torch.where(touched, rows, torch.full_like(rows, -1)).amax(dim=1)  # -1: no contact
    cut = torch.where((u[0] < config.cut_feet_p) & (last >= 0), last - k + 1, torch.full_like(last, r))
    return (rows[None, :] < cut[:, None]).to(mask.dtype)[:, :, None]
