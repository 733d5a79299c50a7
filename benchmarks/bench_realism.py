"""The realism report on real PMD experiment I images against simulated ones, and (optionally) the
bed calibrated against those people.

    .venv/bin/python -m benchmarks.bench_realism [--data ../shared/data/pmd-experiment-i]
        [--bodies 25] [--general 40] [--seed 11] [--label "this checkout's physics"]
        [--synthetic "LABEL=DIR" ...] [--out runs/bench_realism]
        [--calibrate [--per-posture 4 --max-evals 200]] [--no-write]

1. unless ``--synthetic LABEL=DIR`` (repeatable) names datasets made already (by any checkout: the
   label says which physics), generates ``--bodies`` samples per gender of ``general_supine`` and
   ``--general`` per gender of ``general`` (which holds the bodies on their side) with this
   checkout's physics (``pressurepose generate``, seed ``--seed``) under OUT/synthetic, labelled
   ``--label``;
2. for each set runs ``pressurepose realism --real DATA --synthetic DIR --out OUT/report<k>``;
3. checks the image-only head-imprint rule against the simulated bodies' joints (a taxel over
   5 mmHg within 10 cm of the head joint, crown side of the neck: ``bench_supine_realism``);
4. with ``--calibrate``, runs ``pressurepose calibrate --targets real`` against the real statistics
   with ``--per-posture`` bodies of the last set, and lists its fit;

and replaces the ``bench:realism`` section of docs/RESULTS.md (``--no-write`` only prints). To
rerun after a physics change, run it on the new checkout with a new ``--label``. The real images
are never used to train anything.
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


def generate(out: Path, bodies: int, general: int, seed: int) -> None:
    for partition, count in (("general_supine", bodies), ("general", general)):
        for g in ("f", "m"):
            if count > 0:
                rc = cli(["generate", "--partition", partition, "--gender", g, "--count", str(count), "--seed",
                          str(seed), "--out", str(out / f"{partition}_{g}"), "--no-progress"])
                if rc:
                    raise SystemExit(f"generate {partition} {g} failed ({rc})")


def head_rule_agreement(synthetic: Path) -> dict:
    """{posture group: (n, joint-based rate, image-rule rate, agreement)} on the simulated set."""
    from benchmarks.bench_supine_realism import head_imprint as joint_head
    from pressurepose.data.dataset import DatasetReader
    from pressurepose.eval import realism as R
    from pressurepose.eval.posture import posture_of
    from pressurepose.sim import get_bed

    bed = get_bed()
    a = DatasetReader(synthetic).load_arrays(("pressure", "joints", "pose"), image_dtype=np.float32)
    p = a["pressure"].astype(np.float64)
    truth = np.array([joint_head(p[i], a["joints"][i].astype(np.float64), bed) for i in range(len(p))])
    rule = R.head_imprint(p, bed.mat)
    group = R.posture_group(posture_of(a["pose"].astype(np.float64)))
    return {g: {"n": int((group == g).sum()), "joints": float(truth[group == g].mean()),
                "rule": float(rule[group == g].mean()), "agree": float((truth == rule)[group == g].mean())}
            for g in ("supine", "lateral", "prone") if (group == g).any()}


def main(argv=None) -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--data", type=Path, default=DEFAULT_DATA)
    ap.add_argument("--bodies", type=int, default=25, help="general_supine samples per gender [25]")
    ap.add_argument("--general", type=int, default=40, help="general samples per gender [40]")
    ap.add_argument("--seed", type=int, default=11)
    ap.add_argument("--synthetic", action="append", help="LABEL=DIR: use these datasets instead of generating")
    ap.add_argument("--out", type=Path, default=Path("runs/bench_realism"))
    ap.add_argument("--label", default="this checkout's physics", help="what physics made the simulated images")
    ap.add_argument("--calibrate", action="store_true", help="also calibrate against the real statistics")
    ap.add_argument("--per-posture", type=int, default=4)
    ap.add_argument("--max-evals", type=int, default=200)
    ap.add_argument("--note", default="",
                    help="a sentence for the section's header (e.g. how --synthetic sets were made)")
    ap.add_argument("--no-write", action="store_true")
    args = ap.parse_args(argv)

    from pressurepose.cli.eval import format_realism

    if args.synthetic:
        sets = [(lab, Path(d)) for lab, _, d in (x.partition("=") for x in args.synthetic)]
    else:
        sets = [(args.label, args.out / "synthetic")]
        generate(sets[0][1], args.bodies, args.general, args.seed)
    text = ["### Realism: real PMD experiment I vs simulated\n",
            "`python -m benchmarks.bench_realism " + (" ".join(f'--synthetic "{lab}=..."' for lab, _ in sets)
                                                     if args.synthetic else f'--label "{args.label}"')
            + (f" --calibrate --per-posture {args.per_posture} --max-evals {args.max_evals}" if args.calibrate else "")
            + f"`; {platform.processor() or platform.machine()}, {os.cpu_count()} CPUs, {datetime.date.today()}."
            + (f" {args.note}" if args.note else "") + "\n",
            "Real: PMD-I flat-bed supine (postures 1, 8-12) and lateral (2, 3, 13, 14; the 30/60 deg wedge "
            "postures left out) images, one per recording (median of its frames), weight-normalised to mmHg and "
            "resampled onto the simulated BodiTrak mat, clipped at its 100 mmHg (the FSA mat is another mat on "
            "another mattress). Simulated: general_supine and general sets, posture from the body's roll. Areas "
            "are taxels > 5 mmHg; shares are mean shares of the image's load per region (fractions of the body's "
            "contact extent, `pressurepose.eval.realism`). Goals (issue 12): area within 20 % (ratio 0.8-1.2), "
            "head imprint >= 0.8, every region within 5 pp.\n"]
    for k, (label, synthetic) in enumerate(sets):
        report_dir = args.out / f"report{k}"
        if cli(["realism", "--real", str(args.data), "--synthetic", str(synthetic), "--out", str(report_dir)]):
            raise SystemExit("realism failed")
        report = json.loads((report_dir / "realism.json").read_text())
        agree = head_rule_agreement(synthetic)
        text += [f"**{label}**\n", format_realism(report["headline"]), "",
                 "Image-only head-imprint rule against the simulated bodies' joints (agreement; rates by joints / "
                 "by rule): " + ", ".join(f"{g} {d['agree']:.2f} ({d['joints']:.2f} / {d['rule']:.2f}, n = {d['n']})"
                                          for g, d in agree.items()) + ".\n"]
    if args.calibrate:
        out = args.out / "calibrated_bed.json"
        if cli(["calibrate", "--targets", "real", "--real", str(report_dir / "realism.json"), "--bodies",
                str(sets[-1][1]), "--per-posture", str(args.per_posture), "--max-evals", str(args.max_evals),
                "--out", str(out)]):
            raise SystemExit("calibrate failed")
        rec = json.loads(out.read_text())
        lines = [f"Calibrated against these statistics (`calibrate --targets real`, bodies of **{sets[-1][0]}**, "
                 f"{args.per_posture} per posture re-pressed, {rec['evaluations']} evaluations, "
                 f"{rec['seconds']:.0f} s): loss "
                 f"{rec['start_loss']:.3f} -> {rec['loss']:.3f} (1 = every term at its goal); fitted "
                 + ", ".join(f"{k} = {rec['fitted'][k]:.4g}" for k, v in rec["constants_from"].items()
                             if v.startswith("CMA-ES")) + ".\n",
                 "| posture | contact taxels real / calibrated | mean mmHg real / calibrated | peak mmHg real / "
                 "calibrated | worst share gap (pp) |", "|---|---|---|---|---|"]
        for g, t in rec["targets"].items():
            s = rec["simulated_after"].get(g)
            if s:
                gap = 100 * np.max(np.abs(np.subtract(s["shares"], t["shares"])))
                lines.append(f"| {g} | {t['contact_taxels']:.0f} / {s['contact_taxels']:.0f} | {t['mean_mmhg']:.1f} / "
                             f"{s['mean_mmhg']:.1f} | {t['peak_mmhg']:.1f} / {s['peak_mmhg']:.1f} | {gap:.1f} |")
        text += lines
    body = "\n".join(text) + "\n"
    print(body)
    if not args.no_write:
        write_section("realism", body)


if __name__ == "__main__":
    main()
