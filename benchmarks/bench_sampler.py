"""Pose sampler speed and rejection rates per partition (one core, the shipped female body).

    OMP_NUM_THREADS=1 python -m benchmarks.bench_sampler [--scale 1.0] [--no-write]

Accepted bodies per second of CPU time (the process's own, so other work on a shared machine
counts less) and per second of wall time, the rejection rate of each cause (limb causes per limb
candidate judged, whole-pose causes per whole pose checked), and the bins and bodies redrawn.
Prints the table and replaces the ``bench:sampler`` section of docs/RESULTS.md.
"""

from __future__ import annotations

import argparse
import datetime
import os
import platform
import time

from benchmarks.common import machine
from benchmarks.results import write_section
from pressurepose.body import BodyModel
from pressurepose.body.model import asset_path
from pressurepose.body.toy import toy_body_arrays
from pressurepose.pose import sample_bodies
from pressurepose.pose.samples import LIMB_CAUSES

# (partition, limbs_on_bed, bodies at scale 1): the partitions of the paper's table (appendix A.7)
RUNS = [
    ("general", False, 400), ("general", True, 200),
    ("general_supine", False, 300), ("general_supine", True, 200),
    ("hands_behind_head", True, 60), ("prone_hands_up", True, 60),
    ("supine_crossed_legs", False, 30), ("supine_crossed_legs", True, 30),
    ("supine_straight_limbs", False, 200), ("supine_straight_limbs", True, 100),
]
SHORT = {"height": "height", "bin": "bin", "off_mattress": "off mattress",
         "not_behind_head": "not behind head", "limb_collision": "limb collision"}


def measure(partition: str, on_bed: bool, count: int, body) -> dict:
    sample_bodies(partition, "f", 2, seed=999, limbs_on_bed=on_bed, body=body)  # warm caches
    c0, t0 = time.process_time(), time.perf_counter()
    batch = sample_bodies(partition, "f", count, seed=1, limbs_on_bed=on_bed, body=body)
    cpu, wall = time.process_time() - c0, time.perf_counter() - t0
    rej, att = batch.rejections, batch.attempts
    limb_rates = {c: rej[c] / att["limb_candidates"] for c in LIMB_CAUSES}
    cross_tries = rej["legs_not_crossed"] + att["full_poses"]  # leg pairs judged for crossing
    return {"count": count, "cpu": cpu, "wall": wall, "limb_rates": limb_rates,
            "candidates": att["limb_candidates"] / count,
            "crossing": rej["legs_not_crossed"] / cross_tries if partition == "supine_crossed_legs" else None,
            "collision": rej["self_collision"] / att["full_poses"],
            "bins_redrawn": att["bins_redrawn"] / count, "bodies_redrawn": att["bodies_redrawn"] / count}




def main(argv=None) -> int:
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    p.add_argument("--scale", type=float, default=1.0, help="multiply the number of bodies per run (default 1)")
    p.add_argument("--no-write", action="store_true", help="print only; leave docs/RESULTS.md alone")
    args = p.parse_args(argv)
    if asset_path("female.npz").is_file():
        body, label = BodyModel("female"), "shipped female model"
    else:
        body, label = BodyModel(toy_body_arrays()), "toy body (shipped models not baked yet)"
    load0 = os.getloadavg()[0]
    rows = []
    for partition, on_bed, count in RUNS:
        n = max(2, round(count * args.scale))
        r = measure(partition, on_bed, n, body)
        rows.append((partition, on_bed, r))
        print(f"{partition}{' +on bed' if on_bed else ''}: {n / r['cpu']:.0f}/s CPU, {n / r['wall']:.0f}/s wall",
              flush=True)
    load1 = os.getloadavg()[0]
    head = ("| partition | on bed | bodies | per CPU s | per wall s | candidates per body | "
            + " | ".join(SHORT[c] for c in LIMB_CAUSES) + " | legs not crossed | self-collision | "
            "bins redrawn per body | bodies redrawn per body |")
    lines = [
        "## Pose sampler (`benchmarks/bench_sampler.py`)",
        "",
        f"`python -m benchmarks.bench_sampler`; {datetime.date.today().isoformat()}, {machine()}, "
        f"{platform.processor() or platform.machine()}, {os.cpu_count()} CPUs (load average {load0:.1f} at the start, {load1:.1f} at the end: a shared "
        f"machine, so CPU-time rates are the fairer per-core figure), one thread; {label}, seed 1.",
        "",
        "Accepted bodies per second; rejection rates in % of the limb candidates judged (limb causes) or of "
        "the whole poses checked (self-collision) or leg pairs drawn (legs not crossed). Goal: at least 200 "
        "accepted bodies per second per core for `general`.",
        "",
        head,
        "|" + "---|" * (head.count("|") - 1),
    ]
    for partition, on_bed, r in rows:
        cells = [partition, "yes" if on_bed else "no", str(r["count"]), f"{r['count'] / r['cpu']:.0f}",
                 f"{r['count'] / r['wall']:.0f}", f"{r['candidates']:.0f}",
                 *[f"{100 * r['limb_rates'][c]:.1f}" for c in LIMB_CAUSES],
                 "-" if r["crossing"] is None else f"{100 * r['crossing']:.1f}", f"{100 * r['collision']:.1f}",
                 f"{r['bins_redrawn']:.2f}", f"{r['bodies_redrawn']:.3f}"]
        lines.append("| " + " | ".join(cells) + " |")
    lines += ["", "Self-collision here is the whole-pose rate after each limb was already tested against the "
              "trunk, head and itself (limb collision), so it counts collisions between limbs only. Bins "
              "are redrawn when a limb cannot reach its bin from the body's root and shape (prone leg bins "
              "near the hips), after 20 candidates in the bin fell off the mattress (limbs on bed), and "
              "for crossed legs after 20 leg pairs that did not cross."]
    text = "\n".join(lines)
    print(text)
    if not args.no_write:
        write_section("sampler", text)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
