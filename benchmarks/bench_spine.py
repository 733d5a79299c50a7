"""The settle's spine stiffness judged on real people's region shares (issue 12).

    .venv/bin/python -m benchmarks.bench_spine [--data ../shared/data/pmd-experiment-i] [--count 50]
        [--seed 21] [--stiffness paper,40,20,10,4] [--fit-subjects 1-7] [--coarse-factor 2]
        [--out runs/bench_spine] [--no-write]

1. For each spine stiffness (N m/rad of the spine1-3 joints for the average body; ``paper`` is the
   paper's 200), settles and presses ``general_supine`` and ``general_lateral`` bodies, ``--count``
   per gender, drawn as ``pressurepose generate --seed`` draws them (the same attempt streams, so
   the default stiffness gives ``generate``'s samples), into OUT/<stiffness>/<partition>_<g>.npz.
   Each file is kept, so a rerun resumes.
2. Compares each set with PMD experiment I's flat-bed images as ``pressurepose realism
   --match-extent`` does: all subjects, then the ``--fit-subjects`` and the others apart (a
   stiffness chosen on some people should also suit the others); and all subjects unmatched.

Replaces the ``bench:relaxed-spine`` section of docs/RESULTS.md (``--no-write`` only prints). Real
images only measure; nothing is trained on them.
"""

from __future__ import annotations

import argparse
import dataclasses
import datetime
import platform
from pathlib import Path

import numpy as np
from tqdm import tqdm

from benchmarks.bench_people_fit import subject_range
from benchmarks.bench_realism import DEFAULT_DATA
from benchmarks.results import write_section
from pressurepose.data.producers import attempt_rng
from pressurepose.data.schema import GenerationConfig
from pressurepose.eval.realism_report import (
    ImageSet,
    headline,
    load_real,
    load_synthetic,
    realism_report,
)
from pressurepose.files import atomic_write
from pressurepose.mat import get_mat
from pressurepose.sim.settle import SettleConfig

PARTITIONS = ("general_supine", "general_lateral")
PAPER = "paper"


def seeds_and_count(seeds: str, count: int) -> list[int]:
    """The whole numbers of a ``--seeds`` text (comma-separated); SystemExit naming it, or an empty
    list or a ``--count`` below 1."""
    try:
        out = [int(s) for s in seeds.split(",") if s.strip()]
    except ValueError:
        raise SystemExit(f"--seeds {seeds!r}: expected whole numbers separated by commas") from None
    if not out or count < 1:
        raise SystemExit("--seeds needs at least one seed and --count a positive number")
    return out


def paper_or_positive(text: str, option: str, unit: str) -> list[str]:
    """The comma-separated names of ``option``: 'paper' or positive numbers (of ``unit``); SystemExit
    naming the first that is neither."""
    names = [s.strip() for s in text.split(",") if s.strip()]
    for n in names:
        try:
            ok = n == PAPER or 0 < float(n) < float("inf")
        except ValueError:
            ok = False
        if not ok:
            raise SystemExit(f"{option} {n!r}: expected positive numbers of {unit} or '{PAPER}'")
    return names


def stiffness_of(name: str) -> float | None:
    return None if name == PAPER else float(name)


def simulate_set(path: Path, partition: str, gender: str, count: int, seed: int,
                 settle_config: SettleConfig) -> None:
    """``count`` accepted bodies of (partition, gender), drawn as ``generate --seed`` draws them,
    settled with ``settle_config``; written as a ``simulate``-style .npz (with the settled joints,
    the ``attempts`` made and their ``cpu_s``)."""
    import time

    from pressurepose.data.physics import sampler_config, setup
    from pressurepose.sim.simulate import simulate_one

    config = GenerationConfig(partition=partition, gender=gender, count=count, seed=seed)
    body, bed = setup(config)
    keep = {k: [] for k in ("pressure", "force", "pose", "mass", "height", "joints")}
    attempts, start = 0, time.process_time()
    for i in tqdm(range(count), desc=f"{path.parent.name}: {path.stem}"):
        for attempt in range(config.max_attempts):
            attempts += 1
            sim = simulate_one(body, bed, partition, gender, attempt_rng(config, i, attempt), config.limbs_on_bed,
                               sampler_config(config), settle_config=settle_config)
            if not isinstance(sim, str):
                break
        else:
            raise SystemExit(f"{path}: sample {i} was rejected {config.max_attempts} times")
        for k, v in (("pressure", sim.image.pressure), ("force", sim.image.force), ("pose", sim.pose),
                     ("mass", sim.mass), ("height", sim.height), ("joints", sim.joints)):
            keep[k].append(v)
    cpu = time.process_time() - start

    def write(tmp):
        with open(tmp, "wb") as f:  # a file object: np.savez would add ".npz" to the temporary name
            np.savez(f, attempts=attempts, cpu_s=cpu, **{k: np.asarray(v) for k, v in keep.items()})

    atomic_write(path, write)


def simulated(out: Path, name: str, count: int, seed: int,
              coarse_factor: float = SettleConfig.coarse_factor) -> ImageSet:
    """The candidate's images (made if missing), every partition and gender in one set."""
    folder = out / (name if coarse_factor == SettleConfig.coarse_factor else f"{name}_step{coarse_factor:g}x")
    folder.mkdir(parents=True, exist_ok=True)
    sets = []
    for partition in PARTITIONS:
        for g in ("f", "m"):
            path = folder / f"{partition}_{g}.npz"
            if not path.is_file():
                simulate_set(path, partition, g, count, seed,
                             SettleConfig(spine_stiffness=stiffness_of(name), coarse_factor=coarse_factor))
            sets.append(load_synthetic(path))
    cat = lambda k: np.concatenate([getattr(s, k) for s in sets])  # noqa: E731
    return ImageSet(f"simulated (spine {name})", cat("pressure"), cat("posture"), sets[0].mat, cat("force"),
                    cat("mass"), cat("height"))


def subset(real: ImageSet, keep: np.ndarray) -> ImageSet:
    return dataclasses.replace(real, pressure=real.pressure[keep], posture=real.posture[keep],
                               height=real.height[keep], subject=real.subject[keep])


def row(name: str, people: str, real: ImageSet, sim: ImageSet, match: bool) -> str:
    cells = [name, people]
    for h in headline(realism_report(real, sim, match=match)):
        if h["posture"] not in ("supine", "lateral"):
            continue
        gaps = 100 * np.array([h["share_sim"][k] - h["share_real"][k] for k in h["share_real"]])
        lo, hi = h["share_worst_pp_interval"]
        cells += [f"{h['area_ratio']:.2f}", f"{h['head_sim']:.2f}",
                  f"{h['share_worst_pp']:.1f} ({lo:.1f}-{hi:.1f})", f"{np.sqrt(np.mean(gaps ** 2)):.2f}"]
    return "| " + " | ".join(cells) + " |"


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--data", type=Path, default=DEFAULT_DATA, help="PMD experiment I folder")
    ap.add_argument("--count", type=int, default=50, help="samples per partition and gender [50]")
    ap.add_argument("--seed", type=int, default=21)
    ap.add_argument("--stiffness", default="paper,40,20,10,4",
                    help="spine stiffnesses to compare, N m/rad for the average body ('paper': 200)")
    ap.add_argument("--fit-subjects", default="1-7", help="one group of subjects; the others form the second")
    ap.add_argument("--coarse-factor", type=float, default=SettleConfig.coarse_factor,
                    help="the settle's step after touching down, x 0.01 s (1: the fine step throughout, as "
                         f"before session 12) [{SettleConfig.coarse_factor:g}]")
    ap.add_argument("--out", type=Path, default=Path("runs/bench_spine"))
    ap.add_argument("--no-write", action="store_true")
    args = ap.parse_args(argv)
    names = paper_or_positive(args.stiffness, "--stiffness", "N m/rad")
    mat = get_mat("boditrak_bt3510")
    real = load_real(args.data, mat)
    group = subject_range(args.fit_subjects)
    first = np.array([int(s) in group for s in real.subject])
    people = (("all", real), (f"subjects {args.fit_subjects}", subset(real, first)),
              ("the others", subset(real, ~first)))
    head = ("| spine (N m/rad) | real people | supine area ratio | supine head imprint | supine worst share gap, pp "
            "(90 % interval) | supine RMS gap, pp | lateral area ratio | lateral head imprint | lateral worst share "
            "gap, pp (90 % interval) | lateral RMS gap, pp |")
    matched, unmatched = [head, "|" + "---|" * 10], [head, "|" + "---|" * 10]
    for n in names:
        sim = simulated(args.out, n, args.count, args.seed, args.coarse_factor)
        label = "200 (paper)" if n == PAPER else n
        for who, r in people:
            matched.append(row(label, who, r, sim, match=True))
        unmatched.append(row(label, "all", real, sim, match=False))
    text = "\n".join([
        "### The settle's spine stiffness against real region shares (issue 12; `benchmarks/bench_spine.py`)", "",
        f"`python -m benchmarks.bench_spine --count {args.count} --seed {args.seed} --stiffness {args.stiffness} "
        f"--fit-subjects {args.fit_subjects} --coarse-factor {args.coarse_factor:g}`; {platform.machine()}, "
        f"{datetime.date.today()}.", "",
        f"Simulated: {', '.join(PARTITIONS)}, {args.count} per gender, seed {args.seed}, drawn as `generate` draws "
        "them and settled with each spine stiffness (spine1-3 joints, N m/rad for the average body, scaled by mass; "
        "damping 15 x stiffness); every other setting the default. Real: PMD-I's flat-bed supine and lateral images. "
        "Worst gap: the largest difference of a region's mean load share, simulated minus real, over the 7 regions "
        "(the interval resamples the real images by person); RMS: over the 7 regions. Issue 12's goals: area "
        "ratio 0.8-1.2, head imprint >= 0.8, every region within 5 pp.", "",
        "Like postures compared (`realism --match-extent`):", "", *matched, "",
        "All simulated images as drawn (`realism`, no matching), all subjects:", "", *unmatched, ""])
    print(text)
    if not args.no_write:
        write_section("relaxed-spine", text)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
