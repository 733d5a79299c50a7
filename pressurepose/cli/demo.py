"""``pressurepose demo``: the whole pipeline on built-in defaults, drawn and summarised.

sample a body (pose sampler) -> settle it on the soft bed (MuJoCo ragdoll) -> press its mesh and
read the mat (pressure image) -> estimate pose and shape from the image (the shipped PressureNet)
-> compare with the truth (MPJPE, vertex-to-vertex error) and write ``OUT/demo.png``.
"""

from __future__ import annotations

import argparse
import time
from pathlib import Path

import numpy as np

from pressurepose.cli.args import seed_arg


def add_demo_arguments(p: argparse.ArgumentParser) -> None:
    p.add_argument("--gender", default="f", help="f or m [f]")
    p.add_argument("--partition", default="general_supine", help="posture partition to sample [general_supine]")
    p.add_argument("--seed", type=seed_arg, default=0, help="random seed [0]")
    p.add_argument("--model", default=None, help="PressureNet checkpoint [the shipped model]")
    p.add_argument("--out", default="demo_out", help="output folder [demo_out]")


def _stage(name: str, t0: float) -> float:
    t = time.perf_counter()
    print(f"  {name:<34s} {t - t0:6.2f} s")
    return t


def run_demo(args) -> int:
    from pressurepose.body import BodyModel, canonical_gender
    from pressurepose.errors import BadInput
    from pressurepose.files import check_output_path, save_figure_atomic
    from pressurepose.net.infer import DEFAULT_MODEL, estimate, resolve_model
    from pressurepose.pose.partitions import get_partition
    from pressurepose.sim.bed import get_bed
    from pressurepose.sim.simulate import Rejected, simulate_one

    out = check_output_path(args.out, "--out", directory=True)
    if str(args.gender).lower() not in ("f", "m", "female", "male"):  # the network's body models
        raise BadInput(f"--gender {args.gender!r}: the demo's network estimates female or male bodies; expected f or m")
    gender = canonical_gender(args.gender)[0]
    partition = get_partition(args.partition).name
    if args.model:  # a bad model, or one for another mat, fails now, not after the simulation
        grid, mat = resolve_model(args.model).config.grid, get_bed().mat
        if tuple(grid.shape) != tuple(mat.shape):
            raise BadInput(f"--model {args.model} reads {grid.shape[0]} x {grid.shape[1]} mats; the demo's "
                           f"{mat.name} is {mat.rows} x {mat.cols}")
    out.mkdir(parents=True, exist_ok=True)
    rng = np.random.default_rng(args.seed)
    print(f"pressurepose demo: one {partition} {'female' if gender == 'f' else 'male'} body, seed {args.seed}")
    t = time.perf_counter()
    body, bed = BodyModel(gender), get_bed()
    t = _stage("load body model and bed", t)
    for _ in range(20):
        sim = simulate_one(body, bed, partition, gender, rng)
        if not isinstance(sim, Rejected):
            break
        print(f"  (sample rejected: {sim.cause}{f' ({sim.detail})' if sim.detail else ''}; drawing another)")
    else:
        raise BadInput(f"no {partition} body settled in 20 attempts; try another --seed")
    t = _stage(f"sample + settle ({sim.settle_steps} steps) + press", t)
    image = sim.image
    true_v, true_j = body.forward(sim.betas, sim.pose, sim.transl)
    print(f"  body {sim.height:.2f} m, {sim.mass:.1f} kg; sank {100 * image.sink_m:.1f} cm; "
          f"peak {image.pressure.max():.0f} mmHg; {int(image.contact.sum())} taxels in contact")

    model = args.model or DEFAULT_MODEL
    est = None
    if args.model or Path(model).is_file():
        est = estimate(image.pressure, gender, model=model)
        t = _stage("estimate pose and shape (PressureNet)", t)
        mpjpe = 100 * np.linalg.norm(est.joints[0] - true_j[0], axis=-1).mean()
        v2v = 100 * np.linalg.norm(est.vertices[0] - true_v[0], axis=-1).mean()
        print(f"  estimate against the truth: MPJPE {mpjpe:.1f} cm, vertex-to-vertex {v2v:.1f} cm")
    else:
        print(f"  no trained PressureNet at {model}: rebuild it with `python tools/train_shipped_model.py`")
    path = out / "demo.png"
    title = (f"demo: a simulated {partition} {'female' if gender == 'f' else 'male'} body ({sim.height:.2f} m, "
             f"{sim.mass:.0f} kg, seed {args.seed}) on the {bed.mat.name} mat"
             + (f",\nand the body PressureNet estimates from its pressure image (MPJPE {mpjpe:.1f} cm)"
                if est is not None else ""))
    save_figure_atomic(_figure(body, bed, image, true_v[0], true_j[0], est, title=title), path, dpi=110)
    print(f"wrote {path}")
    return 0


def _figure(body, bed, image, true_v, true_j, est, title: str | None = None):
    """The simulated pressure image (mmHg) and the true body at rest seen from below, through the mat;
    with an estimate, also its reconstructed map Q (the estimated body's sink, mm) and the estimated
    body from below. Every panel has the same frame: the mat and both bodies, whole, the head end at
    the top and the bed's left side at the left (the sides named under the panels); ``title`` over
    them."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    from matplotlib.patches import Rectangle

    from pressurepose.viz.mesh import SIDES_NOTE, below_extent, draw_mesh, label_across_bed, label_along_bed

    mat = bed.mat
    w, h = mat.cols * mat.pitch_col_m, mat.rows * mat.pitch_row_m
    extent = [0, w, -h, 0]  # the 'below' view draws (x, -y): row 0 at the top, like the image
    bodies = true_v[None] if est is None else np.stack([true_v, est.vertices[0]])
    x0, x1, y0, y1 = below_extent(bodies, (w, h))
    n = 4 if est is not None else 2
    fig, axes = plt.subplots(1, n, figsize=(3.4 * n, 6.4))

    def colour_bar(ax, im, label):  # beside the panel, taking no room from it: every panel keeps one size
        fig.colorbar(im, cax=ax.inset_axes([1.03, 0.3, 0.05, 0.4]), label=label)

    im = axes[0].imshow(image.pressure, extent=extent, cmap="viridis", vmin=0, interpolation="nearest")
    axes[0].set_title("simulated pressure image")
    colour_bar(axes[0], im, "pressure (mmHg)")
    draw_mesh(axes[1], true_v, body.faces, "below", color=(0.55, 0.7, 0.9))
    axes[1].scatter(true_j[:, 0], -true_j[:, 1], s=8, c="k", zorder=5, label="true joints")
    axes[1].legend(loc="lower right", fontsize=7)
    axes[1].set_title("true body at rest\n(seen through the mat)")
    if est is not None:
        im = axes[2].imshow(est.q[0], extent=extent, cmap="magma", vmin=0, interpolation="nearest")
        axes[2].set_title("reconstructed map Q\n(the estimate's sink)")
        colour_bar(axes[2], im, "mm of sink")
        draw_mesh(axes[3], est.vertices[0], est.faces, "below", color=(0.95, 0.65, 0.4))
        axes[3].scatter(true_j[:, 0], -true_j[:, 1], s=8, c="k", zorder=5, label="true joints")
        axes[3].scatter(est.joints[0, :, 0], -est.joints[0, :, 1], s=8, c="r", zorder=6, label="estimated")
        axes[3].legend(loc="lower right", fontsize=7)
        axes[3].set_title("estimated body\n(seen through the mat)")
    for ax in axes[1::2]:
        ax.add_patch(Rectangle((0, -h), w, h, fill=False, ls="--", color="0.5"))
    for ax in axes:
        ax.set_xlim(x0, x1)
        ax.set_ylim(y0, y1)
        ax.set_aspect("equal")
        label_across_bed(ax)
        label_along_bed(ax)
    for ax in axes[1:]:
        ax.set_ylabel("")  # one label for the row
    if title:
        fig.suptitle(title)
    fig.text(0.01, 0.01, f"{SIDES_NOTE[0].upper()}{SIDES_NOTE[1:]}; the head end at the top.", fontsize=8,
             va="bottom")
    fig.tight_layout(w_pad=3.0, rect=(0, 0.03, 1, 1))
    return fig
