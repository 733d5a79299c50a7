"""CLI verb ``calibrate``: fit the bed's foundation and sensor constants with CMA-ES."""

from __future__ import annotations

import argparse
import json
import time
from pathlib import Path

import numpy as np


def add_calibrate_arguments(p: argparse.ArgumentParser) -> None:
    p.description = (
        "Fit the mattress (Winkler stiffness k_A, Pasternak spread sqrt(G/k_A)) and sensor constants "
        "(c0, c1, c2) with CMA-ES. With --data, to measured capsule objects (pressure images and sink depths, "
        "format in docs/calibration.md) by the paper's loss L_F + L_C + L_Q; with --targets default, to the "
        "documented sink depth and peak pressure of an average body (needs a body model). Writes the fitted "
        "bed as JSON (load it with pressurepose.sim.calibrate.load_fitted_bed).")
    src = p.add_mutually_exclusive_group(required=True)
    src.add_argument("--data", help="calibration measurements (.npz, see docs/calibration.md)")
    src.add_argument("--targets", choices=["default"], help="fit to the documented physical targets instead")
    p.add_argument("--mat", default="boditrak_bt3510",
                   help="mat preset for --targets (boditrak_bt3510, slp, tip) [boditrak_bt3510]; --data uses its own mat")
    p.add_argument("--body", default="f",
                   help="body for --targets: f, m, n (shipped models) or an SMPL-format file [f]")
    p.add_argument("--fit", default=None,
                   help="comma-separated constants to fit, from stiffness, spread, c0, c1, c2 "
                        "[all five for --data; stiffness,spread for --targets]")
    p.add_argument("--popsize", type=int, default=50, help="CMA-ES population size [50]")
    p.add_argument("--seed", type=int, default=0, help="random seed of CMA-ES [0]")
    p.add_argument("--max-evals", type=int, default=5000, help="most loss evaluations [5000]")
    p.add_argument("--out", default="bed_params.json", help="output JSON [bed_params.json]")
    p.add_argument("--plot", default=None, help="also draw measured vs simulated images (PNG)")


def run_calibrate(args) -> int:
    from pressurepose.sim import calibrate as cal
    from pressurepose.sim.bed import BedSpec, get_bed
    from pressurepose.sim.calibration_data import load_measurements

    fit = tuple(s.strip() for s in args.fit.split(",")) if args.fit else None
    t0 = time.perf_counter()

    def progress(gen, evals, best):
        if gen % 10 == 0:
            print(f"generation {gen}: {evals} evaluations, best loss {best:.5f}", flush=True)

    common = dict(popsize=args.popsize, seed=args.seed, max_evals=args.max_evals, progress=progress)
    if args.data:
        data = load_measurements(args.data)
        bed = BedSpec(mat=data.mat)
        res = cal.calibrate(data, bed, fit=fit or ("stiffness", "spread", "c0", "c1", "c2"), **common)
        source = {"data": str(Path(args.data).resolve()), "objects": len(data)}
    else:
        from pressurepose.body import BodyModel

        bed = get_bed(args.mat)
        body = BodyModel(args.body)
        verts, faces, _ = cal.supine_body_mesh(body, bed)
        res = cal.calibrate_targets(verts, faces, cal.DEFAULT_TARGETS, bed, fit=fit or ("stiffness", "spread"),
                                    **common)
        t = cal.DEFAULT_TARGETS
        source = {"targets": {"max_sink_m": t.max_sink_m, "peak_mmhg": t.peak_mmhg, "mass_kg": t.mass_kg,
                              "sources": list(t.sources)}, "body": repr(body)}
    record = {"bed": res.bed.to_dict(), "loss": res.loss, "fitted": res.fitted, "evaluations": res.evaluations,
              "generations": res.generations, "stop": {k: str(v) for k, v in res.stop.items()},
              "popsize": args.popsize, "seed": args.seed, "source": source,
              "seconds": round(time.perf_counter() - t0, 1)}
    Path(args.out).write_text(json.dumps(record, indent=2))
    print(f"loss {res.loss:.5f} after {res.evaluations} evaluations; fitted " +
          ", ".join(f"{k}={v:.6g}" for k, v in res.fitted.items()))
    print(f"wrote {args.out}")
    if args.plot:
        if args.data:
            fig = _plot_measurements(data, res)
        else:
            fig = _plot_body(verts, faces, res, cal.DEFAULT_TARGETS)
        fig.savefig(args.plot, dpi=110)
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

