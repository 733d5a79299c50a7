"""PressureNet's accuracy on real pressure images (PhysioNet PMD experiment I), beside the same
figures on freshly simulated images.

    python -m benchmarks.bench_real --real PATH [--model MODEL] [--synthetic 20]
                                    [--out runs/bench_real] [--no-write]

1. runs ``pressurepose evaluate-real PATH --out OUT/real`` (the shipped model unless ``--model``,
   default options): posture accuracy, stature and mass error, contact IoU, by posture, body model
   and subject;
2. with ``--synthetic N`` (default 20; 0 skips), generates N samples per gender of the
   ``general_supine`` and ``general`` partitions (seeds 902-905, which the shipped model's data does
   not use) and runs ``pressurepose evaluate`` on them, for the same figures on simulated images;

and replaces the ``bench:real`` section of docs/RESULTS.md. ``--real`` defaults to
``$PRESSUREPOSE_PMD``; without real data the benchmark says so and measures nothing. Nothing is
tuned on the real images.
"""

from __future__ import annotations

import argparse
import json
from pathlib import Path

import numpy as np

from benchmarks.common import add_real_argument, real_folder, stamp
from benchmarks.results import write_section
from pressurepose.cli import main as cli

SHIPPED = "pressurepose/net/assets/pressurenet.json"
SYNTHETIC = (("general_supine", (902, 903)), ("general", (904, 905)))  # partition, (female seed, male seed)


def _cli(*args: str) -> None:
    if cli(list(args)) != 0:
        raise SystemExit(f"pressurepose {' '.join(args)} failed")


def synthetic(out: Path, count: int, model: str) -> dict:
    """``pressurepose evaluate``'s summary of ``model`` per partition of :data:`SYNTHETIC` (generated
    into OUT/synthetic if missing)."""
    summaries = {}
    for part, seeds in SYNTHETIC:
        for gender, seed in zip("fm", seeds):
            where = out / "synthetic" / part / gender
            if not (where / "manifest.json").is_file():
                _cli("generate", "--partition", part, "--gender", gender, "--count", str(count), "--seed", str(seed),
                     "--shard-size", str(count), "--workers", "1", "--no-progress", "--out", str(where))
        rep = out / "synthetic_eval" / part
        _cli("evaluate", "--model", model, "--data", str(out / "synthetic" / part), "--out", str(rep))
        summaries[part] = json.loads((rep / "report.json").read_text())["summary"]
    return summaries


def report_section(report: str, title: str) -> str:
    """The body of ``## title`` in evaluate-real's report.md."""
    body = report.split(f"## {title}\n\n", 1)[1]
    return body.split("\n## ", 1)[0].strip()


def as_labelled(m: dict) -> str:
    """The scores as PMD-I labels its postures: flat-bed postures by class, wedge postures by the
    direction of the turn, and how much of the people the mat can show."""
    parts = []
    if m.get("without_wedge"):
        by = ", ".join(f"{g} {a:.2f}" for g, a in m["flat_bed_by_posture"].items())
        parts.append(f"flat bed: posture accuracy **{m['without_wedge']['posture_accuracy']:.2f}** ({by})")
    if m.get("wedge"):
        w = m["wedge"]
        turns = ", ".join(f"{a} deg {t:+.0f}" for a, t in w["median_turn_deg"].items())
        parts.append(f"propped on a wedge: **{w['turned_right_way']:.2f}** of {w['n']} estimates turn at least 15 "
                     f"degrees toward the labelled side (median turn toward it: {turns})")
    if m.get("taller_than_mat") is not None:
        parts.append(f"{m['taller_than_mat']:.0%} of the people are taller than the mat is long "
                     f"({m['mat_length_m']:.2f} m), so stature is no goal on this mat")
    if m.get("load_kg_mean") is not None:
        parts.append(f"the images carry {m['load_kg_mean']:.1f} kg on average against a measured "
                     f"{m['weight_kg_mean']:.1f} kg")
    return "As labelled: " + "; ".join(parts) + "." if parts else ""


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    add_real_argument(ap)
    ap.add_argument("--model", default=None, help="model to read the images with [the shipped one]")
    ap.add_argument("--out", type=Path, default=Path("runs/bench_real"))
    ap.add_argument("--synthetic", type=int, default=20, help="simulated samples per gender and partition (0: skip)")
    ap.add_argument("--no-write", action="store_true", help="print only; leave docs/RESULTS.md alone")
    args = ap.parse_args(argv)
    real = real_folder(args.real, "bench_real")
    if real is None:
        return 0
    out, model = args.out, args.model or SHIPPED
    _cli("evaluate-real", str(real), "--model", model, "--out", str(out / "real"))
    m = json.loads((out / "real" / "metrics.json").read_text())
    report = (out / "real" / "report.md").read_text()
    syn = synthetic(out, args.synthetic, model) if args.synthetic > 0 else {}

    command = "python -m benchmarks.bench_real --real PATH" + (f" --model {args.model}" if args.model else "") \
        + (f" --synthetic {args.synthetic}" if args.synthetic != 20 else "")
    lines = [
        "## PressureNet on real images (`benchmarks/bench_real.py`)", "",
        f"`{command}` (PATH: PhysioNet PMD experiment I); {stamp()}; "
        + ("the shipped model" if args.model is None else f"model `{args.model}`")
        + ". The same as `pressurepose evaluate-real PATH` with its default options: one image per recording, "
        "the median of its non-blank frames; raw readings weight-normalised to mmHg; resampled onto the BodiTrak "
        "64 x 27 mat; no sex is recorded, so every image is estimated with both body models and each estimate "
        f"counts; contact = input above {m['contact_mmhg']:g} mmHg.", "",
        f"{m['n_images']} images of {len(m['per_subject'])} adults ({m['n_estimates']} estimates); skipped "
        f"{m['skipped']['inclined_bed']} inclined-bed recordings and {m['skipped']['weak_recording']} recording(s) "
        "whose load is under 10 % of their subject's median (a mat that barely recorded).", "",
        as_labelled(m), "",
        report_section(report, "By posture"), "",
        "Posture confusion (rows: label; columns: the estimate's class):", "",
        report_section(report, "Posture confusion"), "",
        "By body model:", "",
        report_section(report, "By body model"), "",
        "By subject (each subject's images with both body models):", "",
        report_section(report, "By subject"), "",
    ]
    if syn:
        lines += [f"The same figures on simulated images (`pressurepose evaluate`, freshly generated, {args.synthetic} "
                  "per gender and partition, seeds 902-905; `general` includes bodies on their side and front):", "",
                  "| data | n | posture acc. | stature MAE (cm) | stature bias (cm) | MPJPE (cm) |",
                  "|---|---|---|---|---|---|"]
        for part, s in syn.items():
            a = s["all"]
            lines.append(f"| simulated `{part}` | {a['count']} | {a['posture_accuracy']:.2f} | "
                         f"{a['stature_mae_cm']:.1f} | {a['stature_bias_cm']:+.1f} | {a['mod2']['mpjpe_cm']:.2f} |")
        lines += [f"| real (every posture) | {m['n_estimates']} | {m['posture_accuracy']:.2f} | "
                  f"{100 * m['stature_mae_m']:.1f} | {100 * m['stature_bias_m']:+.1f} | - |", ""]
    rows = json.loads((out / "real" / "estimates.json").read_text())["rows"]
    stat = {g: np.array([r["stature_m"] for r in rows if r["body_model"] == g]) for g in ("f", "m")}
    conf = m.get("confusion", {})
    lateral_n = sum(sum(conf.get(k, {}).values()) for k in ("left", "right"))
    lateral_ok = sum(conf.get(k, {}).get(k, 0) for k in ("left", "right"))
    supine_n, supine_ok = sum(conf.get("supine", {}).values()), conf.get("supine", {}).get("supine", 0)
    lines.append(
        f"Side-lying images read as side lying {lateral_ok}/{lateral_n}, supine ones as supine "
        f"{supine_ok}/{supine_n}. Estimated statures range over "
        + ", ".join(f"{'female' if g == 'f' else 'male'} body {s.min():.2f}-{s.max():.2f} m"
                    for g, s in stat.items() if len(s))
        + f"; the stature bias is {100 * m['stature_bias_m']:+.1f} cm.")
    text = "\n".join(lines)
    print(text)
    if not args.no_write:
        write_section("real", text)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
