"""Pictures of the load on each body site: the pressure image with the sites outlined, the body
coloured by the pressure under it, and each site's peak against the threshold."""

from __future__ import annotations

from pathlib import Path

import numpy as np

from pressurepose.body.sites import OTHER, SITES, site_label
from pressurepose.net.infer import Estimate
from pressurepose.viz.estimate import save_numbered_figures

THRESHOLD_MMHG = 32.0  # capillary closing pressure (Landis 1930), as pressurepose.eval.monitor


def site_figure(est: Estimate, i: int = 0, threshold_mmhg: float = THRESHOLD_MMHG):
    """A matplotlib figure for image ``i`` of an estimate with site loads: the pressure image with
    each loaded site outlined and named with its peak; the estimated body seen from below through
    the mat, coloured by the pressure under its skin; each site's peak pressure (bars, share of the
    load written beside them) against ``threshold_mmhg``. Sites carrying under 0.5 % of the load
    are left out of the outlines and bars."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    from matplotlib import colors as mcolors

    from pressurepose.viz.mesh import draw_mesh

    if est.sites is None or est.vertex_pressure is None:
        from pressurepose.errors import BadInput

        raise BadInput("this estimate has no site loads (estimate(..., sites=True) computes them)")
    loads, grid = est.sites, est.grid
    w, length = grid.size_m
    extent = (0.0, w, -length, 0.0)  # row 0 (the head end) at the top, as the body seen from below
    vmax = max(float(est.pressure[i].max()), threshold_mmhg * 1.5)
    norm = mcolors.Normalize(0.0, vmax)
    cmap = plt.get_cmap("magma_r")
    fig, axes = plt.subplots(1, 3, figsize=(14, 6.5), gridspec_kw={"width_ratios": [1, 1, 1.3]})

    ax = axes[0]
    im = ax.imshow(np.ma.masked_less_equal(est.pressure[i], 0), cmap=cmap, norm=norm, extent=extent,
                   interpolation="nearest")
    taxel = loads.taxel_site[i]
    xs = (np.arange(grid.cols) + 0.5) * grid.pitch_col_m
    ys = -(np.arange(grid.rows) + 0.5) * grid.pitch_row_m
    for k, name in enumerate(SITES):
        mask = taxel == k
        if loads.share[i, k] < 0.005 or name == "other":  # outline the sites that carry some of the load
            continue
        ax.contour(xs, ys, mask.astype(float), levels=[0.5], colors="tab:cyan", linewidths=1.2)
        rr, cc = np.nonzero(mask)
        ax.text(xs[cc].mean(), ys[rr].mean(), f"{site_label(name)}\n{loads.peak_mmhg[i, k]:.0f}", fontsize=7,
                ha="center", va="center", color="black",
                bbox={"boxstyle": "round,pad=0.15", "fc": "white", "ec": "none", "alpha": 0.7})
    ax.set_title("pressure by body site (peak mmHg)")
    ax.set_xticks([])
    ax.set_yticks([])
    fig.colorbar(im, ax=ax, fraction=0.046, label="mmHg")

    ax = axes[1]
    face_p = est.vertex_pressure[i][est.faces].max(axis=1)
    rgb = np.where(face_p[:, None] > 0, np.asarray(cmap(norm(face_p)))[:, :3], 0.82)
    draw_mesh(ax, est.vertices[i], est.faces, view="below", color=rgb)
    ax.plot([0, w, w, 0, 0], [0, 0, -length, -length, 0], ls="--", color="0.5", lw=0.8)
    ax.set_title("estimated body from below: pressure on the skin")
    ax.set_xticks([])
    ax.set_yticks([])

    ax = axes[2]
    shown = [k for k in range(len(SITES)) if loads.share[i, k] >= 0.005]
    shown.sort(key=lambda k: loads.peak_mmhg[i, k])
    names = [site_label(SITES[k]) for k in shown]
    peaks = loads.peak_mmhg[i, shown]
    ax.barh(names, peaks, color=["tab:red" if p > threshold_mmhg else "tab:blue" for p in peaks])
    for y, k in enumerate(shown):
        ax.text(loads.peak_mmhg[i, k], y, f" {100 * loads.share[i, k]:.0f} % of load", va="center", fontsize=8)
    ax.axvline(threshold_mmhg, ls="--", color="k", lw=1)
    ax.text(threshold_mmhg, len(shown) - 0.4 if shown else 0, f" {threshold_mmhg:g} mmHg", fontsize=8)
    ax.set_xlim(0, vmax * 1.35)
    ax.set_xlabel("peak pressure (mmHg); red: above the threshold")
    ax.set_title("load per body site")
    name = f"frame {int(est.frame[i])}" if est.frame is not None else f"image {i}"
    top, named = loads.most_loaded()[i], loads.most_loaded(named=True)[i]
    title = f"{name}: most loaded: {site_label(top) or '-'}"
    if top == SITES[OTHER] and named:  # 'the rest of the body' names no site: the named site loaded most too
        title += f"; of the named sites: {site_label(named)}"
    fig.suptitle(title)
    fig.tight_layout()
    return fig


def save_site_figures(est: Estimate, out_dir: str | Path, max_figures: int = 16) -> list[Path]:
    """Write ``sites_000.png``... for the first ``max_figures`` images of an estimate with site
    loads into ``out_dir``, removing numbered site pictures an earlier estimate left there."""
    count = min(len(est), max_figures) if est.sites is not None else 0
    return save_numbered_figures(out_dir, "sites_", count, lambda i: site_figure(est, i))

