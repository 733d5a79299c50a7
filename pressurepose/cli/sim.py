"""CLI verb ``simulate``: settle bodies on the bed and press them."""

from __future__ import annotations

import argparse

import numpy as np

from pressurepose.cli.args import add_progress_argument, seed_arg
from pressurepose.pose.partitions import ALIASES, PARTITIONS
from pressurepose.sim.wedge import FIELDS as WEDGE_FIELDS


def add_settle_argument(p) -> None:
    """``--settle`` (shared by simulate and generate)."""
    from pressurepose.sim.settle_config import SETTLES

    p.add_argument("--settle", choices=SETTLES, default="relaxed",
                   help="how bodies come to rest: neck and spine relax so the head and the heavy pelvis sink "
                        "onto the bed as people lie (relaxed, default); or the paper's joint springs throughout, "
                        "which hold the head and trunk in their standing shape (paper); docs/physics.md")


def add_simulate_arguments(p: argparse.ArgumentParser) -> None:
    from pressurepose.cli.pose import add_body_arguments

    p.add_argument("--partition", required=True,
                   help=f"posture partition: {', '.join(PARTITIONS)} (also {', '.join(ALIASES)})")
    p.add_argument("--gender", required=True, help="f or m")
    p.add_argument("--limbs-on-bed", action="store_true", help="start every limb over the mattress")
    add_body_arguments(p)
    add_settle_argument(p)
    p.add_argument("--count", type=int, default=4, help="settled bodies to make [4]")
    p.add_argument("--seed", type=seed_arg, default=0, help="random seed [0]")
    p.add_argument("--mat", default=None, help="mat preset, or a mat.json of any grid (docs/data.md) "
                                               "[boditrak_bt3510, or the --bed file's]")
    p.add_argument("--bed", default=None, metavar="JSON",
                   help="the bed to lie on: a `pressurepose calibrate --out` file or a BedSpec.to_dict record "
                        "[the mat preset's default bed]")
    p.add_argument("--out", required=True, help="output .npz (docs/data.md): pressure, force, depth, contact, betas, "
                                                "pose, transl, joints, mass, height and wedge per body; gender, "
                                                "partition and the rejection counts")
    p.add_argument("--plot", default=None, help="PNG: each pressure image beside the body at rest, seen from the side")
    add_progress_argument(p)


SIM_FIELDS = ("pressure", "force", "depth", "contact", "betas", "pose", "transl", "joints", "mass", "height")
# and "wedge": the wedge that propped a body (pressurepose.sim.wedge.FIELDS; NaN without one)
NO_WEDGE = np.full(len(WEDGE_FIELDS), np.nan)
MAX_SIM_COUNT = 10_000  # bodies per file (the file is rewritten after each body); use `generate` for more


def _record(sim) -> dict:
    """The arrays of one settled body (see SIM_FIELDS), and its ``wedge`` (NaN without one)."""
    m = sim.image
    return {"pressure": m.pressure, "force": m.force, "depth": m.depth, "contact": m.contact, "betas": sim.betas,
            "pose": sim.pose, "transl": sim.transl, "joints": sim.joints, "mass": np.float64(sim.mass),
            "height": np.float64(sim.height), "wedge": NO_WEDGE if sim.wedge is None else sim.wedge.as_array()}


def _save_simulated(path, done: list[dict], rejected, **extra) -> None:
    from pressurepose.files import save_npz_atomic

    save_npz_atomic(path, **{k: np.stack([r[k] for r in done]) for k in SIM_FIELDS + ("wedge",)},
                    rejection_causes=np.array(sorted(rejected), dtype=str),
                    rejection_counts=np.array([rejected[k] for k in sorted(rejected)], dtype=np.int64), **extra)


def _resume(partial, run_key: str, count: int):
    """Bodies and rejections already in ``partial`` from an interrupted run of the same command."""
    from collections import Counter

    from pressurepose.errors import BadInput
    from pressurepose.files import load_npz

    if not partial.exists():
        return [], Counter()
    z = load_npz(partial, "bodies of an interrupted run (remove the file to start again)")
    if "run_key" in z and str(z["run_key"]) != run_key:
        raise BadInput(f"{partial} holds bodies of another simulate command; remove it or use another --out")
    missing = [k for k in ("run_key", "pressure", "rejection_causes", "rejection_counts", *SIM_FIELDS) if k not in z]
    if missing:
        raise BadInput(f"{partial} (bodies of an interrupted run) lacks {', '.join(missing)}; remove it to start again")
    n = min(len(z["pressure"]), count)
    done = [{**{k: z[k][i] for k in SIM_FIELDS}, "wedge": z["wedge"][i] if "wedge" in z else NO_WEDGE}
            for i in range(n)]
    rejected = Counter(dict(zip(map(str, z["rejection_causes"]), map(int, z["rejection_counts"]))))
    return done, rejected


NOT_IN_KEY = ("out", "plot", "count", "mat", "bed", "no_progress")  # options that change no body


def simulate_key(args, partition: str, gender: str, bed) -> str:
    """The JSON text that ties a partial file to its command: every option that decides the bodies (the
    outputs, the count and the progress bar do not; the mat and bed enter as the bed's record)."""
    import json

    return json.dumps({**{k: v for k, v in vars(args).items() if not k.startswith("_") and k not in NOT_IN_KEY},
                       "partition": partition, "gender": gender, "bed": bed.to_dict()}, sort_keys=True, default=str)


def run_simulate(args) -> int:
    """Settle and press ``count`` bodies (attempt a of body i uses seed (seed, i, a)). Finished bodies
    go to OUT's ``.partial.npz`` as they come; rerunning the same command resumes from it."""
    from tqdm import tqdm

    from pressurepose.body import BodyModel, canonical_gender
    from pressurepose.cli.pose import body_settings
    from pressurepose.errors import BadInput
    from pressurepose.files import (
        FIGURE_SUFFIXES,
        check_output_path,
        save_figure_atomic,
    )
    from pressurepose.pose.config import SamplerConfig
    from pressurepose.pose.partitions import get_partition
    from pressurepose.cli.args import bed_of
    from pressurepose.sim.settle_config import settle_preset
    from pressurepose.sim.simulate import Rejected, simulate_one

    out = check_output_path(args.out, "--out", suffixes=(".npz",))
    if args.plot:
        check_output_path(args.plot, "--plot", suffixes=FIGURE_SUFFIXES)
    if not 1 <= args.count <= MAX_SIM_COUNT:
        raise BadInput(f"--count is {args.count}; expected 1 to {MAX_SIM_COUNT} bodies per file "
                       f"(use `generate` for datasets)")
    partition = get_partition(args.partition).name
    gender = canonical_gender(args.gender)[0]
    body, bed = BodyModel(gender), bed_of(args.mat, args.bed)
    sampler = SamplerConfig(**body_settings(args))
    settle_config = settle_preset(args.settle)
    run_key = simulate_key(args, partition, gender, bed)
    partial = out.with_name(f"{out.stem}.partial.npz")
    done, rejected = _resume(partial, run_key, args.count)
    if done:
        print(f"resuming: {len(done)} bodies already finished in {partial}")
    for i in tqdm(range(len(done), args.count), desc="simulate", unit="body", initial=len(done), total=args.count,
                  disable=args.no_progress):
        for attempt in range(100):
            sim = simulate_one(body, bed, partition, gender,
                               np.random.default_rng([args.seed, i, attempt]), args.limbs_on_bed, sampler,
                               settle_config=settle_config)
            if not isinstance(sim, Rejected):
                done.append(_record(sim))
                break
            rejected[sim.cause] += 1
        else:
            raise BadInput(f"body {i}: no attempt settled in 100 tries ({dict(rejected)}); the {len(done)} "
                           f"finished bodies are kept in {partial}. Try another --seed or --partition")
        _save_simulated(partial, done, rejected, run_key=np.array(run_key))
    _save_simulated(out, done, rejected, gender=np.array(gender), partition=np.array(partition))
    partial.unlink(missing_ok=True)
    print(f"{len(done)} bodies settled and pressed; rejected {sum(rejected.values())} "
          f"({', '.join(f'{k} {v}' for k, v in sorted(rejected.items())) or 'none'}); wrote {out}")
    if args.plot:
        save_figure_atomic(_plot_simulated(body, bed, done), args.plot, dpi=100)
        print(f"wrote {args.plot}")
    return 0


def _draw_wedge_side(ax, wedge) -> None:
    """The wedge's outline seen from the side (y along the bed, z up), shaded behind the body."""
    from scipy.spatial import ConvexHull

    half = wedge.axis * wedge.length_m / 2
    back = wedge.toe + wedge.rise * wedge.base_width_m
    top = back + np.array([0.0, 0.0, wedge.height_m])
    pts = np.array([p + sgn * half for p in (wedge.toe, back, top) for sgn in (-1.0, 1.0)])[:, 1:]
    hull = pts[ConvexHull(pts).vertices]
    ax.fill(hull[:, 0], hull[:, 1], color="tan", alpha=0.5, zorder=0, label="wedge")
    ax.legend(loc="upper right", fontsize=8)


def _plot_simulated(body, bed, done):
    """One row per body: its pressure image on the mat (x across the bed and the distance from the
    head end, metres, as in the ``demo`` picture; one colour scale for all rows, its mmHg bar on top)
    and the body at rest seen from the bed's right side (+x), the head end at the left."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    from pressurepose.sim.wedge import Wedge
    from pressurepose.viz.mesh import draw_mesh, label_across_bed, label_along_bed

    mat = bed.mat
    extent = [0, mat.cols * mat.pitch_col_m, -mat.rows * mat.pitch_row_m, 0]  # row 0 (head end) at -y = 0
    vmax = max(max(float(s["pressure"].max()) for s in done), 1e-6)
    n = len(done)
    fig, axes = plt.subplots(n, 2, figsize=(9, 3.4 * n), gridspec_kw={"width_ratios": [1, 2.6]}, squeeze=False,
                             layout="constrained")
    verts = np.concatenate([body.forward(s["betas"], s["pose"], s["transl"])[0] for s in done])
    # one frame for every side view, the whole mat's length and every body in it: one scale for all rows
    side_y = (min(0.0, float(verts[..., 1].min())) - 0.05, max(-extent[2], float(verts[..., 1].max())) + 0.05)
    side_z = (float(verts[..., 2].min()) - 0.03, float(verts[..., 2].max()) + 0.03)
    for (a_img, a_side), s, v in zip(axes, done, verts):
        im = a_img.imshow(s["pressure"], extent=extent, cmap="viridis", vmin=0, vmax=vmax, interpolation="nearest")
        a_img.set_title(f"{float(s['mass']):.0f} kg, peak {s['pressure'].max():.0f} mmHg", fontsize=9)
        label_across_bed(a_img)
        label_along_bed(a_img)
        draw_mesh(a_side, v, body.faces, "bed_side")
        wedge = Wedge.from_array(s["wedge"])
        if wedge is not None:
            _draw_wedge_side(a_side, wedge)
        a_side.axhline(0.0, color="0.4", lw=1)
        a_side.set_xlim(*side_y)
        a_side.set_ylim(*side_z)
        a_side.set_title("at rest, seen from the bed's right side (grey line: the unloaded mattress top)", fontsize=9)
        a_side.set_xlabel("from the head end (m)")
        a_side.set_ylabel("height (m)")
    fig.colorbar(im, ax=axes[:, 0], location="top", aspect=15, label="pressure (mmHg)")
    return fig
