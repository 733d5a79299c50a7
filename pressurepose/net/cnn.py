"""The CNN of one PressureNet module (paper appendix B.1, Fig. 12), exactly:

conv 7x7 stride 2 pad 3 -> 192, tanh, dropout 0.1, max-pool 3 stride 2;
conv 3x3 -> 192; conv 3x3 -> 384; conv 3x3 -> 384 (stride 1, no padding; each tanh, dropout 0.1);
linear (flattened features) -> 88 outputs. For a 128 x 54 input the flattened size is 67,200.

``channels`` changes the four layers' widths (the paper's (192, 192, 384, 384) by default). The
named widths are :data:`pressurepose.net.train_config.CNN_VARIANTS`: the paper's and ``half`` (half
as wide, about 3.5x faster to train on a CPU), which the shipped model uses.

Gender: as in the paper and its authors' code, the binary gender flag selects the body model the
CNN's parameters drive (see :mod:`pressurepose.net.model`); the CNN itself does not see it. The
option ``gender_input=True`` instead appends the flag to the flattened features (67,201 -> 88),
a variant not in the paper.
"""

from __future__ import annotations

import torch
from torch import nn

from pressurepose.net.train_config import PAPER_CHANNELS

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


def flattened_size(height: int, width: int, channels: int = PAPER_CHANNELS[-1]) -> int:
    """Number of features entering the linear layer for an input of height x width."""
    h, w = conv_output_size(height, width)
    return channels * h * w


def _mkldnn_fused_available() -> bool:
    return (torch.backends.mkldnn.is_available() and torch.backends.mkldnn.enabled
            and hasattr(torch.ops.mkldnn, "_convolution_pointwise")
            and hasattr(torch.ops.mkldnn, "_reorder_convolution_weight"))


class PressureCNN(nn.Module):
    """CNN (B, in_channels, H, W) -> (B, 88). Input must be at least 31 x 31 pixels."""

    def __init__(self, in_channels: int, height: int, width: int, dropout: float = 0.1,
                 gender_input: bool = False, num_outputs: int = NUM_OUTPUTS,
                 channels: tuple[int, int, int, int] = PAPER_CHANNELS):
        super().__init__()
        h, w = conv_output_size(height, width)
        if h < 1 or w < 1:
            raise ValueError(f"input {height} x {width} is too small for the CNN (needs >= 31 x 31)")
        if len(channels) != 4 or min(channels) < 1:
            raise ValueError(f"channels {tuple(channels)}: expected four positive layer widths")
        c1, c2, c3, c4 = map(int, channels)
        self.gender_input = gender_input
        self.features = nn.Sequential(
            nn.Conv2d(in_channels, c1, kernel_size=7, stride=2, padding=3), nn.Tanh(), nn.Dropout(dropout),
            nn.MaxPool2d(3, stride=2),
            nn.Conv2d(c1, c2, kernel_size=3), nn.Tanh(), nn.Dropout(dropout),
            nn.Conv2d(c2, c3, kernel_size=3), nn.Tanh(), nn.Dropout(dropout),
            nn.Conv2d(c3, c4, kernel_size=3), nn.Tanh(), nn.Dropout(dropout),
        )
        self.num_features = flattened_size(height, width, c4)
        self.fc = nn.Linear(self.num_features + int(gender_input), num_outputs)
        # channels-last convolutions and max-pooling are much faster on CPUs (the pool ~20x); the
        # weights' memory layout changes nothing else (state dicts are saved contiguous)
        self.features.to(memory_format=torch.channels_last)
        self._packed: dict = {}  # inference: oneDNN-packed conv weights per input shape (see _fused_features)

    @property
    def convs(self) -> list[nn.Conv2d]:
        return [m for m in self.features if isinstance(m, nn.Conv2d)]

    def forward(self, x: torch.Tensor, gender: torch.Tensor | None = None) -> torch.Tensor:
        """x (B, in_channels, H, W); gender (B,) 0 female / 1 male, used only with gender_input."""
        x = x.contiguous(memory_format=torch.channels_last)
        if self.training:
            f = self.features(x)
        elif (not torch.is_grad_enabled() and x.device.type == "cpu" and x.dtype == torch.float32
              and self.fc.weight.dtype == torch.float32 and _mkldnn_fused_available()):
            f = self._fused_features(x)
        else:  # dropout is the identity and max-pool commutes with the increasing tanh: pool first
            conv1, pool = self.features[0], self.features[3]
            f = self.features[4:](torch.tanh(pool(conv1(x))))
        f = f.flatten(1)
        if self.gender_input:
            f = torch.cat([f, gender.to(f.dtype)[:, None]], 1)
        return self.fc(f)

    def _fused_features(self, x: torch.Tensor) -> torch.Tensor:
        """The eval-mode features on a CPU without autograd: the same layers (pool first, as in
        ``forward``) through oneDNN with its weights reordered once (kept per input shape until a
        weight changes) and each 3x3 conv's tanh fused into it; ~20 % faster than the plain
        layers at batch 1, equal within float rounding (tests check)."""
        convs = self.convs
        stamp = tuple((c.weight.data_ptr(), c.weight._version) for c in convs)
        key = tuple(x.shape)
        packed = self._packed.get(key)
        if packed is None or packed[0] != stamp:
            if packed is not None or len(self._packed) >= 4:  # weights changed, or too many shapes
                self._packed.clear()
            packed = (stamp, self._pack(convs, list(x.shape)))
            self._packed[key] = packed
        mk = torch.ops.mkldnn
        weights = packed[1]
        c = convs[0]
        y = mk._convolution_pointwise(x, weights[0], c.bias, list(c.padding), list(c.stride), list(c.dilation),
                                      1, "none", [], "")
        y = torch.tanh_(self.features[3](y))
        for c, w in zip(convs[1:], weights[1:]):
            y = mk._convolution_pointwise(y, w, c.bias, list(c.padding), list(c.stride), list(c.dilation),
                                          1, "tanh", [], "")
        return y

    def _pack(self, convs: list[nn.Conv2d], shape: list[int]) -> list[torch.Tensor]:
        out = []
        for i, c in enumerate(convs):
            out.append(torch.ops.mkldnn._reorder_convolution_weight(
                c.weight.detach(), list(c.padding), list(c.stride), list(c.dilation), 1, shape))
            h = (shape[2] + 2 * c.padding[0] - c.kernel_size[0]) // c.stride[0] + 1
            w = (shape[3] + 2 * c.padding[1] - c.kernel_size[1]) // c.stride[1] + 1
            if i == 0:  # the max-pool
                h, w = (h - 3) // 2 + 1, (w - 3) // 2 + 1
            shape = [shape[0], c.out_channels, h, w]
        return out
