"""Both physics simulations end to end: accepted samples per CPU-second per core, rejection causes.

    .venv/bin/python -m benchmarks.bench_simulate [--count 30] [--seed 5] [--no-write]

Draws ``--count`` attempts per partition and gender (sample a pose, settle the ragdoll, press the mesh,
read the mat: :func:`pressurepose.sim.simulate.simulate_one`, the work one dataset sample costs) on
the default bed, one thread, and counts every attempt's outcome. Throughput is accepted samples per
CPU-second of this process over all attempts (rejected attempts cost their CPU too), i.e. per core;
the machine is shared, so wall time would measure the neighbours. Goal (issue 4): at least 2 per
second per core. Prints the figures and replaces the ``bench:simulate`` section of docs/RESULTS.md.
"""

from __future__ import annotations

import argparse
import collections
import datetime
import os
import platform
import time

import mujoco
import numpy as np

from benchmarks.results import write_section
from pressurepose.body import BodyModel
from pressurepose.pose.config import SamplerConfig
from pressurepose.sim.bed import get_bed
from pressurepose.sim.settle import STATUSES
from pressurepose.sim.simulate import simulate_one

PARTITIONS = ("general", "general_supine", "prone_hands_up")
# (row label, partition, sampler's height reference); "bed" is the sampler's opt-in rule that keeps a
# body's upper limbs near the bed (fewer lateral bodies roll over)
RUNS = (("general", "general", "proximal"), ("general, --height-reference bed", "general", "bed"),
        ("general_supine", "general_supine", "proximal"), ("prone_hands_up", "prone_hands_up", "proximal"))
GENDERS = ("female", "male")
CAUSES = tuple(s for s in STATUSES if s != "settled") + ("press_failed", "limb_off_bed")
GOAL = 2.0


def run_partition(bodies: dict, bed, partition: str, count: int, seed: int, height_reference: str) -> dict:
    """``count`` attempts per gender; returns counts per outcome, CPU seconds and settle steps."""
    sampler = SamplerConfig(height_reference=height_reference)
    outcomes: collections.Counter = collections.Counter()
    steps, cpu = [], 0.0
    for g, gender in enumerate(GENDERS):
        rng = np.random.default_rng([seed, PARTITIONS.index(partition), g])
        for _ in range(count):
            t0 = time.process_time()
            out = simulate_one(bodies[gender], bed, partition, gender, rng, sampler=sampler)
            cpu += time.process_time() - t0
            if isinstance(out, str):
                outcomes[out] += 1
            else:
                outcomes["accepted"] += 1
                steps.append(out.settle_steps)
    return dict(outcomes=outcomes, cpu=cpu, steps=np.array(steps), attempts=len(GENDERS) * count)


def table(results: dict) -> list[str]:
    head = "| run | attempts | accepted | accepted per CPU s | CPU s per accepted | " + \
        " | ".join(CAUSES) + " | settle steps median (90th pct) |"
    lines = [head, "|" + "---|" * (head.count("|") - 1)]
    for part, r in results.items():
        acc, st = r["outcomes"]["accepted"], r["steps"]
        rate = acc / r["cpu"] if r["cpu"] > 0 else float("nan")
        steps = f"{np.median(st):.0f} ({np.percentile(st, 90):.0f})" if len(st) else "-"
        lines.append(f"| {part} | {r['attempts']} | {acc} ({100 * acc / r['attempts']:.0f} %) | {rate:.2f} | "
                     f"{r['cpu'] / max(acc, 1):.3f} | " + " | ".join(str(r["outcomes"].get(c, 0)) for c in CAUSES)
                     + f" | {steps} |")
    return lines


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--count", type=int, default=30, help="attempts per partition and gender [30]")
    ap.add_argument("--seed", type=int, default=5, help="seed [5]")
    ap.add_argument("--no-write", action="store_true", help="print only; leave docs/RESULTS.md alone")
    args = ap.parse_args(argv)
    bodies = {g: BodyModel(g) for g in GENDERS}
    bed = get_bed()
    results = {}
    for label, part, ref in RUNS:
        results[label] = run_partition(bodies, bed, part, args.count, args.seed, ref)
        r = results[label]
        print(label, dict(r["outcomes"]), "CPU %.1f s, %.2f accepted per CPU s"
              % (r["cpu"], r["outcomes"]["accepted"] / r["cpu"]), flush=True)
    lines = table(results)
    print("\n".join(lines))
    total_acc = sum(r["outcomes"]["accepted"] for r in results.values())
    total_cpu = sum(r["cpu"] for r in results.values())
    text = "\n".join([
        "## Settle and press end to end (`benchmarks/bench_simulate.py`)", "",
        f"{datetime.date.today()}, {platform.platform()}, {os.cpu_count()} CPUs (shared with other jobs: CPU "
        f"seconds of this process), MuJoCo {mujoco.__version__}, one thread. Shipped female and male models, "
        f"{args.count} attempts per partition and gender (seed {args.seed}), default bed ({bed.mat.name}); "
        "each attempt samples a pose, settles the ragdoll, presses the mesh and reads the mat, as one dataset "
        "sample costs. Rejected attempts' CPU counts against the accepted ones.", "",
        *lines, "",
        f"All runs together: **{total_acc / total_cpu:.2f} accepted samples per CPU-second** "
        f"(goal: at least {GOAL:g} per second per core). The data engine's scaling over cores is in "
        "`bench:data`.",
    ])
    if not args.no_write:
        write_section("simulate", text)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
