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

The lowest *vertex* per taxel is the paper's approximation: where the body's underside has no
vertex inside a taxel (the body models' edges reach 5 to 7 cm on the legs, two taxel pitches of
a 2.86 cm mat) the taxel reads a vertex of the body's side or top, above the mattress, and shows no
contact under a sunk body; the filling spreads each rim taxel's depth two taxels beyond the body's
outline. On bodies the simulator rested (supine and lateral, 2.86 cm taxels) the contact map
agrees with the simulator's ``depth`` at an IoU of about 0.7. :func:`surface_maps` samples the lower surface itself, as the simulator does (its
contact IoU with the simulator's depth about 0.99); the estimate's maps of the final body
(:func:`pressurepose.net.infer.estimate`) are read with it.
"""

from __future__ import annotations

import math
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


def lower_surface_map(verts: torch.Tensor, faces: torch.Tensor, grid: MatSpec, cell_m: float,
                      empty_value: float) -> tuple[torch.Tensor, torch.Tensor]:
    """Per-taxel lowest height (B, R, C) of the surface of meshes verts (B, V, 3) with faces (F, 3),
    and the mask (B, R, C) of taxels the surface lies over.

    Each taxel is split into ``ceil(pitch / cell_m)`` cells per side; every triangle is interpolated
    linearly at the cell centres inside its projection (edges included) and the lowest value over a
    taxel's cells wins (as :func:`pressurepose.body.mesh.lower_surface` and the press read a body),
    so no taxel under the body is left empty however far apart the vertices are. Differentiable in
    the vertices (the choice of cells is not); taxels with no surface over a cell centre hold
    ``empty_value``.
    """
    b, r, c = verts.shape[0], grid.rows, grid.cols
    sr = max(1, math.ceil(grid.pitch_row_m / cell_m - 1e-9))
    sc = max(1, math.ceil(grid.pitch_col_m / cell_m - 1e-9))
    dy, dx = grid.pitch_row_m / sr, grid.pitch_col_m / sc
    tri = verts[:, faces.to(verts.device)].reshape(-1, 3, 3)  # (B F, 3, 3)
    with torch.no_grad():  # which cell centres each triangle's bounding box holds
        e1, e2 = tri[:, 1, :2] - tri[:, 0, :2], tri[:, 2, :2] - tri[:, 0, :2]
        det = e1[:, 0] * e2[:, 1] - e1[:, 1] * e2[:, 0]
        span = torch.maximum(e1.abs().amax(1), e2.abs().amax(1))
        seen = det.abs() > 1e-12 * span.clamp_min(1e-12) ** 2  # edge-on triangles have no area to sample
        lo, hi = tri[:, :, :2].amin(1), tri[:, :, :2].amax(1)
        i0 = torch.ceil(lo[:, 0] / dx - 0.5).clamp_min(0).long()
        i1 = torch.floor(hi[:, 0] / dx - 0.5).clamp_max(c * sc - 1).long()
        j0 = torch.ceil(lo[:, 1] / dy - 0.5).clamp_min(0).long()
        j1 = torch.floor(hi[:, 1] / dy - 0.5).clamp_max(r * sr - 1).long()
        wi = (i1 - i0 + 1).clamp_min(0)
        count = torch.where(seen, wi * (j1 - j0 + 1).clamp_min(0), torch.zeros_like(wi))
        t = torch.repeat_interleave(torch.arange(len(count), device=verts.device), count)
        k = torch.arange(len(t), device=verts.device) - torch.repeat_interleave(torch.cumsum(count, 0) - count, count)
        ii, jj = i0[t] + k % wi[t], j0[t] + k // wi[t]
    tt = tri[t]
    e1, e2 = tt[:, 1] - tt[:, 0], tt[:, 2] - tt[:, 0]
    px = (ii + 0.5).to(verts.dtype) * dx - tt[:, 0, 0]
    py = (jj + 0.5).to(verts.dtype) * dy - tt[:, 0, 1]
    det = e1[:, 0] * e2[:, 1] - e1[:, 1] * e2[:, 0]
    l1 = (px * e2[:, 1] - py * e2[:, 0]) / det
    l2 = (py * e1[:, 0] - px * e1[:, 1]) / det
    inside = ((l1 >= -1e-9) & (l2 >= -1e-9) & (l1 + l2 <= 1 + 1e-9)).detach()
    z = (tt[:, 0, 2] + l1 * e1[:, 2] + l2 * e2[:, 2])[inside]
    taxel = ((t // faces.shape[0]) * (r * c) + (jj // sr) * c + ii // sc)[inside]
    init = torch.full((b * r * c,), float(empty_value), dtype=verts.dtype, device=verts.device)
    low = init.scatter_reduce(0, taxel, z, reduce="amin", include_self=False)
    filled = torch.zeros(b * r * c, dtype=torch.bool, device=verts.device)
    filled[taxel] = True
    return low.reshape(b, r, c), filled.reshape(b, r, c)


SURFACE_CELL_M = 0.01  # the cells the simulator reads a body's lower surface on (BedSpec.press_cell_m)


def surface_maps(verts: torch.Tensor, faces: torch.Tensor, grid: MatSpec, config: PMRConfig = PMRConfig(),
                 cell_m: float = SURFACE_CELL_M) -> PMRMaps:
    """The maps of meshes verts (B, V, 3) with faces (F, 3) from their lower surface
    (:func:`lower_surface_map` on cells of ``cell_m``), no taxel filled from its neighbours:
    contact exactly where the body's surface is below the mattress top. ``config``'s empty depth,
    softness and Q scale apply (computed in at least float32)."""
    if verts.dtype in (torch.float16, torch.bfloat16):
        verts = verts.float()
    low, _ = lower_surface_map(verts, faces, grid, cell_m, config.empty_depth_m)
    return maps_from_depth(low, config)


def pmr(verts: torch.Tensor, grid: MatSpec, config: PMRConfig = PMRConfig()) -> PMRMaps:
    """All PMR maps of meshes verts (B, V, 3) on ``grid`` (computed in at least float32)."""
    if verts.dtype in (torch.float16, torch.bfloat16):
        verts = verts.float()
    return maps_from_depth(sink_depth(verts, grid, config), config)
