"""The shipped PressureNet on real pressure images (PhysioNet PMD experiment I), beside the same
numbers on simulated images.

    .venv/bin/python -m benchmarks.bench_real [--data ../shared/data/pmd-experiment-i] [--synthetic 20]
                                              [--out runs/bench_real] [--no-write]

1. refits the FSA mat's pitch from the subjects' heights (:func:`pressurepose.data.realprep.fit_pitch`,
   supine postures 1, 8, 9) and prints it beside the preset's value;
2. runs ``pressurepose evaluate-real DATA --out OUT/real`` (shipped model, default options);
3. with ``--synthetic N`` (default 20; 0 skips), generates N samples per gender of the
   ``general_supine`` and ``general`` partitions (seeds 902-905) and runs ``pressurepose evaluate``
   on them, for the posture accuracy and stature error of simulated images;

and replaces the ``bench:real`` section of docs/RESULTS.md. Nothing is tuned on the real data.
"""

from __future__ import annotations

import argparse
import datetime
import json
import os
import platform
from pathlib import Path

import numpy as np

from benchmarks.results import write_section
from pressurepose.cli import main as cli

DEFAULT_DATA = Path(__file__).resolve().parents[1].parent / "shared" / "data" / "pmd-experiment-i"


def pitch_fit(data: Path) -> dict:
    from pressurepose.data.readers.real import read_real
    from pressurepose.data.realprep import (
        HEAD_HEEL_OFFSET_M,
        contact_extent_rows,
        fit_pitch,
        remove_baseline,
        repair_taxels,
    )

    real = read_real(data)
    sel = np.isin(real.detail, ("supine", "supine star", "supine hands crossed"))
    ext, heights, cut = [], [], 0
    for img, h in zip(real.images[sel], real.height_m[sel]):
        first, last = contact_extent_rows(repair_taxels(remove_baseline(img)))
        if last >= real.mat.rows - 1 or first < 0:
            cut += 1
            continue
        ext.append(last - first + 1)
        heights.append(h)
    pitch, rms = fit_pitch(ext, heights, HEAD_HEEL_OFFSET_M)
    r = float(np.corrcoef(ext, heights)[0, 1])
    return {"pitch_m": pitch, "rms_m": rms, "used": len(ext), "cut": cut, "r": r, "offset_m": HEAD_HEEL_OFFSET_M,
            "preset_m": real.mat.pitch_row_m}


def side_check(data: Path) -> dict:
    """Which way the knees point in PMD's lateral images: per posture, how many images have the
    column centroid of rows 36-49 (knees, shins) at higher columns than that of rows 20-31 (hips).
    A body lying on its right side faces +x (higher columns) in the project's bed frame."""
    from pressurepose.data.readers.real import read_real

    real = read_real(data)
    cols = np.arange(real.mat.cols)
    centroid = lambda a: (a.sum(0) * cols).sum() / a.sum()  # noqa: E731
    out = {}
    for name in ("right side", "right fetal", "left side", "left fetal"):
        imgs = real.images[real.detail == name]
        out[name] = (int(sum(centroid(i[36:50]) > centroid(i[20:32]) for i in imgs)), len(imgs))
    return out


def synthetic(out: Path, count: int) -> dict:
    summaries = {}
    for part, seeds in (("general_supine", (902, 903)), ("general", (904, 905))):
        for gender, seed in zip("fm", seeds):
            where = out / "synthetic" / part / gender
            if not (where / "manifest.json").is_file():
                assert cli(["generate", "--partition", part, "--gender", gender, "--count", str(count), "--seed",
                            str(seed), "--shard-size", str(count), "--workers", "1", "--out", str(where)]) == 0
        rep = out / "synthetic_eval" / part
        assert cli(["evaluate", "--model", "pressurepose/net/assets/pressurenet.json", "--data",
                    str(out / "synthetic" / part), "--out", str(rep)]) == 0
        summaries[part] = json.loads((rep / "report.json").read_text())["summary"]
    return summaries


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--data", default=str(DEFAULT_DATA))
    ap.add_argument("--out", default="runs/bench_real")
    ap.add_argument("--synthetic", type=int, default=20, help="samples per gender and partition (0: skip)")
    ap.add_argument("--no-write", action="store_true")
    args = ap.parse_args()
    out = Path(args.out)
    fit = pitch_fit(Path(args.data))
    sides = side_check(Path(args.data))
    print(f"pitch fit: {fit}\nknees toward higher columns: {sides}")
    assert cli(["evaluate-real", args.data, "--out", str(out / "real")]) == 0
    m = json.loads((out / "real" / "metrics.json").read_text())
    report = (out / "real" / "report.md").read_text()
    syn = synthetic(out, args.synthetic) if args.synthetic > 0 else {}

    def section(title):
        body = report.split(f"## {title}\n\n", 1)[1]
        return body.split("\n## ", 1)[0].strip()

    lines = [
        "## PressureNet on real images: PhysioNet PMD experiment I (`benchmarks/bench_real.py`)",
        "",
        f"{datetime.date.today().isoformat()}, {platform.platform()}, {os.cpu_count()} CPUs; the shipped model "
        f"(how it was made: section turn-loss, the shipped model since session 17: `turnB`). Reproduce: "
        f"`python -m benchmarks.bench_real` or "
        f"`pressurepose evaluate-real ../shared/data/pmd-experiment-i --out X` (default options: one image per "
        f"recording, the median of its non-blank frames; raw readings weight-normalised to mmHg; resampled from the "
        f"FSA 64 x 32 mat, pitch {fit['preset_m']:.4f} m, onto the BodiTrak 64 x 27; no sex is recorded, so every "
        f"image is estimated with both body models and each estimate counts; contact = input above "
        f"{m['contact_mmhg']:g} mmHg).",
        "",
        f"{m['n_images']} images of {len(m['per_subject'])} adults ({m['n_estimates']} estimates); skipped "
        f"{m['skipped']['inclined_bed']} inclined-bed recordings (postures 15-17) and "
        f"{m['skipped']['weak_recording']} recording(s) whose load is under 10 % of their subject's median (a mat "
        f"that barely recorded).",
        "",
        section("By posture"),
        "",
        "Posture confusion (rows: label; columns: the estimate's class):",
        "",
        section("Posture confusion"),
        "",
        "By body model:",
        "",
        section("By body model"),
        "",
        "By subject (each subject's images with both body models):",
        "",
        section("By subject"),
        "",
    ]
    if syn:
        lines += ["The same numbers on simulated images (`pressurepose evaluate`, freshly generated, "
                  f"{args.synthetic} per gender and partition, seeds 902-905, which the shipped model's data "
                  "(seeds 1410-1414) does not use; `general` includes bodies on their side and front):", "",
                  "| data | n | posture acc. | stature MAE (cm) | stature bias (cm) | MPJPE (cm) |",
                  "|---|---|---|---|---|---|"]
        for part, s in syn.items():
            a = s["all"]
            lines.append(f"| simulated `{part}` | {a['count']} | {a['posture_accuracy']:.2f} | "
                         f"{a['stature_mae_cm']:.1f} | {a['stature_bias_cm']:+.1f} | {a['mod2']['mpjpe_cm']:.2f} |")
        lines.append(f"| real PMD-I (all flat postures) | {m['n_estimates']} | {m['posture_accuracy']:.2f} | "
                     f"{100 * m['stature_mae_m']:.1f} | {100 * m['stature_bias_m']:+.1f} | - |")
        lines.append("")
    rows = json.loads((out / "real" / "estimates.json").read_text())["rows"]
    b0 = np.array([r["betas"][0] for r in rows])
    conf = m.get("confusion", {})
    lateral_n = sum(sum(conf.get(k, {}).values()) for k in ("left", "right"))
    lateral_ok = sum(conf.get(k, {}).get(k, 0) for k in ("left", "right"))
    lateral_as_supine = sum(conf.get(k, {}).get("supine", 0) for k in ("left", "right"))
    supine_n, supine_ok = sum(conf.get("supine", {}).values()), conf.get("supine", {}).get("supine", 0)
    stat = {g: np.array([r["stature_m"] for r in rows if r["body_model"] == g]) for g in ("f", "m")}
    lines += [
        f"What it shows: lateral postures read as lateral {lateral_ok}/{lateral_n} ({lateral_as_supine} called "
        f"supine), supine ones as supine {supine_ok}/{supine_n}; the estimated stature is off by "
        f"{100 * m['stature_bias_m']:+.1f} cm on average and does not follow the real heights (correlation "
        f"{m['stature_r']:.2f}): the first shape coefficient sits at {b0.mean():+.2f} on average (its limit is +-3) "
        f"and the estimated stature ranges over female body {stat['f'].min():.2f}-{stat['f'].max():.2f} m, male "
        f"{stat['m'].min():.2f}-{stat['m'].max():.2f} m against 1.69-1.86 m measured. The input's total force is "
        f"the body's weight (weight normalisation), so the size comes from how the real pressure is spread, not "
        f"from its total (docs/sim_to_real.md compares real and simulated images).",
        "",
        "Left and right: the knees (rows 36-49) lie toward higher columns than the hips (rows 20-31) in "
        + ", ".join(f"{k}/{n} '{name}'" for name, (k, n) in sides.items())
        + " images. A body on its right side faces +x (higher columns) in the project's bed frame, so reading "
        "PMD's 'right' as the side the person lies on (the clinical 'right lateral'), its columns need no flip "
        "(images alone cannot tell a mirrored mat from swapped labels).",
        "",
        f"FSA pitch refit (supine postures 1, 8, 9 whose contact ends before the last row: {fit['used']} images, "
        f"{fit['cut']} left out; offset {fit['offset_m']:.2f} m): {fit['pitch_m']:.5f} m, RMS residual "
        f"{100 * fit['rms_m']:.1f} cm, extent-height correlation r = {fit['r']:.2f} (weak: see docs/data.md).",
    ]
    text = "\n".join(lines)
    print(text)
    if not args.no_write:
        write_section("real", text)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
