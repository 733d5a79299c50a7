"""PMR, pressure map reconstruction (paper appendix B.1): sink-depth, pressure and contact maps on
the mat's grid from a posed mesh, differentiably and without Python loops over vertices or taxels.

Given vertices (B, V, 3) in the bed frame (metres; z = 0 is the unloaded mattress top; taxel
(r, c) covers x in [c, c+1) * pitch_col, y in [r, r+1) * pitch_row, as
:class:`pressurepose.mat.MatSpec`):

1. each vertex falls in the taxel under it; vertices off the mat are ignored;
2. per taxel, the lowest vertex's height is the *depth* (negative = sunk into the mattress), a
   per-taxel minimum done with ``scatter_reduce("amin")`` (its gradient flows to that vertex's z);
3. taxels no vertex fell in take the mean depth of their non-empty 8-neighbours (``fill_passes``
   times, filling holes up to that many taxels deep); taxels still empty (no body above them) get
   ``empty_depth_m``;
4. maps: the reconstructed pressure map ``Q = q_scale * max(-depth, 0)`` (the sink depth; the
   paper computes Q "based on the distance that the human mesh sinks into the bed", its code in
   mm, hence q_scale = 1000), the contact map ``depth < 0`` and, for training losses, a soft
   contact ``sigmoid(-depth / contact_softness_m)``.

The depth has the meaning and sign of the dataset's ``depth`` field and PressurePose's
``mesh_depth``. The bed is flat (the paper's bed angle 0).
"""

from __future__ import annotations

from dataclasses import dataclass

import torch
import torch.nn.functional as F

from pressurepose.mat import MatSpec


@dataclass(frozen=True)
class PMRConfig:
    """fill_passes: neighbour-filling passes for empty taxels; empty_depth_m: depth of taxels with
    no body over them; contact_softness_m: sigmoid width of the soft contact; q_scale: Q units per
    metre of sink (1000: mm)."""

    fill_passes: int = 2
    empty_depth_m: float = 1.0
    contact_softness_m: float = 0.002
    q_scale: float = 1000.0


@dataclass
class PMRMaps:
    """PMR output, each (B, R, C): depth (m), q (sink, q_scale units), contact_soft in (0, 1),
    contact in {0, 1} (no gradient)."""

    depth: torch.Tensor
    q: torch.Tensor
    contact_soft: torch.Tensor
    contact: torch.Tensor


_NEIGHBOURS = torch.tensor([[1.0, 1.0, 1.0], [1.0, 0.0, 1.0], [1.0, 1.0, 1.0]])


def lowest_vertex_map(verts: torch.Tensor, grid: MatSpec, empty_value: float) -> tuple[torch.Tensor, torch.Tensor]:
    """Per-taxel minimum vertex height (B, R, C) and the mask (B, R, C) of taxels holding a vertex.

    Taxels without a vertex hold ``empty_value``.
    """
    b, v, _ = verts.shape
    r, c = grid.rows, grid.cols
    col = torch.floor(verts[..., 0] / grid.pitch_col_m).long()
    row = torch.floor(verts[..., 1] / grid.pitch_row_m).long()
    inside = (row >= 0) & (row < r) & (col >= 0) & (col < c)
    batch = torch.arange(b, device=verts.device)[:, None] * (r * c)
    dump = b * r * c  # one extra slot collects the vertices off the mat
    flat = torch.where(inside, batch + row * c + col, torch.full_like(row, dump)).reshape(-1)
    init = torch.full((dump + 1,), float(empty_value), dtype=verts.dtype, device=verts.device)
    low = init.scatter_reduce(0, flat, verts[..., 2].reshape(-1), reduce="amin", include_self=False)
    count = torch.zeros(dump + 1, dtype=verts.dtype, device=verts.device).scatter_add_(
        0, flat, torch.ones_like(flat, dtype=verts.dtype))
    return low[:dump].reshape(b, r, c), count[:dump].reshape(b, r, c) > 0


def fill_empty(values: torch.Tensor, filled: torch.Tensor, passes: int, empty_value: float) -> torch.Tensor:
    """Give empty taxels (``filled`` False) of maps (B, R, C) the mean of their non-empty
    8-neighbours, ``passes`` times; those still empty get ``empty_value``."""
    kernel = _NEIGHBOURS.to(values)[None, None]
    m = filled[:, None].to(values.dtype)
    x = values[:, None]
    for _ in range(passes):
        total = F.conv2d(torch.where(m > 0, x, torch.zeros_like(x)), kernel, padding=1)
        n = F.conv2d(m, kernel, padding=1)
        new = (m == 0) & (n > 0)
        x = torch.where(new, total / n.clamp_min(1.0), x)
        m = torch.where(new, torch.ones_like(m), m)
    return torch.where(m > 0, x, torch.full_like(x, float(empty_value)))[:, 0]


def sink_depth(verts: torch.Tensor, grid: MatSpec, config: PMRConfig = PMRConfig()) -> torch.Tensor:
    """Depth map (B, R, C), metres: height of the body's lowest point over each taxel above the
    unloaded mattress top (negative = sunk in); see the module docstring."""
    low, filled = lowest_vertex_map(verts, grid, config.empty_depth_m)
    return fill_empty(low, filled, config.fill_passes, config.empty_depth_m)


def maps_from_depth(depth: torch.Tensor, config: PMRConfig = PMRConfig()) -> PMRMaps:
    """Q, soft and hard contact maps from a depth map (B, R, C) (also for ground-truth depths)."""
    return PMRMaps(depth=depth, q=config.q_scale * torch.relu(-depth),
                   contact_soft=torch.sigmoid(-depth / config.contact_softness_m),
                   contact=(depth < 0).to(depth.dtype))


def pmr(verts: torch.Tensor, grid: MatSpec, config: PMRConfig = PMRConfig()) -> PMRMaps:
    """All PMR maps of meshes verts (B, V, 3) on ``grid`` (computed in at least float32)."""
    if verts.dtype in (torch.float16, torch.bfloat16):
        verts = verts.float()
    return maps_from_depth(sink_depth(verts, grid, config), config)
