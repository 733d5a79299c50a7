"""The picture of a dataset summary (``pressurepose info``): sample images, the pressure histogram,
the load ratios and the counts by partition."""

from __future__ import annotations

from pathlib import Path

import numpy as np

from pressurepose.data.info import Summary
from pressurepose.files import save_figure_atomic


def histogram_limit(hist: np.ndarray, edges: np.ndarray) -> float:
    """The upper edge (mmHg) of the last non-empty bin of a histogram (counts (K,), edges (K + 1,)):
    where the data end (the first edge's neighbour when every bin is empty)."""
    filled = np.flatnonzero(hist > 0)
    return float(edges[filled[-1] + 1] if len(filled) else edges[1])


def summary_figure(s: Summary):
    """Figure: the sample pressure images side by side on top (the head end at the top, said beside
    the first), with one colour scale (mmHg bar to their right), and below them the pressure
    histogram of loaded taxels (its axis ends with the data), the load ratios and, when the dataset holds more than one partition, gender or limbs
    setting, the counts of each (one of them is said in the title)."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    from matplotlib.ticker import MaxNLocator

    n_ex = len(s.examples)
    width = max(10.0, 1.7 * n_ex + 1.0)
    fig = plt.figure(figsize=(width, 8.0), layout="constrained")
    top, bottom = fig.subfigures(2, 1, height_ratios=[1.6, 1.0])
    if s.examples:
        rows, cols = s.examples[0][1].shape
        used = n_ex * (4.2 * cols / rows + 0.2) + 1.0  # inches the images (~4.2 in tall) and the bar need
        if used < width:  # few images: keep them together in the middle of the row, not spread across it
            margin = (width - used) / 2
            top = top.subfigures(1, 3, width_ratios=[margin, used, margin])[1]
        axes = top.subplots(1, n_ex, squeeze=False)[0]
        vmax = max(float(img.max()) for _, img in s.examples) or 1.0
        for ax, (title, img) in zip(axes, s.examples):
            im = ax.imshow(img, cmap="viridis", vmin=0, vmax=vmax, interpolation="nearest")
            ax.set_title(title, fontsize=7)
            ax.set_xticks([])
            ax.set_yticks([])
        axes[0].set_ylabel("head end at the top", fontsize=8)
        top.colorbar(im, ax=axes, shrink=0.8, label="pressure (mmHg)")
    labels = sorted(s.counts)
    panels = bottom.subplots(1, 3 if len(labels) > 1 else 2)
    ax = panels[0]
    if s.pressure_hist is not None:
        hist, edges = s.pressure_hist
        ax.bar(edges[:-1], hist, width=np.diff(edges), align="edge")
        ax.set_yscale("log")
        ax.set_xlim(0, histogram_limit(hist, edges))
    ax.set_xlabel("pressure of loaded taxels (mmHg)")
    ax.set_ylabel("taxels")
    ax = panels[1]
    if s.load_ratio is not None:
        ax.hist(s.load_ratio, bins=40)
    ax.yaxis.set_major_locator(MaxNLocator(integer=True))
    ax.set_xlabel("force on mat / body weight")
    ax.set_ylabel("samples")
    if len(labels) > 1:
        ax = panels[2]
        ax.barh([f"{p[:14]} {g}{' plo' if plo else ''}" for p, g, plo in labels], [s.counts[k] for k in labels])
        ax.tick_params(axis="y", labelsize=7)
        ax.set_xlabel("samples")
        what = ""
    else:
        what = "".join(f" of {p}, {'female' if g == 'f' else 'male'}{', limbs on bed' if plo else ''}"
                       for p, g, plo in labels)
    fig.suptitle(f"{s.root.name}: {s.samples} samples{what}, rejected {100.0 * s.rejection_rate:.1f}% of attempts")
    return fig


def draw_summary(s: Summary, path: str | Path) -> Path:
    """Write :func:`summary_figure` of ``s`` to ``path`` (PNG, PDF or SVG); returns the path."""
    import matplotlib.pyplot as plt

    fig = summary_figure(s)
    path = Path(path)
    save_figure_atomic(fig, path, dpi=100)
    plt.close(fig)
    return path
