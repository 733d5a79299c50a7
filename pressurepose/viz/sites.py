"""Pictures of the load on each body site: the pressure image with the sites outlined, the body
coloured by the pressure under it, and each site's peak against the threshold."""

from __future__ import annotations

from pathlib import Path

import numpy as np

from pressurepose.body.sites import OTHER, SITES, site_label
from pressurepose.net.infer import Estimate
from pressurepose.viz.estimate import save_numbered_figures

THRESHOLD_MMHG = 32.0  # capillary closing pressure (Landis 1930), as pressurepose.eval.monitor


OUTLINE = "#00508c"  # site outlines: dark blue, with a white edge, readable on every colour of the scale


def spread_labels(ax, texts, anchors, gap_px: float = 4.0) -> None:
    """Move text labels (centred on their anchors, data coordinates) apart so that no two overlap and
    each lies inside the axes, in the figure's current layout: top to bottom, a label that would
    overlap one placed before it moves down past it (up, where down leaves the axes), and one moved
    off its anchor gets a thin line back to it. Call it once the layout is final."""
    if not texts:
        return
    ax.apply_aspect()  # the axes take their final place (an equal aspect moves them), without a whole draw
    renderer = ax.figure.canvas.get_renderer()
    frame = ax.get_window_extent(renderer)
    boxes = [t.get_window_extent(renderer) for t in texts]
    # [x0, y0, x1, y1] in display pixels, kept inside the axes
    rects = []
    for b in boxes:
        dx = max(frame.x0 - b.x0, 0.0) + min(frame.x1 - b.x1, 0.0)
        dy = max(frame.y0 - b.y0, 0.0) + min(frame.y1 - b.y1, 0.0)
        rects.append([b.x0 + dx, b.y0 + dy, b.x1 + dx, b.y1 + dy])

    def hits(r, placed):
        return [q for q in placed if r[0] < q[2] + gap_px and q[0] < r[2] + gap_px
                and r[1] < q[3] + gap_px and q[1] < r[3] + gap_px]

    placed: list[list[float]] = []
    for k in sorted(range(len(rects)), key=lambda k: -(rects[k][1] + rects[k][3])):
        r, h = rects[k], rects[k][3] - rects[k][1]
        down, up = list(r), list(r)
        while (q := hits(down, placed)):
            top = min(b[1] for b in q) - gap_px
            down[1], down[3] = top - h, top
        while (q := hits(up, placed)):
            bottom = max(b[3] for b in q) + gap_px
            up[1], up[3] = bottom, bottom + h
        fits_down, fits_up = down[1] >= frame.y0, up[3] <= frame.y1
        if fits_down and (not fits_up or r[1] - down[1] <= up[1] - r[1]):
            rects[k] = down
        elif fits_up:
            rects[k] = up
        else:
            rects[k] = down
        placed.append(rects[k])
    to_data = ax.transData.inverted()
    for t, r, b, anchor in zip(texts, rects, boxes, anchors):
        centre = ((r[0] + r[2]) / 2, (r[1] + r[3]) / 2)
        t.set_position(to_data.transform(centre))
        if abs(centre[1] - (b.y0 + b.y1) / 2) > 1.0 or abs(centre[0] - (b.x0 + b.x1) / 2) > 1.0:
            x, y = to_data.transform(centre)
            ax.plot([anchor[0], x], [anchor[1], y], color="black", lw=0.6, zorder=t.get_zorder() - 0.1)


def site_figure(est: Estimate, i: int = 0, threshold_mmhg: float = THRESHOLD_MMHG):
    """A matplotlib figure for image ``i`` of an estimate with site loads: the pressure image with
    each loaded site outlined and named with its peak (labels moved apart where they would overlap,
    :func:`spread_labels`); the estimated body seen from below through the mat, coloured by the
    pressure under its skin; each site's peak pressure (bars, share of the load written beside them)
    against ``threshold_mmhg``. Sites carrying under 0.5 % of the load are left out of the outlines
    and bars. The two pictures are in metres on the mat, the head end at the top and the bed's left
    side at the left (:data:`pressurepose.viz.mesh.SIDES_NOTE`)."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    from matplotlib import colors as mcolors
    from matplotlib import patheffects

    from pressurepose.viz.estimate import doubt_note
    from pressurepose.viz.mesh import SIDES_NOTE, draw_mesh, label_across_bed, label_along_bed

    if est.sites is None or est.vertex_pressure is None:
        from pressurepose.errors import BadInput

        raise BadInput("this estimate has no site loads (estimate(..., sites=True) computes them)")
    loads, grid = est.sites, est.grid
    w, length = grid.size_m
    extent = (0.0, w, -length, 0.0)  # row 0 (the head end) at the top, as the body seen from below
    vmax = max(float(est.pressure[i].max()), threshold_mmhg * 1.5)
    norm = mcolors.Normalize(0.0, vmax)
    cmap = plt.get_cmap("magma_r")
    fig, axes = plt.subplots(1, 3, figsize=(14, 7), gridspec_kw={"width_ratios": [1, 1, 1.3]})

    ax = axes[0]
    im = ax.imshow(np.ma.masked_less_equal(est.pressure[i], 0), cmap=cmap, norm=norm, extent=extent,
                   interpolation="nearest")
    taxel = loads.taxel_site[i]
    xs = (np.arange(grid.cols) + 0.5) * grid.pitch_col_m
    ys = -(np.arange(grid.rows) + 0.5) * grid.pitch_row_m
    halo = [patheffects.withStroke(linewidth=2.6, foreground="white")]
    labels, anchors = [], []
    for k, name in enumerate(SITES):
        mask = taxel == k
        if loads.share[i, k] < 0.005 or name == "other":  # outline the sites that carry some of the load
            continue
        cs = ax.contour(xs, ys, mask.astype(float), levels=[0.5], colors=OUTLINE, linewidths=1.2)
        cs.set_path_effects(halo)
        rr, cc = np.nonzero(mask)
        anchors.append((xs[cc].mean(), ys[rr].mean()))
        labels.append(ax.text(*anchors[-1], f"{site_label(name)}\n{loads.peak_mmhg[i, k]:.0f}", fontsize=7,
                              ha="center", va="center", color="black", zorder=4,
                              bbox={"boxstyle": "round,pad=0.15", "fc": "white", "ec": "none", "alpha": 0.8}))
    ax.set_xlim(extent[0], extent[1])
    ax.set_ylim(extent[2], extent[3])
    ax.set_title("pressure by body site (peak mmHg)")
    label_across_bed(ax)
    label_along_bed(ax)
    fig.colorbar(im, ax=ax, fraction=0.046, label="pressure (mmHg)")

    ax = axes[1]
    face_p = est.vertex_pressure[i][est.faces].max(axis=1)
    rgb = np.where(face_p[:, None] > 0, np.asarray(cmap(norm(face_p)))[:, :3], 0.82)
    draw_mesh(ax, est.vertices[i], est.faces, view="below", color=rgb)
    ax.plot([0, w, w, 0, 0], [0, 0, -length, -length, 0], ls="--", color="0.5", lw=0.8)
    ax.set_title("estimated body seen from below:\npressure on the skin (grey: none)")
    label_across_bed(ax)
    label_along_bed(ax)
    ax.set_ylabel("")  # one label for the row

    ax = axes[2]
    shown = [k for k in range(len(SITES)) if loads.share[i, k] >= 0.005]
    shown.sort(key=lambda k: loads.peak_mmhg[i, k])
    names = [site_label(SITES[k]) for k in shown]
    peaks = loads.peak_mmhg[i, shown]
    ax.barh(names, peaks, color=["tab:red" if p > threshold_mmhg else "tab:blue" for p in peaks])
    for y, k in enumerate(shown):
        ax.text(loads.peak_mmhg[i, k], y, f" {100 * loads.share[i, k]:.0f} % of load", va="center", fontsize=8)
    ax.axvline(threshold_mmhg, ls="--", color="k", lw=1)
    ax.text(threshold_mmhg, len(shown) - 0.4 if shown else 0, f" threshold {threshold_mmhg:g} mmHg", fontsize=8)
    ax.set_xlim(0, vmax * 1.35)
    ax.set_xlabel("peak pressure (mmHg); red: above the threshold")
    ax.set_title("load per body site")
    top, named = loads.most_loaded()[i], loads.most_loaded(named=True)[i]
    title = f"{est.image_name(i)}: most loaded: {site_label(top) or '-'}"
    if top == SITES[OTHER] and named:  # 'the rest of the body' names no site: the named site loaded most too
        title += f"; of the named sites: {site_label(named)}"
    doubt = doubt_note(est, i)
    fig.suptitle(title + (f"\n{doubt}" if doubt else ""), color="tab:red" if doubt else "black")
    fig.text(0.01, 0.01, f"{SIDES_NOTE[0].upper()}{SIDES_NOTE[1:]}; the head end at the top.", fontsize=8,
             va="bottom")
    fig.tight_layout(rect=(0, 0.03, 1, 1))
    spread_labels(axes[0], labels, anchors)
    return fig


def save_site_figures(est: Estimate, out_dir: str | Path, max_figures: int = 16, progress: bool = False) -> list[Path]:
    """Write ``sites_000.png``... for the first ``max_figures`` images of an estimate with site
    loads into ``out_dir``, removing numbered site pictures an earlier estimate left there.
    progress: a progress bar over the pictures."""
    count = min(len(est), max_figures) if est.sites is not None else 0
    return save_numbered_figures(out_dir, "sites_", count, lambda i: site_figure(est, i),
                                 progress="site pictures" if progress else "")

