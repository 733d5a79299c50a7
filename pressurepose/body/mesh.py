"""Geometry of triangle meshes: enclosed volume, inside tests and the lower surface as a height
field on a regular grid (pure numpy, vectorised)."""

from __future__ import annotations

import numpy as np


def mesh_volume(verts: np.ndarray, faces: np.ndarray) -> np.ndarray:
    """Signed volume (B,) of closed meshes verts (B, V, 3) with outward-facing faces (F, 3)."""
    v = np.atleast_3d(verts)
    a, b, c = v[:, faces[:, 0]], v[:, faces[:, 1]], v[:, faces[:, 2]]
    return np.einsum("bfi,bfi->bf", a, np.cross(b, c)).sum(-1) / 6.0


def points_inside(points: np.ndarray, verts: np.ndarray, faces: np.ndarray) -> np.ndarray:
    """(P,) bool: is each point inside the closed surface? Ray parity, majority of 3 ray directions."""
    a, b, c = verts[faces[:, 0]], verts[faces[:, 1]], verts[faces[:, 2]]
    e1, e2 = b - a, c - a
    votes = np.zeros(len(points), int)
    for d in np.array([[0.31, 0.52, 0.79], [-0.62, 0.27, -0.73], [0.58, -0.71, 0.41]]):
        d = d / np.linalg.norm(d)
        p = np.cross(d, e2)  # Moller-Trumbore, every point against every triangle
        det = (e1 * p).sum(-1)
        ok = np.abs(det) > 1e-14
        inv = np.where(ok, 1.0 / np.where(ok, det, 1.0), 0.0)
        s = points[:, None, :] - a[None]
        u = (s * p[None]).sum(-1) * inv
        q = np.cross(s, e1[None])
        v = (q @ d) * inv
        t = (q * e2[None]).sum(-1) * inv
        votes += (ok & (u >= 0) & (v >= 0) & (u + v <= 1) & (t > 0)).sum(1) % 2
    return votes >= 2


def lower_surface(vertices: np.ndarray, faces: np.ndarray, origin_xy: tuple[float, float],
                  cell_xy: tuple[float, float], shape: tuple[int, int], floor: float = -np.inf,
                  return_vertex: bool = False):
    """Lowest z of the mesh above the centre of every grid cell, ignoring points below ``floor``.

    vertices (V, 3) and faces (F, 3) in metres; the grid has ``shape = (ny, nx)`` cells of size
    ``cell_xy = (dx, dy)`` with its corner at ``origin_xy``; cell (j, i) is centred at
    ``origin + ((i + 0.5) dx, (j + 0.5) dy)``. Returns (ny, nx) heights, ``+inf`` where no triangle
    lies over the centre. Each triangle is interpolated linearly at the cell centres inside its
    projection (edges included), and the lowest value at or above ``floor`` (m) wins, so for a
    closed mesh the result is its lower surface sampled at the cell centres.

    ``return_vertex``: also return (ny, nx) int64, the vertex of the lowest triangle nearest each
    cell centre (largest barycentric weight; -1 where no triangle): which point of the surface lies
    over the cell.
    """
    ny, nx = shape
    dx, dy = cell_xy
    out = np.full(ny * nx, np.inf)
    nearest = np.full(ny * nx, -1, dtype=np.int64)

    def result():
        heights = out.reshape(ny, nx)
        return (heights, nearest.reshape(ny, nx)) if return_vertex else heights

    tri = vertices[faces]  # (F, 3, 3)
    # affine map from (x, y) to barycentric (l1, l2) per triangle
    x0, y0 = tri[:, 0, 0], tri[:, 0, 1]
    e1 = tri[:, 1, :2] - tri[:, 0, :2]
    e2 = tri[:, 2, :2] - tri[:, 0, :2]
    det = e1[:, 0] * e2[:, 1] - e1[:, 1] * e2[:, 0]
    # skip triangles seen edge-on (no area in projection): they carry no lowest point of their own
    span = np.maximum(np.abs(e1).max(1), np.abs(e2).max(1))
    keep = np.abs(det) > 1e-12 * np.maximum(span, 1e-12) ** 2
    tri, x0, y0, e1, e2, det = tri[keep], x0[keep], y0[keep], e1[keep], e2[keep], det[keep]
    kept_faces = faces[keep]
    if len(tri) == 0:
        return result()
    # index ranges of the cell centres inside each triangle's bounding box
    lo = tri[:, :, :2].min(1)
    hi = tri[:, :, :2].max(1)
    i0 = np.maximum(np.ceil((lo[:, 0] - origin_xy[0]) / dx - 0.5), 0).astype(np.int64)
    i1 = np.minimum(np.floor((hi[:, 0] - origin_xy[0]) / dx - 0.5), nx - 1).astype(np.int64)
    j0 = np.maximum(np.ceil((lo[:, 1] - origin_xy[1]) / dy - 0.5), 0).astype(np.int64)
    j1 = np.minimum(np.floor((hi[:, 1] - origin_xy[1]) / dy - 0.5), ny - 1).astype(np.int64)
    wi = np.maximum(i1 - i0 + 1, 0)
    wj = np.maximum(j1 - j0 + 1, 0)
    count = wi * wj
    total = int(count.sum())
    if total == 0:
        return result()
    t = np.repeat(np.arange(len(tri)), count)
    k = np.arange(total) - np.repeat(np.cumsum(count) - count, count)
    ii = i0[t] + k % wi[t]
    jj = j0[t] + k // wi[t]
    px = origin_xy[0] + (ii + 0.5) * dx - x0[t]
    py = origin_xy[1] + (jj + 0.5) * dy - y0[t]
    inv = 1.0 / det[t]
    l1 = (px * e2[t, 1] - py * e2[t, 0]) * inv
    l2 = (py * e1[t, 0] - px * e1[t, 1]) * inv
    tol = 1e-9
    inside = (l1 >= -tol) & (l2 >= -tol) & (l1 + l2 <= 1 + tol)
    t, l1, l2 = t[inside], l1[inside], l2[inside]
    z = tri[t, 0, 2] + l1 * (tri[t, 1, 2] - tri[t, 0, 2]) + l2 * (tri[t, 2, 2] - tri[t, 0, 2])
    above = z >= floor
    flat = (jj[inside] * nx + ii[inside])[above]
    np.minimum.at(out, flat, z[above])
    if return_vertex:
        low = z[above] == out[flat]  # the candidates that are the lowest over their cell
        w = np.stack([1.0 - l1 - l2, l1, l2], axis=1)[above][low]
        nearest[flat[low]] = kept_faces[t[above][low], np.argmax(w, axis=1)]
    return result()
