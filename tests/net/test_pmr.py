import math

import numpy as np
import torch

from pressurepose.body.mesh import lower_surface
from pressurepose.mat import MatSpec, custom_mat
from pressurepose.net.pmr import (
    PMRConfig,
    lower_surface_map,
    maps_from_depth,
    pmr,
    sink_depth,
    surface_maps,
)

torch.set_num_threads(1)

GRID = custom_mat(rows=6, cols=5, pitch_row_m=0.03, pitch_col_m=0.02)


def brute_force_depth(verts: np.ndarray, grid: MatSpec, config: PMRConfig) -> np.ndarray:
    """Reference: Python loops over vertices and taxels."""
    out = np.zeros((len(verts), grid.rows, grid.cols))
    for b, mesh in enumerate(verts):
        low = [[None] * grid.cols for _ in range(grid.rows)]
        for x, y, z in mesh:
            c, r = math.floor(x / grid.pitch_col_m), math.floor(y / grid.pitch_row_m)
            if 0 <= r < grid.rows and 0 <= c < grid.cols:
                low[r][c] = z if low[r][c] is None else min(low[r][c], z)
        for _ in range(config.fill_passes):
            new = [row[:] for row in low]
            for r in range(grid.rows):
                for c in range(grid.cols):
                    if low[r][c] is not None:
                        continue
                    vals = [low[rr][cc] for rr in range(r - 1, r + 2) for cc in range(c - 1, c + 2)
                            if (rr, cc) != (r, c) and 0 <= rr < grid.rows and 0 <= cc < grid.cols
                            and low[rr][cc] is not None]
                    if vals:
                        new[r][c] = sum(vals) / len(vals)
            low = new
        for r in range(grid.rows):
            for c in range(grid.cols):
                out[b, r, c] = config.empty_depth_m if low[r][c] is None else low[r][c]
    return out


def _mesh(seed=0, b=3, v=40):
    rng = np.random.default_rng(seed)
    verts = np.stack([rng.uniform(-0.01, 0.08, (b, v)),  # some off the mat on each side
                      rng.uniform(-0.02, 0.15, (b, v)),
                      rng.uniform(-0.05, 0.05, (b, v))], -1)
    verts[1, :, 0] *= 0.4  # leave a band of empty columns to fill or leave empty
    return verts


def test_depth_matches_brute_force():
    verts = _mesh()
    for passes in (0, 1, 2):
        cfg = PMRConfig(fill_passes=passes)
        got = sink_depth(torch.tensor(verts), GRID, cfg).numpy()
        np.testing.assert_allclose(got, brute_force_depth(verts, GRID, cfg), atol=1e-12)


def test_maps_definitions():
    verts = torch.tensor(_mesh(1))
    cfg = PMRConfig()
    m = pmr(verts, GRID, cfg)
    assert torch.equal(m.contact, (m.depth < 0).to(m.depth.dtype))
    assert torch.allclose(m.q, 1000 * torch.clamp(-m.depth, min=0))
    assert torch.all((m.contact_soft > 0.5) == (m.depth < 0))
    # a taxel 1 cm down reads Q = 10 (mm) and nearly certain contact
    d = torch.tensor([[[-0.01, 0.02]]])
    mm = maps_from_depth(d, cfg)
    assert torch.allclose(mm.q, torch.tensor([[[10.0, 0.0]]]))
    assert mm.contact_soft[0, 0, 0] > 0.99 and mm.contact_soft[0, 0, 1] < 1e-4


def test_empty_taxels_far_from_the_body_read_no_contact():
    verts = torch.tensor([[[0.005, 0.005, -0.02]]], dtype=torch.float64)  # one vertex in taxel (0, 0)
    m = pmr(verts, GRID, PMRConfig(fill_passes=1))
    assert m.depth[0, 0, 0] == -0.02 and m.depth[0, 1, 1] == -0.02  # its neighbour is filled
    assert m.depth[0, 3, 3] == 1.0 and m.q[0, 3, 3] == 0 and m.contact[0, 3, 3] == 0


def test_gradients_by_finite_differences():
    rng = np.random.default_rng(2)
    # one vertex per taxel centre region (no ties, away from taxel borders), plus a second, higher one
    rows, cols = np.meshgrid(np.arange(4), np.arange(3), indexing="ij")
    xy = np.stack([(cols.ravel() + 0.5) * GRID.pitch_col_m, (rows.ravel() + 0.5) * GRID.pitch_row_m], -1)
    low = np.concatenate([xy, rng.uniform(-0.03, 0.01, (len(xy), 1))], -1)
    high = low + [0.002, -0.003, 0.02]
    verts = torch.tensor(np.concatenate([low, high])[None], requires_grad=True)

    def f(v):
        m = pmr(v, GRID, PMRConfig(fill_passes=2, contact_softness_m=0.01))
        return m.depth, m.q, m.contact_soft

    assert torch.autograd.gradcheck(f, (verts,), eps=1e-6, atol=1e-6)
    # the gradient of the depth reaches the lowest vertex of each taxel only, through its z
    d = f(verts)[0]
    g, = torch.autograd.grad(d[0, :4, :3].sum(), verts)
    assert torch.all(g[0, :12, 2] == 1) and torch.all(g[0, 12:] == 0) and torch.all(g[0, :, :2] == 0)


def _square(z: float, x0: float, x1: float, y0: float, y1: float) -> tuple[torch.Tensor, torch.Tensor]:
    """A flat square (two triangles, vertices only at its corners) at height z, facing down."""
    verts = torch.tensor([[[x0, y0, z], [x1, y0, z], [x1, y1, z], [x0, y1, z]]], dtype=torch.float64)
    return verts, torch.tensor([[0, 2, 1], [0, 3, 2]])


def test_a_sunk_surface_between_far_apart_vertices_reads_contact_under_all_of_it():
    # a 20 x 20 cm square sunk 1 cm, on 1 cm taxels: its vertices lie 20 taxels apart
    grid = custom_mat(rows=30, cols=30, pitch_row_m=0.01, pitch_col_m=0.01)
    verts, faces = _square(-0.01, 0.05, 0.25, 0.05, 0.25)
    m = surface_maps(verts, faces, grid, cell_m=0.01)
    under = np.zeros((30, 30), bool)
    under[5:25, 5:25] = True  # the taxels whose centres the square covers
    np.testing.assert_array_equal(m.contact[0].numpy(), under)
    np.testing.assert_allclose(m.q[0].numpy()[under], 10.0)
    assert np.all(m.depth[0].numpy()[~under] == PMRConfig().empty_depth_m)
    # the lowest vertex per taxel sees the four corners only: the filling reaches 2 taxels from them
    assert pmr(verts, grid).contact[0].numpy()[under].mean() < 0.2


def test_lower_surface_map_is_the_simulators_lower_surface_reduced_per_taxel():
    # a random closed mesh (a squashed icosphere, tilted) over a grid of 3 x 3 cells per taxel
    import trimesh

    sphere = trimesh.creation.icosphere(subdivisions=1)
    rng = np.random.default_rng(3)
    verts = sphere.vertices * [0.09, 0.12, 0.04] + rng.normal(0, 0.004, sphere.vertices.shape)
    tilt = trimesh.transformations.rotation_matrix(0.3, [1, 1, 0])[:3, :3]
    verts = verts @ tilt.T + [0.1, 0.14, 0.01]
    faces = np.asarray(sphere.faces)
    cell = GRID.pitch_col_m / 3
    grid = custom_mat(rows=12, cols=10, pitch_row_m=3 * cell, pitch_col_m=3 * cell)
    low, filled = lower_surface_map(torch.tensor(verts)[None], torch.tensor(faces), grid, cell, 1.0)
    fine = lower_surface(verts, faces, (0.0, 0.0), (cell, cell), (36, 30))
    want = fine.reshape(12, 3, 10, 3).min(axis=(1, 3))
    np.testing.assert_array_equal(filled[0].numpy(), np.isfinite(want))
    np.testing.assert_allclose(low[0].numpy(), np.where(np.isfinite(want), want, 1.0), atol=1e-12)
    assert filled.sum() > 40 and (low < 0).any() and (low[filled] > 0).any()


def test_surface_depth_gradient_by_finite_differences():
    # a tilted square over 4 x 4 taxels: the depth at each taxel interpolates its corners' heights
    grid = custom_mat(rows=6, cols=6, pitch_row_m=0.02, pitch_col_m=0.02)
    verts, faces = _square(-0.01, 0.011, 0.093, 0.013, 0.097)
    verts = verts + torch.tensor([[[0, 0, 0.0], [0, 0, 0.004], [0, 0, -0.003], [0, 0, 0.002]]], dtype=torch.float64)
    verts.requires_grad_(True)
    assert torch.autograd.gradcheck(lambda v: surface_maps(v, faces, grid, cell_m=0.02).depth, (verts,),
                                    eps=1e-7, atol=1e-6)
