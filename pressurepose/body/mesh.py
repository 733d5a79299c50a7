"""Geometry of closed triangle meshes: enclosed volume and inside tests (pure numpy)."""

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
