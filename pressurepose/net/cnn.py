"""The CNN of one PressureNet module (paper appendix B.1, Fig. 12), exactly:

conv 7x7 stride 2 pad 3 -> 192, tanh, dropout 0.1, max-pool 3 stride 2;
conv 3x3 -> 192; conv 3x3 -> 384; conv 3x3 -> 384 (stride 1, no padding; each tanh, dropout 0.1);
linear (flattened features) -> 88 outputs. For a 128 x 54 input the flattened size is 67,200.

Gender: as in the paper and its authors' code, the binary gender flag selects the body model the
CNN's parameters drive (see :mod:`pressurepose.net.model`); the CNN itself does not see it. The
option ``gender_input=True`` instead appends the flag to the flattened features (67,201 -> 88),
a variant not in the paper.
"""

from __future__ import annotations

import torch
from torch import nn

NUM_OUTPUTS = 88  # 10 betas, 3 translation, 6 root (x, y) pairs, 69 joint angles


def conv_output_size(height: int, width: int) -> tuple[int, int]:
    """Spatial size of the last conv layer's output for an input of height x width."""
    def conv(n, k, s, p):
        return (n + 2 * p - k) // s + 1

    h, w = conv(height, 7, 2, 3), conv(width, 7, 2, 3)
    h, w = conv(h, 3, 2, 0), conv(w, 3, 2, 0)
    for _ in range(3):
        h, w = conv(h, 3, 1, 0), conv(w, 3, 1, 0)
    return h, w


def flattened_size(height: int, width: int, channels: int = 384) -> int:
    """Number of features entering the linear layer for an input of height x width."""
    h, w = conv_output_size(height, width)
    return channels * h * w


class PressureCNN(nn.Module):
    """CNN (B, in_channels, H, W) -> (B, 88). Input must be at least 31 x 31 pixels."""

    def __init__(self, in_channels: int, height: int, width: int, dropout: float = 0.1,
                 gender_input: bool = False, num_outputs: int = NUM_OUTPUTS):
        super().__init__()
        h, w = conv_output_size(height, width)
        if h < 1 or w < 1:
            raise ValueError(f"input {height} x {width} is too small for the CNN (needs >= 31 x 31)")
        self.gender_input = gender_input
        self.features = nn.Sequential(
            nn.Conv2d(in_channels, 192, kernel_size=7, stride=2, padding=3), nn.Tanh(), nn.Dropout(dropout),
            nn.MaxPool2d(3, stride=2),
            nn.Conv2d(192, 192, kernel_size=3), nn.Tanh(), nn.Dropout(dropout),
            nn.Conv2d(192, 384, kernel_size=3), nn.Tanh(), nn.Dropout(dropout),
            nn.Conv2d(384, 384, kernel_size=3), nn.Tanh(), nn.Dropout(dropout),
        )
        self.num_features = flattened_size(height, width)
        self.fc = nn.Linear(self.num_features + int(gender_input), num_outputs)
        # channels-last convolutions and max-pooling are much faster on CPUs (the pool ~20x); the
        # weights' memory layout changes nothing else (state dicts are saved contiguous)
        self.features.to(memory_format=torch.channels_last)

    def forward(self, x: torch.Tensor, gender: torch.Tensor | None = None) -> torch.Tensor:
        """x (B, in_channels, H, W); gender (B,) 0 female / 1 male, used only with gender_input."""
        x = x.contiguous(memory_format=torch.channels_last)
        if self.training:
            f = self.features(x)
        else:  # dropout is the identity and max-pool commutes with the increasing tanh: pool first
            conv1, pool = self.features[0], self.features[3]
            f = self.features[4:](torch.tanh(pool(conv1(x))))
        f = f.flatten(1)
        if self.gender_input:
            f = torch.cat([f, gender.to(f.dtype)[:, None]], 1)
        return self.fc(f)
