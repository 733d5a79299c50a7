"""The gallery of a real-image evaluation: the best and worst estimates beside their inputs."""

from __future__ import annotations

import numpy as np

RULE = ("rows ranked by the posture (read right first), then the stature error where the height is known "
        "(smallest first), then the contact IoU; one row per image")


def gallery_picks(rows: dict, count: int) -> list[tuple[str, int]]:
    """[("best" | "worst", row index)]: up to ``count`` best and ``count`` worst estimates, each of
    another image (an image estimated with both body models shows once, by its better estimate
    among the best and its worse one among the worst), ranked as :data:`RULE` says.

    rows: the per-estimate columns of :func:`pressurepose.eval.real.evaluate_real` (image, scored,
    correct, stature_err_m, contact_iou)."""
    n = len(rows["image"])
    # posture: 0 right, 1 not scored (a label the classes do not name), 2 wrong
    posture = np.where(rows["scored"], np.where(rows["correct"], 0, 2), 1)
    err = np.abs(np.asarray(rows["stature_err_m"], dtype=np.float64))
    known = np.isfinite(err)
    iou = np.asarray(rows["contact_iou"], dtype=np.float64)
    # lexsort's last key ranks first: posture, then whether the stature is known, its error, the IoU
    order = np.lexsort((-iou, np.where(known, err, 0.0), ~known, posture))
    count = min(count, len(np.unique(rows["image"])) // 2 or 1)

    def distinct(indices, taken):
        out = []
        for i in indices:
            if len(out) == count:
                break
            if rows["image"][i] not in taken:
                taken.add(rows["image"][i])
                out.append(int(i))
        return out

    taken: set = set()
    best = distinct(order, taken)
    worst = distinct(order[::-1], taken) if n > 1 else []
    return [("best", i) for i in best] + [("worst", i) for i in worst]


def _row_title(kind: str, rows: dict, i: int) -> str:
    if not rows["scored"][i]:
        posture = f"posture {rows['predicted'][i]} (label {rows['posture'][i]}, not scored)"
    else:
        verdict = "right" if rows["correct"][i] else "wrong"
        posture = f"posture {verdict}: {rows['predicted'][i]} (label {rows['posture'][i]})"
    err = rows["stature_err_m"][i]
    stature = (f"stature {rows['stature_m'][i]:.2f} m, error {round(100 * err):+d} cm" if np.isfinite(err)
               else f"stature {rows['stature_m'][i]:.2f} m (height unknown)")
    return (f"{kind}: S{rows['subject'][i]} {rows['detail'][i]}, {rows['body_model'][i]} body model\n"
            f"{posture}; {stature}; contact IoU {rows['contact_iou'][i]:.2f}")


def gallery_figure(result, count: int = 3):
    """Figure: the ``count`` best and worst estimates of a real-image evaluation (picked by
    :func:`gallery_picks`, each of another image), one row each: the model input (mmHg), the
    estimated body's reconstructed map Q (mm of sink; the input's contact outlined) and the body
    seen from below through the mat, laid out like the images (as in the ``infer`` picture: a
    supine body shows its back; the head end at the top, its ticks the distance from it, and the
    bed's left side at the left), every body on the same scale and extent.

    result: what :func:`pressurepose.eval.real.evaluate_real` returns."""
    # what the picture reads of the evaluation
    rows, est, x = result.rows, result.estimate, result.input
    contact_mmhg = result.contact_mmhg

    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    from matplotlib.patches import Rectangle

    from pressurepose.viz.mesh import SIDES_NOTE, below_extent, draw_mesh, label_across_bed, label_along_bed

    picks = gallery_picks(rows, count)
    idx = [i for _, i in picks]
    w, length = est.grid.size_m
    x0, x1, y0, y1 = below_extent(est.vertices[idx], (w, length))
    p_max = max(float(x[idx].max()), 1e-6)
    q_max = max(float(est.q[idx].max()), 1e-6)
    fig = plt.figure(figsize=(10, 5.2 * len(picks) + 0.6), layout="constrained")
    fig.suptitle("Best and worst estimates: " + RULE.replace(", then the stature", ",\nthen the stature")
                 + f"\n({SIDES_NOTE})", fontsize=10)
    for (kind, i), sub in zip(picks, fig.subfigures(len(picks), 1, squeeze=False)[:, 0]):
        sub.suptitle(_row_title(kind, rows, i), fontsize=9, fontweight="bold", ha="left", x=0.02)
        ax = sub.subplots(1, 3)
        im = ax[0].imshow(x[i], cmap="magma", interpolation="nearest", vmin=0, vmax=p_max)
        ax[0].set_title("input", fontsize=9)
        sub.colorbar(im, ax=ax[0], shrink=0.9, label="mmHg")
        im = ax[1].imshow(est.q[i], cmap="magma", interpolation="nearest", vmin=0, vmax=q_max)
        ax[1].contour(x[i] > contact_mmhg, [0.5], colors="tab:cyan", linewidths=0.7)
        ax[1].set_title(f"reconstructed map Q\n(cyan: input above {contact_mmhg:g} mmHg)", fontsize=9)
        sub.colorbar(im, ax=ax[1], shrink=0.9, label="mm of sink")
        for a in ax[:2]:
            a.set_xticks([])
            a.set_yticks([])
        ax[2].add_patch(Rectangle((0, -length), w, length, fill=False, ls="--", color="0.5"))
        draw_mesh(ax[2], est.vertices[i], est.faces, view="below")
        ax[2].set_xlim(x0, x1)
        ax[2].set_ylim(y0, y1)
        ax[2].set_aspect("equal")
        ax[2].set_title("estimated body from below\ndashed: the mat", fontsize=9)
        label_along_bed(ax[2])
        label_across_bed(ax[2])
        ax[2].xaxis.label.set_fontsize(8)
        ax[2].yaxis.label.set_fontsize(8)
        ax[2].tick_params(labelsize=7)
    return fig
