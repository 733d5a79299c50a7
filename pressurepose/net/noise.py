"""The training noise model (paper section 5.2; figures from its public code): synthetic images made to
look like a real sensor's.

Per image: multiply by N(1, 0.2); add per-taxel N(0, 14) mmHg to the non-zero taxels; clip to
[0, clip_max]; keep the clean image's contact mask (zero taxels stay zero, and the contact channel
is the clean mask); blur with a per-image sigma ~ N(0.5, 0.2) taxels (clamped at 0), which replaces
the fixed blur of clean images.
"""

from __future__ import annotations

import torch

from pressurepose.net.train_config import NoiseConfig
from pressurepose.net.transforms import contact_map, to_device_async


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
    return noisy, mask, sigma
