"""CLI verb ``calibrate``: fit the bed's foundation and sensor constants with CMA-ES."""

from __future__ import annotations

import argparse
import time
from pathlib import Path

import numpy as np

from pressurepose.cli.args import bed_of, seed_arg
from pressurepose.errors import BadInput


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
                          "(real: with --real and --bodies; pressurepose.calibrate.people)")
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
                   help="mat for --targets: a preset (boditrak_bt3510, slp, tip, fsa_softflex_2048) or a mat.json "
                        "of any grid (docs/data.md) [boditrak_bt3510]; --data uses its own mat")
    p.add_argument("--body", default="f",
                   help="body for --targets: f, m, n (shipped models) or an SMPL-format file [f]")
    p.add_argument("--fit", default=None,
                   help="comma-separated constants to fit, from stiffness, spread, c0, c1, c2, tissue and "
                        "threshold [stiffness,spread,c0,c1,c2 for --data; stiffness,spread for --targets default; "
                        "stiffness,tissue,threshold for --targets real]")
    p.add_argument("--popsize", type=int, default=None, help="CMA-ES population size [50; 10 for --targets real]")
    p.add_argument("--seed", type=seed_arg, default=0, help="random seed of CMA-ES [0]")
    p.add_argument("--max-evals", type=int, default=None,
                   help="loss evaluations to stop at (CMA-ES stops at the end of the generation that reaches "
                        "it, so up to one population more) [5000; 400 for --targets real]")
    p.add_argument("--out", default="bed_params.json", help="output JSON [bed_params.json]")
    p.add_argument("--plot", default=None, help="also draw measured vs simulated images (PNG)")


def run_calibrate(args) -> int:
    from pressurepose.calibrate import objects as cal
    from pressurepose.calibrate.measurements import load_measurements
    from pressurepose.errors import BadInput
    from pressurepose.files import (
        FIGURE_SUFFIXES,
        check_output_path,
        save_figure_atomic,
        write_json_atomic,
    )
    from pressurepose.sim.bed import BedSpec

    check_output_path(args.out, "--out", suffixes=(".json",))
    if args.plot:
        check_output_path(args.plot, "--plot", suffixes=FIGURE_SUFFIXES)
    if args.max_evals is not None and args.max_evals < 1:
        raise BadInput(f"--max-evals is {args.max_evals}; expected at least 1 loss evaluation")
    if args.targets == "real":
        return _run_people_calibration(args)
    args.popsize = 50 if args.popsize is None else args.popsize
    args.max_evals = 5000 if args.max_evals is None else args.max_evals
    fit = tuple(s.strip() for s in args.fit.split(",")) if args.fit else None
    if args.bed or args.match_extent:
        raise BadInput("--bed and --match-extent are options of --targets real")
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

        bed = bed_of(args.mat, None)
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

    from pressurepose.calibrate import objects as cal
    from pressurepose.sim.stiffness import press_objects

    fields = cal.measurement_heightfields(data, res.bed)
    force, sink = press_objects(res.bed, fields, data.mass_kg)
    sim = cal.readings(force, res.bed)
    n = min(len(data), 6)
    fig, axes = plt.subplots(2, n + 1, figsize=(2.2 * (n + 1) + 0.8, 7), squeeze=False, layout="constrained")
    vmax = max(float(data.pressure_mmhg[:n].max()), float(sim[:n].max()), 1e-9)
    for j in range(n):
        for row, (img, q, label) in enumerate(((data.pressure_mmhg[j], data.sink_m[j], "measured"),
                                               (sim[j], sink[j], "simulated"))):
            ax = axes[row, j]
            im = ax.imshow(img, vmin=0, vmax=vmax, cmap="viridis")
            ax.set_title(f"{label} #{j}\n{data.mass_kg[j]:.1f} kg, sink {100 * q:.1f} cm", fontsize=8)
            ax.axis("off")
    fig.colorbar(im, ax=axes[:, :n], shrink=0.6, label="mmHg (one scale for all)")
    _plot_history(axes[0, n], res)
    axes[1, n].axis("off")
    return fig


def _plot_body(verts, faces, res, targets):
    import matplotlib.pyplot as plt

    from pressurepose.sim.press import press

    out = press(verts, faces, targets.mass_kg, res.bed)
    fig, axes = plt.subplots(1, 2, figsize=(8, 6))
    im = axes[0].imshow(out.pressure, cmap="viridis", vmin=0)
    fig.colorbar(im, ax=axes[0], label="mmHg")
    axes[0].set_xlabel("column")
    axes[0].set_ylabel("row (head end at 0)")
    axes[0].set_title(f"peak {out.pressure.max():.1f} mmHg (target {targets.peak_mmhg:g})\n"
                      f"sink {100 * out.sink_m:.1f} cm (target {100 * targets.max_sink_m:g})", fontsize=9)
    _plot_history(axes[1], res)
    fig.tight_layout()
    return fig


def _plot_history(ax, res, title: str = "CMA-ES"):
    """The loss by generation: the best found so far, and each generation's best (faint)."""
    from matplotlib.ticker import MaxNLocator

    gen = np.arange(1, len(res.history) + 1)
    ax.semilogy(gen, np.maximum(res.history, 1e-12), color="tab:blue", alpha=0.35, lw=1,
                label="best of the generation")
    ax.semilogy(gen, np.maximum(np.minimum.accumulate(res.history), 1e-12), color="tab:blue",
                label="best so far")
    ax.xaxis.set_major_locator(MaxNLocator(integer=True))
    ax.set_xlabel("generation")
    ax.set_ylabel("loss")
    ax.legend(fontsize=7)
    ax.set_title(title, fontsize=9)




def _run_people_calibration(args) -> int:
    """``pressurepose calibrate --targets real --real DIR|realism.json --bodies DATASET``."""
    from pressurepose.calibrate.objects import with_params
    from pressurepose.calibrate.people import (
        DEFAULT_FIT,
        calibrate_people,
        people_loss,
        press_forces,
        pressable,
        resting_bodies,
        simulated_stats,
        targets_from_images,
        targets_from_report,
        tipping,
    )
    from pressurepose.eval import realism as R
    from pressurepose.eval.realism_report import load_real
    from pressurepose.files import (
        check_output_path,
        save_figure_atomic,
        write_json_atomic,
    )

    if not args.real or not args.bodies:
        raise BadInput("--targets real needs --real (a real-data folder or a realism.json) and --bodies "
                       "(a generated dataset or simulate .npz of settled bodies)")
    out = check_output_path(args.out, "--out", suffixes=(".json",))
    if args.plot:
        check_output_path(args.plot, "--plot", suffixes=(".png",))
    t0 = time.perf_counter()
    bed = bed_of(args.mat, args.bed)
    match = None
    if Path(args.real).is_file():
        if args.match_extent:
            raise BadInput("--match-extent needs the real images' statures: give --real a real-data folder, "
                           "not a realism.json")
        targets = targets_from_report(args.real)
    else:
        real = load_real(args.real, bed.mat)
        targets = targets_from_images(real.pressure, real.posture, bed.mat, f"{args.real} ({real.name})")
        if args.match_extent:
            ratio = R.extent_ratio(real.pressure, bed.mat, real.height)
            match = {g: ratio[real.posture == g] for g in targets.groups}
    bodies = resting_bodies(args.bodies, bed, args.per_posture, tuple(g for g in targets.groups), match=match,
                            seed=args.seed)
    bodies, dropped = pressable(bodies, bed)
    if dropped:
        print(f"note: left out {dropped} bod{'y' if dropped == 1 else 'ies'} the re-press finds no equilibrium "
              f"for on the starting bed (a tilted body's first-order press tips over)")
    if not bodies:
        raise BadInput(f"no body of {args.bodies} can be re-pressed on the starting bed")
    fit = tuple(s.strip() for s in args.fit.split(",")) if args.fit else DEFAULT_FIT
    if "threshold" in fit and bed.sensor_threshold_mmhg < R.DEFAULT_RULE.contact_mmhg:
        # below the contact level a threshold changes nothing measured: start where it starts to matter
        bed = with_params(bed, {"threshold": R.DEFAULT_RULE.contact_mmhg})
    start_loss = people_loss(simulated_stats(press_forces(bodies, bed), bodies, bed), targets)

    def progress(gen, evals, best):
        if gen % 5 == 0:
            print(f"generation {gen}: {evals} evaluations, best loss {best:.4f}", flush=True)

    res = calibrate_people(bodies, targets, bed, fit=fit, popsize=args.popsize or 10, seed=args.seed,
                           max_evals=args.max_evals or 400, progress=progress)
    final = simulated_stats(press_forces(bodies, res.bed), bodies, res.bed)
    tipped = tipping(bodies, res.bed)
    where = {"fitted": f"CMA-ES on statistics of real images: {targets.source}",
             "start": f"the shipped bed for the {bed.mat.name} mat (docs/calibration.md: k_A and spread from "
                      f"documented physical targets, ideal sensor, tissue modulus from docs/physics.md)"}
    record = {
        "bed": res.bed.to_dict(), "loss": res.loss, "start_loss": start_loss, "fitted": res.fitted,
        "constants_from": {k: where["fitted"] if k in fit else where["start"] for k in res.fitted},
        "evaluations": res.evaluations, "generations": res.generations,
        "stop": {k: str(v) for k, v in res.stop.items()}, "popsize": args.popsize or 10, "seed": args.seed,
        "source": {"targets": targets.source, "bodies": str(Path(args.bodies).resolve()),
                   "bodies_matched_by_extent": bool(match),
                   "bodies_per_posture": {g: sum(b.posture == g for b in bodies) for g in targets.groups}},
        "targets": {g: t.__dict__ for g, t in targets.groups.items()},
        "simulated_after": {g: t.__dict__ for g, t in final.items()},
        "tipped_after": {g: {"tipped": t, "bodies": n} for g, (t, n) in tipped.items()},
        "seconds": round(time.perf_counter() - t0, 1)}
    write_json_atomic(out, record)
    print(f"loss {start_loss:.4f} -> {res.loss:.4f} after {res.evaluations} evaluations; fitted " +
          ", ".join(f"{k}={res.fitted[k]:.6g}" for k in fit))
    for g, t in targets.groups.items():
        s = final.get(g)
        if s is not None:
            print(f"{g}: contact taxels {s.contact_taxels:.0f} (real {t.contact_taxels:.0f}), mean "
                  f"{s.mean_mmhg:.1f} mmHg ({t.mean_mmhg:.1f}), peak {s.peak_mmhg:.1f} ({t.peak_mmhg:.1f}), worst "
                  f"region share gap {100 * np.max(np.abs(np.subtract(s.shares, t.shares))):.1f} pp")
    for g, (t, n) in tipped.items():
        if t:
            print(f"warning: {t} of {n} {g} bodies tip over on the fitted bed when pressed in full (the fit's "
                  f"first-order re-press does not see it); data made on it loses them (press_failed)")
    print(f"wrote {out}")
    if args.plot:
        import matplotlib

        matplotlib.use("Agg")
        import matplotlib.pyplot as plt

        fig, ax = plt.subplots(figsize=(5, 3.5))
        _plot_history(ax, res, "CMA-ES against real images' statistics")
        fig.tight_layout()
        save_figure_atomic(fig, args.plot, dpi=100)
        plt.close(fig)
        print(f"wrote {args.plot}")
    return 0
