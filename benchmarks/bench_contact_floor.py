"""The input's contact floor, A/B: the same simulated training set and training run with
``train --contact-floor 0`` (the paper's contact channel, C_I = p > 0) and with the default 5 mmHg,
each scored on real images (PhysioNet PMD experiment I) by ``pressurepose evaluate-real``.

    .venv/bin/python -m benchmarks.bench_contact_floor --data DATASET [--real ../shared/data/pmd-experiment-i]
                                                       [--work runs/bench_contact_floor] [--floors 0 5]
                                                       [--epochs-mod1 30 --epochs-mod2 15] [--no-write]

DATASET is any simulated training set (``generate`` output, one dataset or a recipe's train folder).
Both runs use the quarter-width CNN with bf16 autocast, batch 32, cosine rates 5e-4 / 1e-4 and seed
0, so the floor is the only difference. Training resumes (rerun the same command), so an interrupted
benchmark loses nothing. Replaces the ``bench:contact-floor`` section of docs/RESULTS.md. Nothing is
trained or tuned on the real images: the floor's value comes from the real mat's readings away from
the body (docs/sim_to_real.md), not from these scores.
"""

from __future__ import annotations

import argparse
import datetime
import json
import platform
import subprocess
import sys
from pathlib import Path

from benchmarks.results import write_section

REPO = Path(__file__).resolve().parents[1]
DEFAULT_REAL = REPO.parent / "shared" / "data" / "pmd-experiment-i"
LABELS = ("supine", "left", "right")


def cli(*args: str) -> None:
    cmd = [sys.executable, "-m", "pressurepose.cli", *map(str, args)]
    print("+", " ".join(cmd), flush=True)
    subprocess.run(cmd, check=True, cwd=REPO)


def row(floor: float, metrics: dict) -> str:
    conf = metrics.get("confusion", {})
    per = {k: conf.get(k, {}) for k in LABELS}
    right = [per[k].get(k, 0) for k in LABELS]
    total = [sum(per[k].values()) for k in LABELS]
    acc = " | ".join(f"{r}/{t}" for r, t in zip(right, total))
    r = metrics.get("stature_r")
    return (f"| {floor:g} | {metrics['posture_accuracy']:.2f} | {acc} | {100 * metrics['stature_mae_m']:.1f} "
            f"({100 * metrics['stature_bias_m']:+.1f}) | {'-' if r is None else f'{r:+.2f}'} | "
            f"{metrics['mass_mae_kg']:.1f} | {metrics['contact_iou']:.2f} |")


def main() -> int:
    p = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument("--data", required=True, help="simulated training set")
    p.add_argument("--real", default=str(DEFAULT_REAL), help="real images [../shared/data/pmd-experiment-i]")
    p.add_argument("--work", default="runs/bench_contact_floor", help="run folders [runs/bench_contact_floor]")
    p.add_argument("--floors", type=float, nargs="+", default=[0.0, 5.0], help="floors to compare, mmHg [0 5]")
    p.add_argument("--epochs-mod1", type=int, default=30)
    p.add_argument("--epochs-mod2", type=int, default=15)
    p.add_argument("--note", default="", help="what the training set is, written into the section")
    p.add_argument("--no-write", action="store_true", help="print only; leave docs/RESULTS.md alone")
    args = p.parse_args()
    work = Path(args.work).resolve()
    rows, n = [], None
    for floor in args.floors:
        run, real = work / f"floor{floor:g}", work / f"real{floor:g}"
        cli("train", "--data", args.data, "--out", run, "--epochs-mod1", args.epochs_mod1, "--epochs-mod2",
            args.epochs_mod2, "--lr", 5e-4, "--lr-mod2", 1e-4, "--lr-schedule", "cosine", "--batch-size", 32,
            "--cnn", "quarter", "--cpu-amp", "--seed", 0, "--contact-floor", floor)
        cli("evaluate-real", args.real, "--model", run, "--out", real)
        metrics = json.loads((real / "metrics.json").read_text())
        n = metrics["n_estimates"]
        rows.append(row(floor, metrics))
    text = "\n".join([
        "## The input's contact floor on real images (`benchmarks/bench_contact_floor.py`)",
        "",
        f"{datetime.date.today().isoformat()}, {platform.platform()}. The same simulated training set "
        f"(`{Path(args.data).name}`{': ' + args.note if args.note else ''}) and run (quarter CNN, bf16, "
        f"{args.epochs_mod1} + {args.epochs_mod2} epochs, seed 0) "
        "with each contact floor; `pressurepose evaluate-real` on PMD experiment I "
        f"({n} estimates: each image with both body models). Posture columns: correct / images of that "
        "label (supine, on the left side, on the right side).",
        "",
        "| floor (mmHg) | posture acc. | supine | left | right | stature MAE (bias), cm | stature r | "
        "mass MAE, kg | contact IoU |",
        "|---|---|---|---|---|---|---|---|---|",
        *rows,
    ])
    print(text)
    if not args.no_write:
        write_section("contact-floor", text)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
