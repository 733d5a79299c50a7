#!/usr/bin/env python3
"""Draw the body sites of the shipped open body models (``docs/body_sites.png``, shown in
docs/monitoring.md): each model at rest, mean shape, seen from the back, its left side and the front,
every triangle coloured by the site of its vertices (:func:`pressurepose.body.sites.vertex_sites`,
named by :func:`pressurepose.body.sites.site_label`)::

    .venv/bin/python tools/draw_body_sites.py [--out docs/body_sites.png]
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

import numpy as np

REPO = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(REPO))

OUT = REPO / "docs" / "body_sites.png"
# (title, the viewer's right, the direction toward the viewer) in the z-up rest frame (+x the body's
# left, -y its front): seen from the back, the body's left is on the viewer's left
VIEWS = (("back", (-1.0, 0, 0), (0, 1.0, 0)), ("left side", (0, 1.0, 0), (1.0, 0, 0)),
         ("front", (1.0, 0, 0), (0, -1.0, 0)))


def site_colours() -> np.ndarray:
    """(16, 4) RGBA: a colour per site of :data:`SITES` (``other`` light grey)."""
    import matplotlib

    from pressurepose.body.sites import OTHER, SITES

    cmap = matplotlib.colormaps["tab20"]
    out = np.array([cmap(k) for k in range(len(SITES))])
    out[OTHER] = (0.86, 0.86, 0.86, 1.0)
    return out


def draw_view(ax, verts: np.ndarray, faces: np.ndarray, face_site: np.ndarray, colours: np.ndarray,
              across, toward) -> None:
    """The mesh (V, 3), faces (F, 3) projected on the plane of ``across`` and z, the triangles turned
    toward the viewer painted back to front (by their depth along ``toward``) in the colour of their site."""
    from matplotlib.collections import PolyCollection

    across, toward = np.asarray(across), np.asarray(toward)
    xy = np.stack([verts @ across, verts[:, 2]], axis=1)
    a, b, c = (verts[faces[:, k]] for k in range(3))
    facing = np.flatnonzero(np.cross(b - a, c - a) @ toward > 0)  # triangles turned toward the viewer
    order = facing[np.argsort((verts @ toward)[faces[facing]].mean(axis=1))]
    ax.add_collection(PolyCollection(xy[faces[order]], facecolors=colours[face_site[order]],
                                     edgecolors=(0, 0, 0, 0.08), linewidths=0.2))
    ax.set_xlim(xy[:, 0].min() - 0.05, xy[:, 0].max() + 0.05)
    ax.set_aspect("equal")
    ax.axis("off")


def main(argv=None) -> int:
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    p.add_argument("--out", default=str(OUT), help=f"PNG to write [{OUT.relative_to(REPO)}]")
    args = p.parse_args(argv)
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    from matplotlib.patches import Patch

    from pressurepose.body import BodyModel
    from pressurepose.body.sites import SITES, site_label, vertex_sites

    colours = site_colours()
    meshes = []
    for gender in ("female", "male"):
        body = BodyModel(gender)
        verts, _ = body.rest(np.zeros((1, body.num_betas)))
        faces = np.asarray(body.faces)
        # a triangle touching a named site takes it (OTHER is the last index)
        meshes.append((gender, verts[0], faces, vertex_sites(body)[faces].min(axis=1)))
    # every panel at one scale: each as wide as the body seen from its side
    widths = [np.ptp(v @ np.asarray(across)) + 0.1 for _, v, _, _ in meshes for _, across, _ in VIEWS]
    fig, axes = plt.subplots(1, len(widths), figsize=(13, 4.6), gridspec_kw={"width_ratios": widths})
    low = min(v[:, 2].min() for _, v, _, _ in meshes) - 0.05
    high = max(v[:, 2].max() for _, v, _, _ in meshes) + 0.05
    for g, (gender, verts, faces, face_site) in enumerate(meshes):
        for k, (title, across, toward) in enumerate(VIEWS):
            ax = axes[g * len(VIEWS) + k]
            draw_view(ax, verts, faces, face_site, colours, across, toward)
            ax.set_ylim(low, high)
            ax.set_title(f"{gender}: {title}", fontsize=10)
    fig.legend(handles=[Patch(color=colours[k], label=site_label(s)) for k, s in enumerate(SITES)],
               loc="lower center", ncol=8, fontsize=8, frameon=False)
    fig.subplots_adjust(left=0.01, right=0.99, top=0.92, bottom=0.16, wspace=0.05)
    fig.savefig(args.out, dpi=90)
    print(f"wrote {args.out}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
