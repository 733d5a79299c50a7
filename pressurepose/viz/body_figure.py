"""A body seen from the front and the side, capsules overlaid, with a one-paragraph summary."""

from __future__ import annotations

import numpy as np


def body_figure(body, betas: np.ndarray, pose: np.ndarray, capsules: bool = True, title: str | None = None):
    """Figure of a posed body (front and side views) and a text summary.

    body: BodyModel; betas (S,); pose (72,) SMPL axis-angle. Returns (figure, summary string).
    """
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    from pressurepose.viz.mesh import draw_capsules, draw_mesh

    betas = np.asarray(betas, dtype=np.float64)
    verts, joints = body.forward(betas, pose)
    verts, joints = verts[0], joints[0]
    caps = None
    if capsules:
        from pressurepose.body.capsules import capsules_for, posed_capsules

        c = capsules_for(body, betas)
        ends, radius = posed_capsules(body, c, betas[None], np.asarray(pose)[None], np.zeros((1, 3)))
        caps = (ends[0], radius)
    fig, axes = plt.subplots(1, 2, figsize=(8, 6))
    # "front" faces the body (its left on the picture's right); "side" looks at its left side
    for ax, view, name in zip(axes, ("front", "side"), ("front (its left on the right)", "side (from its left)")):
        draw_mesh(ax, verts, body.faces, view)
        if caps is not None:
            draw_capsules(ax, caps[0], caps[1], view)
        ax.set_title(name, fontsize=10)
        ax.set_xlabel("m")
    axes[0].set_ylabel("m")
    height = float(body.height(betas)[0])
    mass = float(body.mass(betas)[0])
    summary = (f"{body.gender} body ({body.num_vertices} vertices, {body.num_joints} joints): "
               f"height {height:.2f} m, mass {mass:.1f} kg (volume x 1000 kg/m^3), "
               f"betas [{', '.join(f'{b:+.2f}' for b in betas)}]")
    fig.suptitle(title or f"{body.gender}: {height:.2f} m, {mass:.1f} kg"
                 + ("\nred outlines: the capsules the settle simulates the body with" if caps is not None else ""))
    fig.tight_layout()
    return fig, summary
