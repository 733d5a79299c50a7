"""The gallery of a real-image evaluation: best and worst estimates beside their inputs."""

from __future__ import annotations

import numpy as np


def gallery_figure(result: dict, count: int = 3):
    """Figure: the ``count`` best and worst estimates by contact IoU, one row each: the model input
    (mmHg), the reconstructed map Q (PMR) and the estimated body seen from below, through the mat, laid
    out like the images (as in the ``infer`` picture: a supine body shows its back; its titles say so)."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    from matplotlib.patches import Rectangle

    from pressurepose.viz.mesh import draw_mesh

    rows, est, x = result.rows, result.estimate, result.input
    order = np.argsort(-rows["contact_iou"], kind="stable")
    count = min(count, len(order) // 2 or 1)
    picks = [("best", int(i)) for i in order[:count]] + [("worst", int(i)) for i in order[::-1][:count]]
    fig, axes = plt.subplots(len(picks), 3, figsize=(9, 4.2 * len(picks)), squeeze=False)
    w, length = est.grid.size_m
    for (kind, i), ax in zip(picks, axes):
        ax[0].imshow(x[i], cmap="magma", interpolation="nearest", vmin=0, vmax=max(float(x[i].max()), 1e-6))
        ax[0].set_title(f"{kind}: S{rows['subject'][i]} {rows['detail'][i]}\ninput (mmHg)", fontsize=9)
        ax[1].imshow(est.q[i], cmap="magma", interpolation="nearest")
        ax[1].set_title(f"reconstructed map Q, IoU {rows['contact_iou'][i]:.2f}", fontsize=9)
        for a in ax[:2]:
            a.set_xticks([])
            a.set_yticks([])
        ax[2].add_patch(Rectangle((0, -length), w, length, fill=False, ls="--", color="0.5"))
        draw_mesh(ax[2], est.vertices[i], est.faces, view="below")
        ax[2].set_title(f"estimate ({rows['body_model'][i]}), from below\n"
                        f"{rows['predicted'][i]}, label {rows['posture'][i]}\n"
                        f"stature {rows['stature_m'][i]:.2f} m (true {rows['height_m'][i]:.2f})", fontsize=9)
        ax[2].set_xticks([])
        ax[2].set_yticks([])
    fig.tight_layout()
    return fig
