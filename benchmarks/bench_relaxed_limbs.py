"""Relaxed limbs against the paper's limb damping, judged on real people's images (issue 12).

    .venv/bin/python -m benchmarks.bench_relaxed_limbs [--data ../shared/data/pmd-experiment-i]
        [--count 40] [--seeds 31,21] [--damping paper,3] [--out runs/bench_relaxed_limbs] [--no-write]

1. For each limb damping (seconds x the joint stiffness of hips, knees, ankles, collars, shoulders,
   elbows and wrists; ``paper`` is the paper's 15) and seed, settles and presses ``general_supine``
   and ``general_lateral`` bodies, ``--count`` per gender, drawn as ``pressurepose generate --seed``
   draws them (the same attempt streams for every damping), into
   OUT/<damping>/s<seed>/<partition>_<g>.npz. Each file is kept, so a rerun resumes.
2. Compares each damping's images (all seeds together) with PMD experiment I's flat-bed images as
   ``pressurepose realism`` does, with and without ``--match-extent``; per region, the contact
   area and mean reading; where the resting hands and feet lie; and what the bodies cost to make.

Replaces the ``bench:relaxed-limbs`` section of docs/RESULTS.md (``--no-write`` only prints). Real
images only measure; nothing is trained on them.
"""

from __future__ import annotations

import argparse
import datetime
import platform
from pathlib import Path

import numpy as np

from benchmarks.bench_realism import DEFAULT_DATA
from benchmarks.bench_spine import (
    PAPER,
    PARTITIONS,
    paper_or_positive,
    row,
    seeds_and_count,
    simulate_set,
)
from benchmarks.results import write_section
from pressurepose.body.joints import JOINT_NAMES
from pressurepose.eval.realism import REGIONS, region_contact
from pressurepose.eval.realism_report import ImageSet, load_real, load_synthetic
from pressurepose.mat import get_mat
from pressurepose.sim.settle import SettleConfig

HANDS = tuple(JOINT_NAMES.index(n) for n in ("left_wrist", "right_wrist"))
FEET = tuple(JOINT_NAMES.index(n) for n in ("left_ankle", "right_ankle"))
IN_THE_AIR_M = 0.10  # a wrist or ankle joint this high above the unloaded mattress top is not on the bed


def damping_of(name: str) -> float | None:
    return None if name == PAPER else float(name)


def label(name: str) -> str:
    return "15 s (paper)" if name == PAPER else f"{float(name):g} s"


def sets_of(out: Path, name: str, seeds, count: int) -> list[Path]:
    """The damping's .npz files (made if missing): every partition, gender and seed."""
    paths = []
    for seed in seeds:
        folder = out / name / f"s{seed}"
        folder.mkdir(parents=True, exist_ok=True)
        for partition in PARTITIONS:
            for g in ("f", "m"):
                path = folder / f"{partition}_{g}.npz"
                if not path.is_file():
                    simulate_set(path, partition, g, count, seed, SettleConfig(limb_damping_s=damping_of(name)))
                paths.append(path)
    return paths


def image_set(paths, name: str) -> ImageSet:
    sets = [load_synthetic(p) for p in paths]
    cat = lambda k: np.concatenate([getattr(s, k) for s in sets])  # noqa: E731
    return ImageSet(name, cat("pressure"), cat("posture"), sets[0].mat, cat("force"), cat("mass"), cat("height"))


def air_and_cost(paths) -> dict:
    """Fractions of resting wrists and ankles more than :data:`IN_THE_AIR_M` above the mattress top
    (the joints' z in the bed frame), and attempts and CPU seconds per accepted body."""
    z, attempts, cpu = [], 0, 0.0
    for p in paths:
        with np.load(p, allow_pickle=False) as f:
            z.append(f["joints"][..., 2])
            attempts, cpu = attempts + int(f["attempts"]), cpu + float(f["cpu_s"])
    z = np.concatenate(z)
    return {"hands": float((z[:, HANDS] > IN_THE_AIR_M).mean()), "feet": float((z[:, FEET] > IN_THE_AIR_M).mean()),
            "hand_z": float(np.median(z[:, HANDS])), "attempts": attempts / len(z), "cpu": cpu / len(z)}


def contact_rows(real: ImageSet, sims: dict[str, ImageSet], mat) -> list[str]:
    rows = []
    for posture in ("supine", "lateral"):
        r = region_contact(real.pressure[real.posture == posture], mat)
        cells = {k: region_contact(s.pressure[s.posture == posture], mat) for k, s in sims.items()}
        for j, region in enumerate(REGIONS):
            out = [posture, region, f"{np.nanmedian(r[:, j, 0]):.0f}"]
            out += [f"{np.nanmedian(c[:, j, 0]):.0f}" for c in cells.values()]
            out += [f"{np.nanmedian(r[:, j, 1]):.1f}"] + [f"{np.nanmedian(c[:, j, 1]):.1f}" for c in cells.values()]
            rows.append("| " + " | ".join(out) + " |")
    return rows


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--data", type=Path, default=DEFAULT_DATA, help="PMD experiment I folder")
    ap.add_argument("--count", type=int, default=40, help="samples per partition, gender and seed [40]")
    ap.add_argument("--seeds", default="31,21", help="seeds of the draws [31,21]")
    ap.add_argument("--damping", default="paper,3",
                    help="limb dampings to compare, seconds x stiffness ('paper': 15) [paper,3]")
    ap.add_argument("--out", type=Path, default=Path("runs/bench_relaxed_limbs"))
    ap.add_argument("--no-write", action="store_true")
    args = ap.parse_args(argv)
    names = paper_or_positive(args.damping, "--damping", "seconds")
    seeds = seeds_and_count(args.seeds, args.count)
    mat = get_mat("boditrak_bt3510")
    real = load_real(args.data, mat)
    paths = {n: sets_of(args.out, n, seeds, args.count) for n in names}
    sims = {n: image_set(paths[n], f"simulated (limb damping {label(n)})") for n in names}
    head = ("| limb damping | real people | supine area ratio | supine head imprint | supine worst share gap, pp "
            "(90 % interval) | supine RMS gap, pp | lateral area ratio | lateral head imprint | lateral worst share "
            "gap, pp (90 % interval) | lateral RMS gap, pp |")
    matched, unmatched = [head, "|" + "---|" * 10], [head, "|" + "---|" * 10]
    for n in names:
        matched.append(row(label(n), "all", real, sims[n], match=True))
        unmatched.append(row(label(n), "all", real, sims[n], match=False))
    contact_head = ("| posture | region | taxels real | " + " | ".join(f"taxels {label(n)}" for n in names)
                    + " | mmHg real | " + " | ".join(f"mmHg {label(n)}" for n in names) + " |")
    cost = ["| limb damping | wrists > 0.1 m above the bed | ankles > 0.1 m | median wrist height, m | "
            "attempts per accepted body | CPU s per accepted body |", "|---|---|---|---|---|---|"]
    for n in names:
        a = air_and_cost(paths[n])
        cost.append(f"| {label(n)} | {a['hands']:.2f} | {a['feet']:.2f} | {a['hand_z']:.3f} | {a['attempts']:.2f} "
                    f"| {a['cpu']:.2f} |")
    count = {n: (int((s.posture == 'supine').sum()), int((s.posture == 'lateral').sum())) for n, s in sims.items()}
    text = "\n".join([
        "### Relaxed limbs against the paper's limb damping (issue 12; `benchmarks/bench_relaxed_limbs.py`)", "",
        f"`python -m benchmarks.bench_relaxed_limbs --count {args.count} --seeds {args.seeds} --damping "
        f"{args.damping}`; {platform.machine()}, {datetime.date.today()}.", "",
        f"Simulated: {', '.join(PARTITIONS)}, {args.count} per gender and seed, drawn as `generate` draws them (the "
        "same draws for every damping) and settled with the limb joints' damping at that many seconds x their "
        "stiffness; every other setting the default. Supine / side-lying images per damping: "
        + ", ".join(f"{label(n)} {a} / {b}" for n, (a, b) in count.items()) + ". Real: PMD-I's flat-bed supine "
        "and lateral images. Worst gap: the largest difference of a region's mean load share, simulated minus "
        "real, over the 7 regions (the interval resamples the real images by person); RMS: over the 7 regions. "
        "Issue 12's goals: area ratio 0.8-1.2, head imprint >= 0.8, every region within 5 pp.", "",
        "All simulated images as drawn (`realism`, no matching):", "", *unmatched, "",
        "Like postures compared (`realism --match-extent`):", "", *matched, "",
        "Per region, medians over images: contact taxels over 5 mmHg and the mean reading over them "
        "(`realism.region_contact`):", "", contact_head, "|" + "---|" * (3 + 2 * len(names)),
        *contact_rows(real, sims, mat), "",
        "Where the resting hands and feet lie (joints' height above the unloaded mattress top; every image) and what "
        "the bodies cost (CPU of this benchmark's process, rejected attempts included; not a throughput figure, "
        "see `bench:simulate`):", "", *cost, ""])
    print(text)
    if not args.no_write:
        write_section("relaxed-limbs", text)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
