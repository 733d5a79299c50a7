"""Input transforms of PressureNet: blur, Sobel edges, contact, upsampling, per-image normalisation.

Pure torch functions over batched images ``(..., H, W)`` (any leading shape, any device, float
dtypes). Boundaries are half-sample symmetric (scipy.ndimage's ``mode="reflect"``), so blurring
keeps an image's total and the functions agree with ``scipy.ndimage`` (tests check both).

The network input (paper section 4): pressure P, its Sobel edge magnitude E and the binary contact
map C_I, each upsampled (x2 bilinear for the 64 x 27 mat, giving 128 x 54) and normalised by its
own sum; Mod2 appends the two maps PMR reconstructed from Mod1's body.
"""

from __future__ import annotations

import functools
from dataclasses import dataclass

import torch
import torch.nn.functional as F

from pressurepose.errors import BadInput, require_non_negative, require_whole

MAX_UPSAMPLE = 8         # input zoom factors a model may use (the paper's 2 for the 64 x 27 mat)
MAX_BLUR_SIGMA = 10.0    # taxels


@dataclass(frozen=True)
class InputConfig:
    """How a pressure image becomes the network input.

    upsample: integer zoom factor (2 for the 64 x 27 mat as in the paper; 1 for dense mats).
    blur_sigma: Gaussian blur in taxels applied to every pressure image (paper: 0.5).
    edges_contact: include the Sobel edge and contact channels (False ablates them, paper Table 2).
    contact_floor_mmhg: readings at or below this pressure are dropped before the channels are made,
        so contact C_I means "reads more than the floor" (0: any non-zero reading, the paper's). Real
        mats read faint values over most of their area (PMD experiment I: 66 % of the taxels away
        from the body are non-zero; 99 % of them read under 5 mmHg); simulated ones read exactly 0
        off the body. A network that learned C_I = (p > 0) from simulation reads a real image's faint
        background as body area (docs/sim_to_real.md), so a floor applied to both makes the channel
        mean the same for simulated and real input.
    """

    upsample: int = 2
    blur_sigma: float = 0.5
    edges_contact: bool = True
    contact_floor_mmhg: float = 0.0

    def __post_init__(self):
        """BadInput naming the field (``inputs.<name>``) for a value no input transform can use."""
        require_whole("inputs.upsample", self.upsample, 1, MAX_UPSAMPLE)
        require_non_negative("inputs.blur_sigma", self.blur_sigma)
        if self.blur_sigma > MAX_BLUR_SIGMA:
            raise BadInput(f"inputs.blur_sigma is {self.blur_sigma!r} taxels; expected at most {MAX_BLUR_SIGMA:g} "
                           f"(a wider blur erases the image; the paper's is 0.5)")
        if not isinstance(self.edges_contact, bool):
            raise BadInput(f"inputs.edges_contact is {self.edges_contact!r}; expected true or false")
        require_non_negative("inputs.contact_floor_mmhg", self.contact_floor_mmhg)
        object.__setattr__(self, "upsample", int(self.upsample))
        object.__setattr__(self, "blur_sigma", float(self.blur_sigma))
        object.__setattr__(self, "contact_floor_mmhg", float(self.contact_floor_mmhg))

    def num_channels(self, extra: int = 0) -> int:
        """Input channels: P (+ E, C_I) (+ ``extra`` PMR maps for Mod2)."""
        return (3 if self.edges_contact else 1) + extra

    def input_size(self, rows: int, cols: int) -> tuple[int, int]:
        return rows * self.upsample, cols * self.upsample


# The small constant tensors below are made once per size, dtype and device (lru_cache) and outside
# inference mode, so that a constant first made during inference can still enter autograd.
@functools.lru_cache(maxsize=64)
def _symmetric_index(n: int, pad: int, device) -> torch.Tensor:
    """Indices (n + 2 pad,) into a length-n axis for half-sample symmetric padding (any pad)."""
    with torch.inference_mode(False):
        i = torch.arange(-pad, n + pad, device=device) % (2 * n)
        return torch.where(i < n, i, 2 * n - 1 - i)


@functools.lru_cache(maxsize=64)
def _gaussian_kernel(sigma: float, radius: int, dtype, device) -> torch.Tensor:
    with torch.inference_mode(False):
        return gaussian_kernels(torch.tensor([sigma], dtype=dtype, device=device), radius)


@functools.lru_cache(maxsize=16)
def _sobel_kernels(dtype, device) -> torch.Tensor:
    with torch.inference_mode(False):
        d = torch.tensor([-1.0, 0.0, 1.0], dtype=dtype, device=device)
        s = torch.tensor([1.0, 2.0, 1.0], dtype=dtype, device=device)
        return torch.stack([torch.outer(d, s), torch.outer(s, d)])[:, None]  # d/drow, d/dcol


def _pad_symmetric(x: torch.Tensor, pad_h: int, pad_w: int) -> torch.Tensor:
    """Pad the last two axes of x by (pad_h, pad_w) on each side, half-sample symmetric."""
    h, w = x.shape[-2:]
    if pad_h:
        x = x.index_select(-2, _symmetric_index(h, pad_h, x.device))
    if pad_w:
        x = x.index_select(-1, _symmetric_index(w, pad_w, x.device))
    return x


def gaussian_kernels(sigma: torch.Tensor, radius: int) -> torch.Tensor:
    """Normalised 1-D Gaussian kernels (N, 2 radius + 1) for sigmas (N,) in pixels; sigma <= 0 is
    the identity (a delta kernel)."""
    x = torch.arange(-radius, radius + 1, dtype=sigma.dtype, device=sigma.device)
    s = sigma.clamp_min(1e-6)[:, None]
    k = torch.exp(-0.5 * (x[None] / s) ** 2)
    return k / k.sum(-1, keepdim=True)


def to_device_async(t: torch.Tensor, device: torch.device, dtype: torch.dtype | None = None) -> torch.Tensor:
    """``t`` on ``device`` (and ``dtype``) without the host waiting for the GPU: a CPU tensor bound for
    a GPU goes through pinned memory, from which the copy is queued like a kernel."""
    if device.type == "cuda" and t.device.type == "cpu":
        t = t.pin_memory()
    return t.to(device=device, dtype=dtype, non_blocking=True)


def gaussian_blur(images: torch.Tensor, sigma: float | torch.Tensor, truncate: float = 4.0) -> torch.Tensor:
    """Gaussian blur of images (..., H, W) with standard deviation ``sigma`` in pixels.

    sigma: a number, or a tensor broadcastable to the leading shape ``images.shape[:-2]`` (one
    sigma per image, e.g. the noise model's random blur). The kernel is truncated at
    ``truncate`` sigma like ``scipy.ndimage.gaussian_filter``; the total of each image is kept.
    """
    lead, (h, w) = images.shape[:-2], images.shape[-2:]
    n = lead.numel()
    if isinstance(sigma, (int, float)):  # one sigma for all: a cached kernel
        radius = int(truncate * max(float(sigma), 0.0) + 0.5) if n else 0
        if radius == 0:
            return images
        k = _gaussian_kernel(max(float(sigma), 0.0), radius, images.dtype, images.device).expand(n, -1)
    else:
        # the kernel's size from the sigmas where they are (a CPU tensor: no wait for the GPU), then the
        # sigmas to the images' device without waiting either
        sig = torch.as_tensor(sigma, dtype=images.dtype).clamp_min(0)
        radius = int(truncate * float(sig.max()) + 0.5) if sig.numel() and n else 0
        if radius == 0:
            return images
        sig = to_device_async(sig, images.device).expand(lead).reshape(-1)
        k = gaussian_kernels(sig, radius)  # (N, K)
    x = _pad_symmetric(images.reshape(1, n, h, w), radius, radius)
    x = F.conv2d(x, k[:, None, :, None], groups=n)  # along H
    x = F.conv2d(x, k[:, None, None, :], groups=n)  # along W
    return x.reshape(images.shape)


def sobel_magnitude(images: torch.Tensor) -> torch.Tensor:
    """Sobel edge magnitude sqrt(gx^2 + gy^2) of images (..., H, W), as
    ``hypot(ndimage.sobel(p, 0), ndimage.sobel(p, 1))`` (mode reflect)."""
    lead, (h, w) = images.shape[:-2], images.shape[-2:]
    x = _pad_symmetric(images.reshape(-1, 1, h, w), 1, 1)
    g = F.conv2d(x, _sobel_kernels(images.dtype, images.device))
    return torch.hypot(g[:, 0], g[:, 1]).reshape(*lead, h, w)


def apply_floor(pressure: torch.Tensor, floor: float) -> torch.Tensor:
    """Pressure images (..., H, W) with the readings at or below ``floor`` (mmHg) set to 0."""
    if floor <= 0:
        return pressure
    return torch.where(pressure > floor, pressure, torch.zeros_like(pressure))


def contact_map(pressure: torch.Tensor) -> torch.Tensor:
    """Binary contact map C_I (same shape, same dtype): 1 where the pressure is non-zero."""
    return (pressure > 0).to(pressure.dtype)


def upsample(images: torch.Tensor, factor: int) -> torch.Tensor:
    """Bilinear zoom of images (..., H, W) to (..., factor H, factor W), corners aligned, as
    ``scipy.ndimage.zoom(image, factor, order=1)`` (the paper's 64 x 27 -> 128 x 54)."""
    if factor == 1:
        return images
    lead, (h, w) = images.shape[:-2], images.shape[-2:]
    x = F.interpolate(images.reshape(-1, 1, h, w), size=(h * factor, w * factor), mode="bilinear",
                      align_corners=True)
    return x.reshape(*lead, h * factor, w * factor)


def normalise_per_image(images: torch.Tensor, total: float = 1.0) -> torch.Tensor:
    """Scale each image (..., H, W) so that it sums to ``total`` (all-zero images stay zero)."""
    s = images.sum((-2, -1), keepdim=True)
    return torch.where(s != 0, images * (total / torch.where(s != 0, s, torch.ones_like(s))),
                       torch.zeros_like(images))


def map_channels(maps: torch.Tensor, config: InputConfig = InputConfig()) -> torch.Tensor:
    """Maps (B, K, R, C) on the mat's grid -> network channels (B, K, f R, f C): upsampled, then
    each normalised by its own sum, set to the number of input pixels (mean 1) rather than 1 (a
    constant factor that keeps the first layer's inputs near unit scale for any mat size)."""
    x = upsample(maps, config.upsample)
    return normalise_per_image(x, total=float(x.shape[-2] * x.shape[-1]))


def input_channels(pressure: torch.Tensor, config: InputConfig = InputConfig(), *,
                   contact: torch.Tensor | None = None, blur_sigma: float | torch.Tensor | None = None,
                   ) -> torch.Tensor:
    """The network input (B, K, f R, f C) from pressure images (B, R, C) on the mat's grid: the
    blurred pressure P, its Sobel edges E and the contact map C_I (K = 3; K = 1 without edges and
    contact), through :func:`map_channels`. Mod2 appends ``map_channels`` of its PMR maps.

    contact: the binary contact map (B, R, C); default: the taxels of ``pressure`` above
        ``config.contact_floor_mmhg`` (the readings at or below it are dropped first). The noise
        model passes the clean, floored image's mask, and then ``pressure`` is used as given (the
        training path floors the clean image before adding noise: :func:`apply_floor`).
        blur_sigma: default ``config.blur_sigma``; a (B,) tensor blurs each image with its own sigma.
    """
    if contact is None:
        pressure = apply_floor(pressure, config.contact_floor_mmhg)
        contact = contact_map(pressure)
    p = gaussian_blur(pressure, config.blur_sigma if blur_sigma is None else blur_sigma)
    chans = [p, sobel_magnitude(p), contact.to(p.dtype)] if config.edges_contact else [p]
    return map_channels(torch.stack(chans, 1), config)
