"""The press's tissue fitted to some real people, checked on others (issue 12's region shares).

    .venv/bin/python -m benchmarks.bench_people_fit [--data ../shared/data/pmd-experiment-i]
        [--count 50] [--seed 21] [--per-posture 60] [--max-evals 300] [--fit tissue,bone_pelvis,...]
        [--fit-subjects 1-7] [--out runs/bench_people_fit] [--no-write]

1. splits PMD experiment I by subject: the fit uses ``--fit-subjects``' images, the check the others'
   (folders of links under OUT);
2. generates ``general_supine`` and ``general_lateral``, ``--count`` per gender, seed ``--seed``, on
   the default bed (``pressurepose generate``) under OUT/default;
3. fits ``--fit`` (the tissue's modulus and bone fractions: constants of the press, so the settled
   bodies stay valid) with ``pressurepose calibrate --targets real --match-extent`` against the fit
   subjects, ``--per-posture`` bodies of OUT/default per posture, into OUT/bed_people.json;
4. generates the same bodies on that bed (``generate --bed``) under OUT/people;
5. runs ``pressurepose realism --match-extent`` of both sets against the fit and the check subjects;

and replaces the ``bench:people-fit`` section of docs/RESULTS.md (``--no-write`` only prints). Every
step keeps what it made, so a rerun resumes. Real images only calibrate and measure; nothing is
trained on them.
"""

from __future__ import annotations

import argparse
import datetime
import json
import os
import platform
from pathlib import Path

from benchmarks.bench_realism import DEFAULT_DATA
from benchmarks.results import write_section
from pressurepose.cli import main as cli

PARTITIONS = ("general_supine", "general_lateral")
DEFAULT_FIT = "tissue,bone_pelvis,bone_spine,bone_shoulder,bone_head,bone_thigh,bone_calf,bone_foot,bone_upper_arm"


def subject_range(text: str) -> set[int]:
    lo, _, hi = text.partition("-")
    return set(range(int(lo), int(hi or lo) + 1))


def split_subjects(data: Path, fit: set[int], out: Path) -> tuple[Path, Path]:
    """Two real-data folders of links to ``data``'s subject folders: the ``fit`` subjects and the rest."""
    folders = {int(p.name[1:]): p for p in data.iterdir() if p.is_dir() and p.name[:1] == "S" and p.name[1:].isdigit()}
    if not fit or not fit < set(folders):
        raise SystemExit(f"--fit-subjects must be some but not all of {sorted(folders)}")
    made = []
    for name, keep in (("real_fit", fit), ("real_check", set(folders) - fit)):
        d = out / name
        d.mkdir(parents=True, exist_ok=True)
        for f in data.iterdir():
            if f.is_file() and not (d / f.name).exists():
                (d / f.name).symlink_to(f.resolve())
        for k in keep:
            if not (d / folders[k].name).exists():
                (d / folders[k].name).symlink_to(folders[k].resolve())
        made.append(d)
    return made[0], made[1]


def generate(out: Path, count: int, seed: int, bed: Path | None = None) -> None:
    for partition in PARTITIONS:
        for g in ("f", "m"):
            rc = cli(["generate", "--partition", partition, "--gender", g, "--count", str(count), "--seed", str(seed),
                      "--out", str(out / f"{partition}_{g}"), "--no-progress", "--workers", "2"]
                     + (["--bed", str(bed)] if bed else []))
            if rc:
                raise SystemExit(f"generate {partition} {g} failed ({rc})")


def realism(real: Path, synthetic: Path, out: Path) -> dict:
    if not (out / "realism.json").is_file():
        if cli(["realism", "--real", str(real), "--synthetic", str(synthetic), "--out", str(out), "--match-extent"]):
            raise SystemExit("realism failed")
    return json.loads((out / "realism.json").read_text())


def main(argv=None) -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--data", type=Path, default=DEFAULT_DATA)
    ap.add_argument("--count", type=int, default=50, help="samples per partition and gender [50]")
    ap.add_argument("--seed", type=int, default=21)
    ap.add_argument("--per-posture", type=int, default=60)
    ap.add_argument("--max-evals", type=int, default=300)
    ap.add_argument("--fit", default=DEFAULT_FIT)
    ap.add_argument("--fit-subjects", default="1-7")
    ap.add_argument("--out", type=Path, default=Path("runs/bench_people_fit"))
    ap.add_argument("--no-write", action="store_true")
    args = ap.parse_args(argv)

    from pressurepose.cli.eval import format_worst_gap
    from pressurepose.eval.realism import REGIONS

    args.out.mkdir(parents=True, exist_ok=True)
    real_fit, real_check = split_subjects(args.data, subject_range(args.fit_subjects), args.out)
    generate(args.out / "default", args.count, args.seed)
    bed = args.out / "bed_people.json"
    if not bed.is_file():
        if cli(["calibrate", "--targets", "real", "--real", str(real_fit), "--bodies", str(args.out / "default"),
                "--match-extent", "--per-posture", str(args.per_posture), "--fit", args.fit, "--max-evals",
                str(args.max_evals), "--out", str(bed)]):
            raise SystemExit("calibrate failed")
    rec = json.loads(bed.read_text())
    generate(args.out / "people", args.count, args.seed, bed)

    rows = []
    for who, real in (("fit subjects", real_fit), ("held-out subjects", real_check)):
        for label in ("default", "people"):
            rep = realism(real, args.out / label, args.out / f"realism_{label}_{real.name}")
            for r in rep["headline"]:
                rows.append((who, label, r))
    bed_name = {"default": "default bed", "people": "tissue fitted to the fit subjects"}
    lines = ["### Tissue fitted to people, checked on other people (issue 12; `benchmarks/bench_people_fit.py`)\n",
             f"`python -m benchmarks.bench_people_fit --count {args.count} --seed {args.seed} --per-posture "
             f"{args.per_posture} --max-evals {args.max_evals} --fit-subjects {args.fit_subjects}`; "
             f"{platform.processor() or platform.machine()}, {os.cpu_count()} CPUs, {datetime.date.today()}.\n",
             f"PMD experiment I split by subject: subjects {args.fit_subjects} calibrate, the others only measure. "
             f"Simulated: {', '.join(PARTITIONS)}, {args.count} per gender, seed {args.seed}, made on the default "
             f"bed and again (the same bodies) on the fitted bed. `calibrate --targets real --match-extent` "
             f"fitted {', '.join(f'`{k}`' for k in rec['fitted'] if rec['constants_from'][k].startswith('CMA-ES'))} "
             f"({rec['evaluations']} evaluations, {rec['seconds']:.0f} s; loss {rec['start_loss']:.3f} -> "
             f"{rec['loss']:.3f}, 1 = every term at its goal on average). Region shares compare like postures "
             "(`realism --match-extent`); goals: area ratio 0.8-1.2, head imprint >= 0.8, every region within "
             "5 pp. The interval resamples the real images by person and the simulated ones by image "
             "(`realism.share_gap_interval`).\n",
             "| real images | bed | posture | images real / sim | contact taxels real / sim (ratio) | head imprint "
             "real / sim | " + " | ".join(f"{k} %" for k in REGIONS) + " | worst share gap (pp; 90 % interval) |",
             "|---" * (7 + len(REGIONS)) + "|"]
    for who, label, r in rows:
        shares = " | ".join(f"{100 * r['share_real'][k]:.1f} / {100 * r['share_sim'][k]:.1f}" for k in REGIONS)
        lines.append(f"| {who} | {bed_name[label]} | {r['posture']} | {r['n_real']} / {r['n_sim']} | "
                     f"{r['area_real']:.0f} / {r['area_sim']:.0f} ({r['area_ratio']:.2f}) | {r['head_real']:.2f} / "
                     f"{r['head_sim']:.2f} | {shares} | {format_worst_gap(r)} |")
    fitted = {k: v for k, v in rec["fitted"].items() if rec["constants_from"][k].startswith("CMA-ES")}
    lines += ["", "Fitted constants (start: the default bed): " + ", ".join(
        f"{k} {v:.3g}" for k, v in fitted.items()) + ". The fitted bed: `OUT/bed_people.json` (`generate --bed`).\n"]
    body = "\n".join(lines) + "\n"
    print(body)
    if not args.no_write:
        write_section("people-fit", body)


if __name__ == "__main__":
    main()
