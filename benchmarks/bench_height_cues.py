"""Does a supine pressure image carry its person's height? Two image-only cues, real and simulated.

    .venv/bin/python -m benchmarks.bench_height_cues [--data ../shared/data/pmd-experiment-i]
        [--synthetic DATASET | --count 40 --seed 41] [--out runs/bench_height_cues] [--no-write]

The cues, measured on the image alone (the realism report's rule, ``pressurepose.eval.realism``):
the contact extent along the bed (crown to heel, m) and the crown-to-pelvis distance (the top of the
extent to the row of peak load in its middle 35-65 %, m). Real: PMD experiment I's supine images
(flat bed), per image and over each person's mean. Simulated: ``general_supine`` bodies
(``--synthetic``, or ``--count`` per gender made with ``pressurepose generate``) lying long (extent at
least 0.9 of the stature), so that bent legs do not stand in for height. Writes the
``bench:height-cues`` section of docs/RESULTS.md (``--no-write`` only prints).
"""

from __future__ import annotations

import argparse
import datetime
import os
import platform
from pathlib import Path

import numpy as np

from benchmarks.bench_realism import DEFAULT_DATA
from benchmarks.results import write_section
from pressurepose.cli import main as cli


def cues(pressure: np.ndarray, mat) -> tuple[np.ndarray, np.ndarray]:
    """(extent (N,) m, crown-to-pelvis (N,) m) of supine images (N, rows, cols); NaN without contact."""
    from pressurepose.eval import realism as R

    ext = R.body_extent(pressure, mat)
    rows = pressure.sum(2)
    pelvis = np.full(len(pressure), np.nan)
    for i, (a, b) in enumerate(ext):
        if np.isfinite(a) and b > a:
            lo, hi = int(a + 0.35 * (b - a)), int(a + 0.65 * (b - a)) + 1
            pelvis[i] = lo + int(np.argmax(rows[i, lo:hi]))
    return (ext[:, 1] - ext[:, 0]) * mat.pitch_row_m, (pelvis - ext[:, 0]) * mat.pitch_row_m


def corr(a, b) -> float:
    ok = np.isfinite(a) & np.isfinite(b)
    return float(np.corrcoef(np.asarray(a)[ok], np.asarray(b)[ok])[0, 1])


def main(argv=None) -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--data", type=Path, default=DEFAULT_DATA)
    ap.add_argument("--synthetic", type=Path, default=None)
    ap.add_argument("--count", type=int, default=40)
    ap.add_argument("--seed", type=int, default=41)
    ap.add_argument("--out", type=Path, default=Path("runs/bench_height_cues"))
    ap.add_argument("--no-write", action="store_true")
    args = ap.parse_args(argv)

    from pressurepose.eval.realism_report import load_real, load_synthetic
    from pressurepose.mat import get_mat

    mat = get_mat("boditrak_bt3510")
    synthetic = args.synthetic
    if synthetic is None:
        synthetic = args.out / "synthetic"
        for g in ("f", "m"):
            if cli(["generate", "--partition", "general_supine", "--gender", g, "--count", str(args.count), "--seed",
                    str(args.seed), "--out", str(synthetic / f"general_supine_{g}"), "--no-progress"]):
                raise SystemExit("generate failed")
    real = load_real(args.data, mat)
    sup = real.posture == "supine"
    r_len, r_trunk = cues(real.pressure[sup], mat)
    r_h, subj = real.height[sup], real.subject[sup]
    people = sorted(set(subj))
    mean = lambda v: np.array([np.nanmean(v[subj == s]) for s in people])  # noqa: E731
    sim = load_synthetic(synthetic)
    s = sim.posture == "supine"
    s_len, s_trunk = cues(sim.pressure[s], mat)
    s_h = sim.height[s]
    long = s_len / s_h >= 0.9
    rows = [("real PMD-I, per image", int(sup.sum()), float(np.std(r_h)), corr(r_h, r_len), corr(r_h, r_trunk)),
            ("real PMD-I, per person (mean of their images)", len(people), float(np.std(mean(r_h))),
             corr(mean(r_h), mean(r_len)), corr(mean(r_h), mean(r_trunk))),
            ("simulated general_supine lying long", int(long.sum()), float(np.std(s_h[long])),
             corr(s_h[long], s_len[long]), corr(s_h[long], s_trunk[long]))]
    lines = ["### Height cues in supine images (`benchmarks/bench_height_cues.py`)\n",
             "`python -m benchmarks.bench_height_cues" + (f" --synthetic {args.synthetic}" if args.synthetic else
                                                           f" --count {args.count} --seed {args.seed}")
             + f"`; {platform.processor() or platform.machine()}, {os.cpu_count()} CPUs, {datetime.date.today()}.\n",
             "Correlation with the measured (real) or model (simulated) stature of two image-only cues: the "
             "contact extent along the bed and the crown-to-pelvis distance (top of the extent to the row of peak "
             "load in its middle 35-65 %). Simulated bodies lying long: extent at least 0.9 of the stature.\n",
             "| images | n | stature sd (cm) | r(stature, extent) | r(stature, crown to pelvis) |",
             "|---|---|---|---|---|"]
    lines += [f"| {name} | {n} | {100 * sd:.1f} | {a:+.2f} | {b:+.2f} |" for name, n, sd, a, b in rows]
    body = "\n".join(lines) + "\n"
    print(body)
    if not args.no_write:
        write_section("height-cues", body)


if __name__ == "__main__":
    main()
