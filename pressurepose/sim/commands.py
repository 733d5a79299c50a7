"""CLI verb ``calibrate``: fit the bed's foundation and sensor constants with CMA-ES."""

from __future__ import annotations

import argparse
import time
from pathlib import Path

import numpy as np

from pressurepose.cli import seed_arg
from pressurepose.pose.partitions import ALIASES, PARTITIONS
from pressurepose.sim.wedge import FIELDS as WEDGE_FIELDS


def add_calibrate_arguments(p: argparse.ArgumentParser) -> None:
    p.description = (
        "Fit the mattress (Winkler stiffness k_A, Pasternak spread sqrt(G/k_A)) and sensor constants "
        "(c0, c1, c2) with CMA-ES. With --data, to measured capsule objects (pressure images and sink depths, "
        "format in docs/calibration.md) by the paper's loss L_F + L_C + L_Q; with --targets default, to the "
        "documented sink depth and peak pressure of an average body (needs a body model). Writes the fitted "
        "bed as JSON (load it with pressurepose.sim.bed.load_bed).")
    src = p.add_mutually_exclusive_group(required=True)
    src.add_argument("--data", help="calibration measurements (.npz, see docs/calibration.md)")
    src.add_argument("--targets", choices=["default", "real"],
                     help="fit to the documented physical targets (default), or to statistics of real images "
                          "(real: with --real and --bodies; pressurepose.sim.calibrate_people)")
    p.add_argument("--real", help="--targets real: real-data folder (e.g. PMD experiment I) or a realism.json")
    p.add_argument("--bodies",
                   help="--targets real: settled bodies to re-press (dataset directory or simulate .npz)")
    p.add_argument("--per-posture", type=int, default=4, help="--targets real: bodies per posture group [4]")
    p.add_argument("--match-extent", action="store_true",
                   help="--targets real: draw the bodies so that how long they lie (contact extent over stature) "
                        "follows the real images' (as `realism --match-extent`); the first ones otherwise")
    p.add_argument("--bed", default=None, metavar="JSON",
                   help="--targets real: the bed to start from and the bodies' bed (a calibrate --out file) "
                        "[the mat preset's default bed]")
    p.add_argument("--mat", default=None,
                   help="mat preset for --targets (boditrak_bt3510, slp, tip, fsa_softflex_2048) [boditrak_bt3510]; "
                        "--data uses its own mat")
    p.add_argument("--body", default="f",
                   help="body for --targets: f, m, n (shipped models) or an SMPL-format file [f]")
    p.add_argument("--fit", default=None,
                   help="comma-separated constants to fit, from stiffness, spread, c0, c1, c2, tissue, "
                        "threshold and (--targets real) bone_pelvis, bone_spine, ... bone_hand "
                        "[stiffness,spread,c0,c1,c2 for --data; stiffness,spread for --targets default; "
                        "stiffness,tissue,threshold for --targets real]")
    p.add_argument("--popsize", type=int, default=None, help="CMA-ES population size [50; 10 for --targets real]")
    p.add_argument("--seed", type=seed_arg, default=0, help="random seed of CMA-ES [0]")
    p.add_argument("--max-evals", type=int, default=None,
                   help="loss evaluations to stop at (CMA-ES stops at the end of the generation that reaches "
                        "it, so up to one population more) [5000; 400 for --targets real]")
    p.add_argument("--out", default="bed_params.json", help="output JSON [bed_params.json]")
    p.add_argument("--plot", default=None, help="also draw measured vs simulated images (PNG)")


def run_calibrate(args) -> int:
    from pressurepose.errors import BadInput
    from pressurepose.files import (
        FIGURE_SUFFIXES,
        check_output_path,
        save_figure_atomic,
        write_json_atomic,
    )
    from pressurepose.mat import DEFAULT_MAT
    from pressurepose.sim import calibrate as cal
    from pressurepose.sim.bed import BedSpec, get_bed
    from pressurepose.sim.calibration_data import load_measurements

    check_output_path(args.out, "--out", suffixes=(".json",))
    if args.plot:
        check_output_path(args.plot, "--plot", suffixes=FIGURE_SUFFIXES)
    if args.max_evals is not None and args.max_evals < 1:
        raise BadInput(f"--max-evals is {args.max_evals}; expected at least 1 loss evaluation")
    if args.targets == "real":
        from pressurepose.sim.calibrate_people import run_people_calibration

        return run_people_calibration(args)
    args.popsize = 50 if args.popsize is None else args.popsize
    args.max_evals = 5000 if args.max_evals is None else args.max_evals
    fit = tuple(s.strip() for s in args.fit.split(",")) if args.fit else None
    if args.bed or args.match_extent:
        raise BadInput("--bed and --match-extent are options of --targets real")
    bones = [n for n in fit or () if n in cal.BONE_PARAMETERS]
    if bones:
        raise BadInput(f"--fit {','.join(bones)}: bone fractions shape the tissue of people, so they are fitted "
                       f"with --targets real only")
    t0 = time.perf_counter()

    def progress(gen, evals, best):
        if gen % 10 == 0:
            print(f"generation {gen}: {evals} evaluations, best loss {best:.5f}", flush=True)

    common = dict(popsize=args.popsize, seed=args.seed, max_evals=args.max_evals, progress=progress)
    if args.data:
        data = load_measurements(args.data)
        bed = BedSpec(mat=data.mat)
        fit = fit or ("stiffness", "spread", "c0", "c1", "c2")
        res = cal.calibrate(data, bed, fit=fit, **common)
        source = {"data": str(Path(args.data).resolve()), "objects": len(data)}
    else:
        from pressurepose.body import BodyModel

        bed = get_bed(args.mat or DEFAULT_MAT)
        body = BodyModel(args.body)
        verts, faces, _ = cal.supine_body_mesh(body, bed)
        fit = fit or ("stiffness", "spread")
        res = cal.calibrate_targets(verts, faces, cal.DEFAULT_TARGETS, bed, fit=fit, **common)
        t = cal.DEFAULT_TARGETS
        source = {"targets": {"max_sink_m": t.max_sink_m, "peak_mmhg": t.peak_mmhg, "mass_kg": t.mass_kg,
                              "sources": list(t.sources)}, "body": repr(body)}
    if not res.loss < cal.PENALTY:
        raise BadInput(f"the fit found no bed it could simulate (best loss {res.loss:.3g} is the penalty "
                       f"{cal.PENALTY:g} for a failed press or a sensor out of range); nothing was written. "
                       f"Check that the objects lie on the mat and their masses and images are right")
    record = {"bed": res.bed.to_dict(), "loss": res.loss, "fit": list(fit), "fitted": res.fitted,
              "evaluations": res.evaluations,
              "generations": res.generations, "stop": {k: str(v) for k, v in res.stop.items()},
              "popsize": args.popsize, "seed": args.seed, "source": source,
              "seconds": round(time.perf_counter() - t0, 1)}
    write_json_atomic(args.out, record, indent=2)
    print(f"loss {res.loss:.5f} after {res.evaluations} evaluations; fitted " +
          ", ".join(f"{k}={res.fitted[k]:.6g}" for k in fit) + " (the bed's other constants unchanged)")
    print(f"wrote {args.out}")
    if args.plot:
        if args.data:
            fig = _plot_measurements(data, res)
        else:
            fig = _plot_body(verts, faces, res, cal.DEFAULT_TARGETS)
        save_figure_atomic(fig, args.plot, dpi=110)
        print(f"wrote {args.plot}")
    return 0


def _plot_measurements(data, res):
    import matplotlib.pyplot as plt

    from pressurepose.sim import calibrate as cal

    fields = cal.measurement_heightfields(data, res.bed)
    force, sink = cal.simulate(res.bed, fields, data.mass_kg)
    sim = cal.readings(force, res.bed)
    n = min(len(data), 6)
    fig, axes = plt.subplots(2, n + 1, figsize=(2.2 * (n + 1), 7), squeeze=False)
    vmax = max(float(data.pressure_mmhg[:n].max()), float(sim[:n].max()), 1e-9)
    for j in range(n):
        for row, (img, q, label) in enumerate(((data.pressure_mmhg[j], data.sink_m[j], "measured"),
                                               (sim[j], sink[j], "simulated"))):
            ax = axes[row, j]
            ax.imshow(img, vmin=0, vmax=vmax, cmap="viridis")
            ax.set_title(f"{label} #{j}\n{data.mass_kg[j]:.1f} kg, sink {100 * q:.1f} cm", fontsize=8)
            ax.axis("off")
    _plot_history(axes[0, n], res)
    axes[1, n].axis("off")
    fig.tight_layout()
    return fig


def _plot_body(verts, faces, res, targets):
    import matplotlib.pyplot as plt

    from pressurepose.sim.press import press

    out = press(verts, faces, targets.mass_kg, res.bed)
    fig, axes = plt.subplots(1, 2, figsize=(8, 6))
    im = axes[0].imshow(out.pressure, cmap="viridis")
    fig.colorbar(im, ax=axes[0], label="mmHg")
    axes[0].set_title(f"peak {out.pressure.max():.1f} mmHg (target {targets.peak_mmhg:g})\n"
                      f"sink {100 * out.sink_m:.1f} cm (target {100 * targets.max_sink_m:g})", fontsize=9)
    _plot_history(axes[1], res)
    fig.tight_layout()
    return fig


def _plot_history(ax, res):
    ax.semilogy(np.arange(1, len(res.history) + 1), np.maximum(res.history, 1e-12))
    ax.set_xlabel("generation")
    ax.set_ylabel("best loss")
    ax.set_title("CMA-ES", fontsize=9)



def add_settle_argument(p) -> None:
    """``--settle`` (shared by simulate and generate)."""
    # sim.settle.SETTLES, written out: importing the settle (and MuJoCo) here would slow every command's start
    p.add_argument("--settle", choices=("relaxed", "paper", "relaxed-limbs"), default="relaxed",
                   help="how bodies come to rest: neck and spine relax so the head and the heavy pelvis sink "
                        "onto the bed as people lie (relaxed, default); the paper's joint springs throughout, "
                        "which hold the head and trunk in their standing shape (paper); or relaxed with limbs "
                        "damped 5x less than the paper's, so resting hands lie on the bed (relaxed-limbs); "
                        "docs/physics.md")


def add_simulate_arguments(p: argparse.ArgumentParser) -> None:
    from pressurepose.pose.commands import add_body_arguments

    p.add_argument("--partition", required=True,
                   help=f"posture partition: {', '.join(PARTITIONS)} (also {', '.join(ALIASES)})")
    p.add_argument("--gender", required=True, help="f or m")
    p.add_argument("--limbs-on-bed", action="store_true", help="start every limb over the mattress")
    p.add_argument("--height-reference", choices=("proximal", "bed"), default="proximal",
                   help="where ankles and wrists start: within 0.2 m of their hip's or shoulder's height "
                        "(proximal, default) or 0.1 m below to 0.3 m above the surface the body lies on "
                        "(bed: fewer bodies on their side roll over while settling; see `sample --help`)")
    add_body_arguments(p)
    add_settle_argument(p)
    p.add_argument("--count", type=int, default=4, help="settled bodies to make [4]")
    p.add_argument("--seed", type=seed_arg, default=0, help="random seed [0]")
    p.add_argument("--mat", default=None, help="mat preset [boditrak_bt3510, or the --bed file's]")
    p.add_argument("--bed", default=None, metavar="JSON",
                   help="the bed to lie on: a `pressurepose calibrate --out` file or a BedSpec.to_dict record "
                        "[the mat preset's default bed]")
    p.add_argument("--out", required=True, help="output .npz (docs/data.md): pressure, force, depth, contact, betas, "
                                                "pose, transl, joints, mass, height and wedge per body; gender, "
                                                "partition and the rejection counts")
    p.add_argument("--plot", default=None, help="PNG: each pressure image beside the body at rest, seen from the side")


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


def run_simulate(args) -> int:
    """Settle and press ``count`` bodies (attempt a of body i uses seed (seed, i, a)). Finished bodies
    go to OUT's ``.partial.npz`` as they come; rerunning the same command resumes from it."""
    import json

    from tqdm import tqdm

    from pressurepose.body import BodyModel, canonical_gender
    from pressurepose.errors import BadInput
    from pressurepose.files import (
        FIGURE_SUFFIXES,
        check_output_path,
        save_figure_atomic,
    )
    from pressurepose.pose.commands import body_settings
    from pressurepose.pose.config import SamplerConfig
    from pressurepose.pose.partitions import get_partition
    from pressurepose.sim.bed import bed_for
    from pressurepose.sim.settle import settle_preset
    from pressurepose.sim.simulate import simulate_one

    out = check_output_path(args.out, "--out", suffixes=(".npz",))
    if args.plot:
        check_output_path(args.plot, "--plot", suffixes=FIGURE_SUFFIXES)
    if not 1 <= args.count <= MAX_SIM_COUNT:
        raise BadInput(f"--count is {args.count}; expected 1 to {MAX_SIM_COUNT} bodies per file "
                       f"(use `generate` for datasets)")
    partition = get_partition(args.partition).name
    gender = canonical_gender(args.gender)[0]
    body, bed = BodyModel(gender), bed_for(args.mat, args.bed)
    sampler = SamplerConfig(height_reference=args.height_reference, **body_settings(args))
    settle_config = settle_preset(args.settle)
    # everything but the outputs and the count decides the bodies: a partial file of another command is refused
    run_key = json.dumps({**{k: v for k, v in vars(args).items() if not k.startswith("_")
                             and k not in ("out", "plot", "count", "mat", "bed")}, "partition": partition,
                          "gender": gender, "bed": bed.to_dict()}, sort_keys=True, default=str)
    partial = out.with_name(f"{out.stem}.partial.npz")
    done, rejected = _resume(partial, run_key, args.count)
    if done:
        print(f"resuming: {len(done)} bodies already finished in {partial}")
    for i in tqdm(range(len(done), args.count), desc="simulate", unit="body", initial=len(done), total=args.count):
        for attempt in range(100):
            sim = simulate_one(body, bed, partition, gender,
                               np.random.default_rng([args.seed, i, attempt]), args.limbs_on_bed, sampler,
                               settle_config=settle_config)
            if not isinstance(sim, str):
                done.append(_record(sim))
                break
            rejected[sim] += 1
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
    """One row per body: its pressure image on the mat (x across the bed, -y along it, metres, as in
    the ``demo`` picture; one colour scale for all rows, its mmHg bar on top) and the body at rest seen
    from the side."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    from pressurepose.sim.wedge import Wedge
    from pressurepose.viz.mesh import draw_mesh

    mat = bed.mat
    extent = [0, mat.cols * mat.pitch_col_m, -mat.rows * mat.pitch_row_m, 0]  # row 0 (head end) at -y = 0
    vmax = max(max(float(s["pressure"].max()) for s in done), 1e-6)
    n = len(done)
    fig, axes = plt.subplots(n, 2, figsize=(9, 3.4 * n), gridspec_kw={"width_ratios": [1, 2.6]}, squeeze=False,
                             layout="constrained")
    for (a_img, a_side), s in zip(axes, done):
        im = a_img.imshow(s["pressure"], extent=extent, cmap="viridis", vmin=0, vmax=vmax)
        a_img.set_title(f"{float(s['mass']):.0f} kg, peak {s['pressure'].max():.0f} mmHg", fontsize=9)
        a_img.set_xlabel("x across the bed (m)")
        a_img.set_ylabel("-y along the bed (m)")
        verts, _ = body.forward(s["betas"], s["pose"], s["transl"])
        draw_mesh(a_side, verts[0], body.faces, "bed_side")
        wedge = Wedge.from_array(s["wedge"])
        if wedge is not None:
            _draw_wedge_side(a_side, wedge)
        a_side.axhline(0.0, color="0.4", lw=1)
        a_side.set_title("at rest, seen from the side (bed top at z = 0)", fontsize=9)
        a_side.set_xlabel("y along the bed (m)")
    fig.colorbar(im, ax=axes[:, 0], location="top", aspect=15, label="pressure (mmHg)")
    return fig
