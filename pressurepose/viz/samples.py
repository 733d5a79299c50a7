"""A grid of sampled bodies seen from above the bed: capsules projected on the mattress."""

from __future__ import annotations

import math

import numpy as np

from pressurepose.pose.samples import SampleBatch

# fill colours: trunk and head grey, the body's left limbs blue, its right limbs red
_SIDE_COLOURS = {"left": "#4a7fc1", "right": "#d0584f", "": "#9a9a9a"}


def stadium(p: np.ndarray, q: np.ndarray, r: float, n: int = 12) -> np.ndarray:
    """Outline (2 n + 2, 2) of the set of points within r of segment p-q (2-D points)."""
    d = q - p
    length = float(np.hypot(*d))
    a = math.atan2(d[1], d[0]) if length > 1e-12 else 0.0
    t = np.linspace(-np.pi / 2, np.pi / 2, n + 1)
    cap_q = q + r * np.stack([np.cos(a + t), np.sin(a + t)], 1)
    cap_p = p + r * np.stack([np.cos(a + np.pi + t), np.sin(a + np.pi + t)], 1)
    return np.concatenate([cap_q, cap_p])


def plot_samples(batch: SampleBatch, body, mattress: tuple[float, float, float, float],
                 sensing: tuple[float, float, float, float] | None = None, max_bodies: int = 16,
                 columns: int = 4, regressors=None):
    """Figure of up to ``max_bodies`` bodies of ``batch`` seen from above (head end at the top).

    mattress, sensing: (x_min, x_max, y_min, y_max) outlines in the bed frame, m. Capsules are drawn
    lowest first, so what is on top shows on top. The view is from above: the bed's x axis points
    left and its y axis down the page.
    """
    import matplotlib

    matplotlib.use("Agg", force=False)
    import matplotlib.pyplot as plt
    from matplotlib.patches import Polygon, Rectangle

    from pressurepose.body.capsules import CAPSULE_NAMES, capsules_for, posed_capsules

    n = min(len(batch), max_bodies)
    cols = min(columns, n)
    rows = math.ceil(n / cols)
    x0, x1, y0, y1 = mattress
    fig, axes = plt.subplots(rows, cols, figsize=(2.2 * cols, 4.2 * rows), squeeze=False)
    for ax in axes.ravel()[n:]:
        ax.axis("off")
    for i, ax in enumerate(axes.ravel()[:n]):
        caps = capsules_for(body, batch.betas[i], regressors)
        ends, radius = posed_capsules(body, caps, batch.betas[i], batch.pose[i:i + 1], batch.transl[i:i + 1])
        ends = ends[0]
        ax.add_patch(Rectangle((x0, y0), x1 - x0, y1 - y0, fill=True, fc="#f4efe6", ec="#8c7b62", lw=1.0))
        if sensing is not None:
            s0, s1, t0, t1 = sensing
            ax.add_patch(Rectangle((s0, t0), s1 - s0, t1 - t0, fill=False, ec="#b9ab94", lw=0.6, ls="--"))
        for k in np.argsort(ends[:, :, 2].mean(1) - radius):  # lowest first
            side = CAPSULE_NAMES[k].split("_")[0] if "_" in CAPSULE_NAMES[k] else ""
            colour = _SIDE_COLOURS.get(side, _SIDE_COLOURS[""])
            ax.add_patch(Polygon(stadium(ends[k, 0, :2], ends[k, 1, :2], radius[k]), closed=True, fc=colour,
                                 ec="black", lw=0.5, alpha=0.85))
        head = ends[CAPSULE_NAMES.index("head")].mean(0)
        ax.plot(*head[:2], marker="o", ms=3, color="black")
        ax.set_xlim(x1 + 0.05, x0 - 0.05)  # seen from above with the head end up: x points left
        ax.set_ylim(y1 + 0.05, y0 - 0.05)
        ax.set_aspect("equal")
        ax.set_xticks([])
        ax.set_yticks([])
        ax.set_title(f"#{i} roll {math.degrees(batch.roll[i]):.0f}  yaw {math.degrees(batch.yaw[i]):.0f}\n"
                     f"bins L{batch.bins[i, 0]} R{batch.bins[i, 1]} / L{batch.bins[i, 2]} R{batch.bins[i, 3]}",
                     fontsize=7)
    lob = ", limbs on bed" if batch.limbs_on_bed else ""
    fig.suptitle(f"{batch.partition} ({batch.gender}{lob}) seen from above, head end up; "
                 f"blue: body's left, red: its right", fontsize=9)
    fig.tight_layout()
    return fig
