"""Fitting an estimated body to the image's print (test-time refinement after the network).

PressureNet reads a body from the image in one pass; the body it returns need not lie where the
image shows load. :func:`fit_to_print` moves each estimated body (root rotation, joint rotations,
translation; the shape stays the network's) for a few steps of Adam so that

* every loaded taxel (reading more than the model's contact floor) has a vertex of the body under
  it: the taxel's centre to the nearest vertex at or below the mattress top, across the bed
  (x, y), plus that vertex's height above the top; clipped at ``max_reach_m``, so print farther
  than that from the body (a wedge, another object) does not pull it (print nearer than that does:
  a wedge beside a propped body pulls the body onto it);
* no vertex sinks into the mattress over a taxel that reads nothing (the vertex's sink, squared);
* the pose and translation stay near the network's (a quadratic prior).

The loss per image, for loaded taxels ``L``, vertices ``V``, pose change ``dθ`` (rad) and
translation change ``dt`` (m)::

    w_print * mean_{l in L} min(d_l, max_reach)^2 + w_lift * mean_{v in V} [v over an unloaded taxel] max(-z_v, 0)^2
      + w_pose * |dθ|^2 + w_transl * |dt|^2

Each loaded taxel's nearest vertex is searched among a fixed, seeded subset of the mesh's vertices
(``search_vertices``) with no gradient; the distance to it carries the gradient. Images are
independent: each body's fit depends on its image only, whatever else is in the batch. The default
settings were chosen on simulated images of every partition; docs/training.md has what they do to
simulated and real estimates.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import torch

from pressurepose.errors import BadInput, require_non_negative, require_positive, require_whole
from pressurepose.mat import MatSpec
from pressurepose.net.outputs import BodyParams


@dataclass(frozen=True)
class FitConfig:
    """Settings of :func:`fit_to_print` (module docstring). steps: Adam steps; lr: Adam's step size
    (rad for rotations, m for translation); print_weight, lift_weight: the two image terms' weights
    (per m^2); pose_prior (per rad^2), transl_prior (per m^2): the prior's weights; max_reach_m: the
    clip on a loaded taxel's distance; search_vertices: how many vertices (a seeded subset) are
    searched for each loaded taxel's nearest."""

    steps: int = 30
    lr: float = 0.02
    print_weight: float = 100.0
    lift_weight: float = 100.0
    pose_prior: float = 0.01
    transl_prior: float = 10.0
    max_reach_m: float = 0.1
    search_vertices: int = 1500

    def __post_init__(self):
        require_whole("fit steps", self.steps, 1, 10_000)
        require_whole("fit search_vertices", self.search_vertices, 1, 10_000_000)
        for name in ("lr", "max_reach_m"):
            require_positive(f"fit {name}", getattr(self, name))
        for name in ("print_weight", "lift_weight", "pose_prior", "transl_prior"):
            require_non_negative(f"fit {name}", getattr(self, name))


def fit_config(fit) -> FitConfig | None:
    """The fit asked for: True (the default settings), a FitConfig, or False / None (no fit);
    BadInput for anything else."""
    if fit is True:
        return FitConfig()
    if fit is False or fit is None or isinstance(fit, FitConfig):
        return fit or None
    raise BadInput(f"fit is {fit!r}; expected True, False or a FitConfig")


def taxel_centres(grid: MatSpec) -> torch.Tensor:
    """(R * C, 2) x, y of each taxel's centre, m, row-major (x across the bed, y along it)."""
    y, x = np.meshgrid((np.arange(grid.rows) + 0.5) * grid.pitch_row_m,
                       (np.arange(grid.cols) + 0.5) * grid.pitch_col_m, indexing="ij")
    return torch.from_numpy(np.stack([x, y], -1).reshape(-1, 2))


def _search_subset(num_vertices: int, count: int) -> torch.Tensor:
    count = min(count, num_vertices)
    return torch.from_numpy(np.sort(np.random.default_rng(0).choice(num_vertices, count, replace=False)))


def _prepare(loaded: torch.Tensor, grid: MatSpec, dtype: torch.dtype) -> tuple[torch.Tensor, torch.Tensor, torch.Tensor]:
    """What the image terms need of loaded taxels (B, R, C) bool, built once per image: each
    image's loaded taxels first, as centres (B, K, 2) m and a mask (B, K) (K the most any image
    has; the mask marks the real ones), and the flat (B, R * C) loaded map."""
    flat = loaded.reshape(loaded.shape[0], -1)
    k = max(int(flat.sum(1).max()), 1)
    order = torch.argsort((~flat).to(torch.int8), dim=1, stable=True)[:, :k]  # loaded taxels first
    centres = taxel_centres(grid).to(device=loaded.device, dtype=dtype)[order]
    return centres, torch.gather(flat, 1, order).to(dtype), flat


def _terms(verts: torch.Tensor, prepared, grid: MatSpec, config: FitConfig,
           search: torch.Tensor | None) -> tuple[torch.Tensor, torch.Tensor]:
    where, mask, flat = prepared
    cand = verts if search is None else verts[:, search]
    with torch.no_grad():
        d2 = torch.cdist(where, cand[..., :2]).square_() + torch.relu(cand[..., 2]).square()[:, None, :]
        nearest = d2.argmin(-1)  # (B, K)
    v = torch.gather(cand, 1, nearest[..., None].expand(-1, -1, 3))
    d2 = ((where - v[..., :2]) ** 2).sum(-1) + torch.relu(v[..., 2]) ** 2
    d2 = torch.clamp(d2, max=config.max_reach_m ** 2)
    print_term = (d2 * mask).sum(1) / mask.sum(1).clamp(min=1.0)
    col = torch.floor(verts[..., 0] / grid.pitch_col_m).long()
    row = torch.floor(verts[..., 1] / grid.pitch_row_m).long()
    on = (col >= 0) & (col < grid.cols) & (row >= 0) & (row < grid.rows)
    idx = row.clamp(0, grid.rows - 1) * grid.cols + col.clamp(0, grid.cols - 1)
    unloaded = on & ~torch.gather(flat, 1, idx)
    lift_term = (torch.relu(-verts[..., 2]) ** 2 * unloaded).sum(1) / verts.shape[1]
    return print_term, lift_term


def print_loss(verts: torch.Tensor, loaded: torch.Tensor, grid: MatSpec, config: FitConfig,
               search: torch.Tensor | None = None) -> tuple[torch.Tensor, torch.Tensor]:
    """The two image terms of the fit for vertices (B, V, 3) (bed frame, m; z = 0 the mattress top)
    and loaded taxels (B, R, C) bool: (print (B,), lift (B,)), unweighted (module docstring);
    search: the vertices searched for each loaded taxel's nearest (default all)."""
    return _terms(verts, _prepare(loaded, grid, verts.dtype), grid, config, search)


def fit_to_print(body, params: BodyParams, gender: torch.Tensor, pressure: torch.Tensor, grid: MatSpec,
                 floor_mmhg: float, config: FitConfig = FitConfig()) -> BodyParams:
    """The estimated bodies ``params`` (batch B) moved to fit their images' prints (module
    docstring): pressure (B, R, C) mmHg on ``grid``; a taxel is loaded above ``floor_mmhg``;
    ``body`` a :class:`~pressurepose.net.model.GenderedBody`, gender (B,) its codes. Returns new
    BodyParams (betas, root_euler and unconstrained as given; root_euler then no longer describes
    global_orient)."""
    if pressure.ndim != 3 or tuple(pressure.shape[1:]) != grid.shape or pressure.shape[0] != params.betas.shape[0]:
        raise BadInput(f"pressure has shape {tuple(pressure.shape)}; expected ({params.betas.shape[0]}, "
                       f"{grid.rows}, {grid.cols})")
    with torch.inference_mode(False), torch.enable_grad():
        base = {k: v.detach().clone().float() for k, v in vars(params).items() if torch.is_tensor(v)}
        prepared = _prepare((pressure > floor_mmhg).clone(), grid, torch.float32)
        gender = gender.clone()
        d_root = torch.zeros_like(base["global_orient"], requires_grad=True)
        d_pose = torch.zeros_like(base["body_pose"], requires_grad=True)
        d_transl = torch.zeros_like(base["transl"], requires_grad=True)
        opt = torch.optim.Adam([d_root, d_pose, d_transl], lr=config.lr)
        search = None

        def moved() -> BodyParams:
            return BodyParams(unconstrained=base["unconstrained"], betas=base["betas"],
                              transl=base["transl"] + d_transl, root_euler=base["root_euler"],
                              global_orient=base["global_orient"] + d_root, body_pose=base["body_pose"] + d_pose)

        for _ in range(config.steps):
            verts, _ = body(moved(), gender)
            if search is None:
                search = _search_subset(verts.shape[1], config.search_vertices).to(verts.device)
            p, lift = _terms(verts, prepared, grid, config, search)
            prior = (config.pose_prior * ((d_root ** 2).sum(1) + (d_pose ** 2).sum(1))
                     + config.transl_prior * (d_transl ** 2).sum(1))
            loss = (config.print_weight * p + config.lift_weight * lift + prior).sum()
            opt.zero_grad(set_to_none=True)
            loss.backward()
            opt.step()
        return BodyParams(**{k: v.detach() for k, v in vars(moved()).items()})
