"""Pictures of estimates: the pressure image, the reconstructed map Q and the body from below."""

from __future__ import annotations

from pathlib import Path

from pressurepose.files import remove_stale_numbered, save_figure_atomic
from pressurepose.net.infer import Estimate

CAPTION = ("Q is how far the estimated body's lower surface lies below the mattress top at each taxel. Where the "
           "image reads pressure and Q reads 0, the estimate has no part of the body sunk there: a limb or head "
           "placed a few cm off, or held above the mattress (docs/real-mats.md).")


def doubt_note(est: Estimate, i: int) -> str:
    """'' where image ``i`` looks like a person lying on the mat (or was not checked), else a line
    saying that it does not and why, for a picture's title: its estimate means nothing."""
    p = est.plausibility
    if p is None or p.doubt[i] is None:
        return ""
    import textwrap

    return textwrap.fill(f"this image does not look like a person lying on the mat ({p.reason[i]}): the estimate "
                         f"means nothing", 110)


def estimate_figure(est: Estimate, i: int = 0):
    """A matplotlib figure: the pressure image, the reconstructed map Q (the estimated body's sink,
    :func:`pressurepose.net.pmr.surface_maps`) and the body seen from below through the mat (laid
    out like the images: row 0 / the head end at the top, the bed's left side at the left; every
    panel in metres on the mat), with :data:`CAPTION` under them and the image's name (and a doubt
    about it, :func:`doubt_note`) over them."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    from matplotlib.patches import Rectangle

    from pressurepose.viz.mesh import SIDES_NOTE, draw_mesh, label_across_bed, label_along_bed

    w, length = est.grid.size_m
    extent = (0.0, w, -length, 0.0)  # row 0 (the head end) at the top, as the body seen from below
    fig, axes = plt.subplots(1, 3, figsize=(12, 6.8))
    for ax, img, title, unit in ((axes[0], est.pressure[i], "pressure image", "pressure (mmHg)"),
                                 (axes[1], est.q[i], "reconstructed map Q\n(the estimated body's sink)", "mm of sink")):
        im = ax.imshow(img, cmap="magma", interpolation="nearest", extent=extent, vmin=0)
        ax.set_title(title)
        fig.colorbar(im, ax=ax, fraction=0.046, label=unit)
        label_across_bed(ax)
        label_along_bed(ax)
    ax = axes[2]
    ax.add_patch(Rectangle((0, -length), w, length, fill=False, ls="--", color="0.5", label="mat"))
    draw_mesh(ax, est.vertices[i], est.faces, view="below")
    j = est.joints[i]
    ax.plot(j[:, 0], -j[:, 1], "o", ms=3, color="tab:red", label="joints")
    ax.legend(loc="lower right", fontsize=7)
    ax.set_title(f"estimated body ({'female' if est.gender[i] == 'f' else 'male'}),\nseen from below through the mat")
    label_across_bed(ax)
    label_along_bed(ax)
    for ax in axes[1:]:
        ax.set_ylabel("")  # one label for the row
    title = f"{est.image_name(i)}: the pressure image and the body estimated from it"
    doubt = doubt_note(est, i)
    fig.suptitle(title + (f"\n{doubt}" if doubt else ""), color="tab:red" if doubt else "black")
    fig.text(0.01, 0.01, f"{CAPTION} {SIDES_NOTE[0].upper()}{SIDES_NOTE[1:]}.", fontsize=8, va="bottom", wrap=True)
    fig.tight_layout(rect=(0, 0.06, 1, 1))
    return fig


def drop_spent_layout(fig) -> None:
    """Forget the placeholder that ``fig.tight_layout()`` leaves as the figure's layout engine: it lays
    nothing out, but while it is there ``savefig`` draws the whole figure once more, for nothing, before
    drawing it into the file (a third of the time of saving). A real layout engine is kept."""
    from matplotlib.layout_engine import PlaceHolderLayoutEngine

    if isinstance(fig.get_layout_engine(), PlaceHolderLayoutEngine):
        fig.set_layout_engine(None)


def save_numbered_figures(out_dir: str | Path, prefix: str, count: int, draw, progress: str = "") -> list[Path]:
    """Write ``PREFIX000.png``... : ``draw(i)`` for i < ``count`` into ``out_dir``, removing numbered
    pictures of the same prefix an earlier, longer estimate left there. Returns the paths written.
    progress: the label of a progress bar over the pictures (about a second each); "" for none.
    Matplotlib is loaded only when there is a picture to draw."""
    out = Path(out_dir)
    out.mkdir(parents=True, exist_ok=True)
    paths = []
    if count:
        import matplotlib.pyplot as plt
        from tqdm import tqdm

        for i in tqdm(range(count), desc=progress, unit="picture", disable=not progress):
            p = out / f"{prefix}{i:03d}.png"
            fig = draw(i)
            drop_spent_layout(fig)
            save_figure_atomic(fig, p, dpi=110)
            plt.close(fig)
            paths.append(p)
    remove_stale_numbered(out, prefix, (".png",), paths)
    return paths


def save_estimate_figures(est: Estimate, out_dir: str | Path, max_figures: int = 16,
                          progress: bool = False) -> list[Path]:
    """Write ``estimate_000.png``... for the first ``max_figures`` images of ``est`` into ``out_dir``,
    removing numbered pictures an earlier estimate left there. Returns the paths written.
    progress: a progress bar over the pictures."""
    return save_numbered_figures(out_dir, "estimate_", min(len(est), max_figures), lambda i: estimate_figure(est, i),
                                 progress="pictures" if progress else "")
