"""Data generation as users run it: accepted samples per CPU-second of ``pressurepose generate``.

    python -m benchmarks.bench_simulate [--count 16] [--seed 5] [--recipe-scale 0.003] [--no-write]

Throughput is measured on the user's path: the CLI with its defaults (physics producer, default
bed and mat) and ``--workers 1``, a fresh process per run, timed by the CPU time of its whole process tree
(start-up, imports, set-up, every attempt, shard encoding and writing); the machine is shared, so
wall time would measure the neighbours. One run per partition of the paper's recipe and gender,
``--count`` samples each (partitions the recipe only has with limbs over the bed run with
``--limbs-on-bed``), and one run of the whole paper recipe scaled down (``--recipe paper --scale``;
its smallest entries round up to one sample, so they weigh a little more than in the paper's mix).
The recipe's rate is also predicted from the rows: the paper's full-scale mix of partitions and
genders, each at its row's CPU per sample (:func:`mix_rate`; entries with limbs over the bed at
their partition's row without). At the old default scale, 0.0005
(110 samples), the run read 1.46 where the rows predict about 1.0, and 620-sample runs (scale
0.003) measured 1.09-1.20: so few samples of the slow partitions made the small run's figure luck.

Where the time goes is measured in this process, on the very same attempts (same configs and
per-attempt seeds): settle steps to rest, rejected attempts by cause with how many steps and CPU
seconds they ran before rejection, and the CPU split between pose sampling, settling and pressing.
Start-up is the CPU of a one-sample run minus that sample's attempts, with the settle stiffness
read from the cache and, once, fitted afresh (an empty cache, as on a machine's first run).

Goal: at least 3 accepted samples per CPU-second on one core, start-up included, for
``general`` and for the recipe mix. Prints the figures and replaces the ``bench:simulate`` section
of docs/RESULTS.md.
"""

from __future__ import annotations

import argparse
import collections
import datetime
import os
import shutil
import tempfile
from pathlib import Path

import mujoco
import numpy as np

from benchmarks.common import dataset_counts, machine, run_cli
from benchmarks.results import write_section
from pressurepose.data.producers import attempt_rng
from pressurepose.data.schema import GenerationConfig

# (partition, limbs on bed): the paper recipe's partitions (two exist there only with limbs over the
# bed), then the project's side-lying and propped partitions (not in the recipe)
PARTITIONS = (("general", False), ("general_supine", False), ("hands_behind_head", True),
              ("prone_hands_up", True), ("supine_crossed_legs", False), ("supine_straight_limbs", False),
              ("general_lateral", False), ("propped_lateral", False))
GENDERS = ("f", "m")
CAUSES = ("not_settled", "unstable", "fell_off_bed", "posture_changed", "self_collision", "support_overlap",
          "press_failed", "limb_off_bed")
GOAL = 3.0


def cli_args(partition: str, gender: str, plo: bool, count: int, seed: int, out: Path) -> list[str]:
    return (["generate", "--partition", partition, "--gender", gender, "--count", str(count), "--seed", str(seed),
             "--workers", "1", "--out", str(out), "--no-progress"] + (["--limbs-on-bed"] if plo else []))


def breakdown(config: GenerationConfig) -> dict:
    """Every attempt of ``config``'s samples, made by the physics producer's own call
    (:func:`pressurepose.sim.simulate.simulate_one`), with its settle steps and the CPU of its phases."""
    from pressurepose.data.physics import sampler_config, setup
    from pressurepose.sim.simulate import Rejected, simulate_one

    body, bed = setup(config)
    rows = []  # (status, steps, sample s, settle s, press s)
    for i in range(config.count):
        for attempt in range(config.max_attempts):
            t: dict = {}
            res = simulate_one(body, bed, config.partition, config.gender, attempt_rng(config, i, attempt),
                               config.limbs_on_bed, sampler_config(config), timings=t)
            status = res.cause if isinstance(res, Rejected) else "settled"
            rows.append((status, t["steps"], t["sample"], t["settle"], t["press"]))
            if status == "settled":
                break
    return {"rows": rows}


def mix_rate(rates: dict, mix: dict) -> float:
    """Accepted samples per CPU-second of a mix: ``mix`` {key: samples} (e.g. a recipe's count per
    (partition, gender, limbs on bed)) made at ``rates`` {key: samples per CPU-second}; every key of
    ``mix`` must have a rate. The mix's CPU is the sum of each part's samples over its rate."""
    missing = [k for k in mix if k not in rates]
    if missing:
        raise KeyError(f"no rate for {missing}")
    return sum(mix.values()) / sum(n / rates[k] for k, n in mix.items())


def recipe_mix(scale: float = 1.0) -> dict:
    """{(partition, gender, limbs on bed): samples} of the paper recipe at ``scale``."""
    from pressurepose.data.recipes import load_recipe

    mix: dict = collections.Counter()
    for e in load_recipe("paper", scale=scale):
        mix[(e.config.partition, e.config.gender, e.config.limbs_on_bed)] += e.config.count
    return dict(mix)


def _med(x) -> str:
    return f"{np.median(x):.0f}" if len(x) else "-"


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--count", type=int, default=16, help="samples per partition and gender [16]")
    ap.add_argument("--seed", type=int, default=5, help="seed [5]")
    ap.add_argument("--recipe-scale", type=float, default=0.003, help="scale of the paper recipe run [0.003]")
    ap.add_argument("--no-write", action="store_true", help="print only; leave docs/RESULTS.md alone")
    args = ap.parse_args(argv)
    tmp = Path(tempfile.mkdtemp(prefix="bench_simulate_"))
    load_before = os.getloadavg()
    results = {}
    try:
        # start-up: a one-sample run with the stiffness cache cold (a machine's first run), then warm
        one = cli_args("general", "f", False, 1, args.seed, tmp / "one_cold")
        cold = run_cli(one, env={"PRESSUREPOSE_CACHE_DIR": str(tmp / "cache")})
        warm = run_cli(cli_args("general", "f", False, 1, args.seed, tmp / "one_warm"),
                       env={"PRESSUREPOSE_CACHE_DIR": str(tmp / "cache")})
        first_config = GenerationConfig(partition="general", gender="f", count=1, seed=args.seed)
        breakdown(first_config)  # set-up (settle model, caches) in this process, so the next is per attempt
        first = breakdown(first_config)
        first_cpu = sum(sum(r[2:]) for r in first["rows"])
        startup = {"cold": cold["cpu"] - first_cpu, "warm": warm["cpu"] - first_cpu}
        print(f"start-up CPU s: cold cache {startup['cold']:.2f}, warm {startup['warm']:.2f}", flush=True)
        for part, plo in PARTITIONS:
            for g in GENDERS:
                out = tmp / f"{part}_{g}"
                run = run_cli(cli_args(part, g, plo, args.count, args.seed, out))
                counts = dataset_counts(out)
                config = GenerationConfig(partition=part, gender=g, limbs_on_bed=plo, count=args.count,
                                          seed=args.seed)
                detail = breakdown(config)
                results[(part, g, plo)] = dict(run=run, counts=counts, **detail)
                print(part, g, f"{counts['samples']} samples, {counts['attempts']} attempts, CPU {run['cpu']:.1f} s: "
                      f"{counts['samples'] / run['cpu']:.2f} per CPU s", flush=True)
        recipe_out = tmp / "recipe"
        recipe = run_cli(["generate", "--recipe", "paper", "--scale", str(args.recipe_scale), "--workers", "1",
                          "--out", str(recipe_out), "--no-progress"])
        recipe_counts = dataset_counts(recipe_out)
    finally:
        shutil.rmtree(tmp, ignore_errors=True)
    load_after = os.getloadavg()

    head = ("| partition | gender | samples | attempts | CPU s (process tree) | **accepted per CPU s** | "
            "settle steps to rest, median (90th pct) | rejected: cause x count (median steps, CPU s in all) | "
            "CPU in rejected attempts | CPU split sample / settle / press |")
    lines = [head, "|" + "---|" * (head.count("|") - 1)]
    for (part, g, plo), r in results.items():
        rows, c, run = r["rows"], r["counts"], r["run"]
        ok = [x for x in rows if x[0] == "settled"]
        steps = np.array([x[1] for x in ok])
        rej = collections.defaultdict(list)
        for x in rows:
            if x[0] != "settled":
                rej[x[0]].append(x)
        rej_text = ", ".join(f"{cause} x {len(v)} ({_med([x[1] for x in v])}, {sum(sum(x[2:]) for x in v):.1f})"
                             for cause, v in sorted(rej.items())) or "none"
        total = sum(sum(x[2:]) for x in rows)
        rej_cpu = sum(sum(x[2:]) for v in rej.values() for x in v)
        split = [sum(x[k] for x in rows) / total for k in (2, 3, 4)]
        lines.append(f"| {part}{' (limbs on bed)' if plo else ''} | {g} | {c['samples']} | {c['attempts']} | "
                     f"{run['cpu']:.1f} | **{c['samples'] / run['cpu']:.2f}** | "
                     f"{_med(steps)} ({np.percentile(steps, 90):.0f}) | {rej_text} | {100 * rej_cpu / total:.0f} % | "
                     f"{100 * split[0]:.0f} / {100 * split[1]:.0f} / {100 * split[2]:.0f} % |")
    general = [r for (p, g, plo), r in results.items() if p == "general"]
    general_rate = sum(r["counts"]["samples"] for r in general) / sum(r["run"]["cpu"] for r in general)
    recipe_rate = recipe_counts["samples"] / recipe["cpu"]
    rates = {k: r["counts"]["samples"] / r["run"]["cpu"] for k, r in results.items()}
    mix: dict = collections.Counter()  # entries with no row of their own (limbs over the bed) at the other one's rate
    for (part, g, plo), n in recipe_mix().items():
        mix[(part, g, plo) if (part, g, plo) in rates else (part, g, not plo)] += n
    predicted = mix_rate(rates, mix)
    per_step = [sum(x[3] for x in r["rows"]) / max(1, sum(x[1] for x in r["rows"])) for r in results.values()]
    text = "\n".join([
        "## Data generation as users run it (`benchmarks/bench_simulate.py`)", "",
        f"`python -m benchmarks.bench_simulate`; {datetime.date.today()}, {machine()}, {os.cpu_count()} "
        f"CPUs shared with other jobs (load "
        f"average {load_before[0]:.1f} before, {load_after[0]:.1f} after), MuJoCo {mujoco.__version__}, "
        f"OMP_NUM_THREADS=1 (the simulation is CPU-only).", "",
        f"Each row is one `pressurepose generate --partition P --gender G --count {args.count} --seed {args.seed} "
        "--workers 1` with every other option at its default, in a fresh process; its CPU is that of the whole "
        "process tree, start-up included. Steps, rejections and the CPU split come from the same attempts "
        "replayed in the benchmark process.", "",
        *lines, "",
        f"Start-up of a run (interpreter, imports, body model, bed, settle model; CPU of a one-sample run less "
        f"its attempts): {startup['warm']:.2f} s with the fitted settle stiffness read from the cache, "
        f"{startup['cold']:.2f} s on a machine's first run (the fit, then cached in `~/.cache/pressurepose`).",
        f"A settle step costs {1000 * np.median(per_step):.2f} ms of CPU (median over the rows; MuJoCo's "
        "step is most of it: about a third is the 612-cell bed itself, the contacts of the resting body most of "
        "the rest; docs/throughput.md).", "",
        f"**`general`: {general_rate:.2f} accepted samples per CPU-second** (both genders, start-up included). "
        f"**Paper recipe** (`generate --recipe paper --scale {args.recipe_scale:g} --workers 1`, all 36 entries in one "
        f"process, {recipe_counts['samples']} samples, {recipe_counts['attempts']} attempts): "
        f"**{recipe_rate:.2f} accepted samples per CPU-second**; the rows above, weighted by the paper's "
        f"full-scale mix of partitions and genders, predict {predicted:.2f} (entries with limbs over the bed "
        f"at their partition's rate without). Goal: {GOAL:g}.",
    ])
    print(text)
    if not args.no_write:
        write_section("simulate", text)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
