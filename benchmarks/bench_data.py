"""Data engine throughput as users run it: ``pressurepose generate`` with 1 and 2 workers, bytes per
sample, load time.

Run: ``python -m benchmarks.bench_data`` (a few minutes). Two workers against one is the
parallel scaling of ``generate`` a user sees. Prints the figures and replaces
the ``bench:data`` section of docs/RESULTS.md.

The throughput runs are the CLI with its defaults (physics producer), ``--shard-size 256`` (so 64
samples are ONE shard) and ``--workers 1`` or ``--workers 2``, each a fresh process tree timed by
wall time and by the CPU time of the whole tree (workers, forkserver and start-up included).
``--producer synthetic`` measures the pipeline alone with a fixed CPU cost per attempt instead.
"""

from __future__ import annotations

import argparse
import os
import shutil
import tempfile
import time
from pathlib import Path

from benchmarks.common import dataset_counts, machine, run_cli
from benchmarks.results import write_section


def run_generation(out: Path, workers: int, count: int, cost_ms: float, producer: str, partition: str,
                   gender: str) -> dict:
    args = ["generate", "--partition", partition, "--gender", gender, "--count", str(count), "--seed", "11",
            "--workers", str(workers), "--shard-size", "256", "--producer", producer, "--out", str(out),
            "--no-progress"]
    if producer == "synthetic":
        args += ["--option", f"cost_ms={cost_ms}"]
    run = run_cli(args)
    counts = dataset_counts(out)
    return {"wall": run["wall"], "cpu": run["cpu"], "rate": counts["samples"] / run["wall"],
            "attempts": counts["attempts"], "shards": counts["shards"],
            "bytes": sum(p.stat().st_size for p in out.glob("shard-*.h5"))}


def load_time(root: Path, count: int) -> dict:
    from pressurepose.data.dataset import DatasetReader
    from pressurepose.data.generate import generate
    from pressurepose.data.schema import GenerationConfig
    from pressurepose.data.torch_dataset import PressureDataset

    # the load set comes from the cheap synthetic producer: loading cost does not depend on how
    # the samples were made, and physics would take hours for thousands of samples
    config = GenerationConfig(partition="general", gender="m", count=count, shard_size=256, seed=12,
                              producer="synthetic")
    generate(config, root, workers=1, progress=False)
    t0 = time.perf_counter()
    reader = DatasetReader(root)  # verifies every shard's sha256
    t1 = time.perf_counter()
    ds = PressureDataset(reader)
    t2 = time.perf_counter()
    nbytes = sum(t.numel() * t.element_size() for t in ds.tensors.values())
    return {"verify": t1 - t0, "load": t2 - t1, "count": count, "memory": nbytes,
            "disk": sum(p.stat().st_size for p in root.glob("shard-*.h5"))}


def main(argv=None) -> int:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--count", type=int, default=64, help="samples per throughput run (default 64)")
    p.add_argument("--cost-ms", type=float, default=40.0,
                   help="CPU cost per attempt of the synthetic producer (default 40 ms)")
    p.add_argument("--producer", default="physics", help="producer to measure (default physics)")
    p.add_argument("--partition", default="general", help="partition of the throughput runs (default general)")
    p.add_argument("--gender", default="m", help="gender of the throughput runs (default m)")
    p.add_argument("--load-samples", type=int, default=4096,
                   help="samples generated for the load-time measurement (default 4096)")
    p.add_argument("--no-write", action="store_true", help="print only; leave docs/RESULTS.md alone")
    args = p.parse_args(argv)
    os.environ.setdefault("OMP_NUM_THREADS", "1")
    tmp = Path(tempfile.mkdtemp(prefix="bench_data_"))
    try:
        load_before = os.getloadavg()
        one = run_generation(tmp / "w1", 1, args.count, args.cost_ms, args.producer, args.partition, args.gender)
        two = run_generation(tmp / "w2", 2, args.count, args.cost_ms, args.producer, args.partition, args.gender)
        load_after = os.getloadavg()
        lt = load_time(tmp / "load", args.load_samples)
    finally:
        shutil.rmtree(tmp, ignore_errors=True)
    speedup = one["wall"] / two["wall"]
    per_sample_disk = lt["disk"] / lt["count"]
    scale = 100_000 / lt["count"]
    text = "\n".join([
        "## Data engine (`benchmarks/bench_data.py`)",
        "",
        f"`python -m benchmarks.bench_data`; machine: {machine()}, {os.cpu_count()} CPUs (shared: load average {load_before[0]:.1f} "
        f"before, {load_after[0]:.1f} after the throughput runs); {time.strftime('%Y-%m-%d')}.",
        f"Runs: `pressurepose generate --partition {args.partition} --gender {args.gender} --count {args.count} "
        f"--producer {args.producer} --workers N --shard-size 256`, other options at their defaults (one "
        f"shard)" + (f", {args.cost_ms:g} ms of CPU per attempt (a stand-in cost; not physics)"
                      if args.producer == "synthetic" else "") + "; CPU is the whole process tree's.",
        "",
        "| workers | samples | attempts | shard files | wall s | CPU s (tree) | samples per wall s | "
        "samples per CPU s | cores busy (CPU / wall) |",
        "|---|---|---|---|---|---|---|---|---|",
        *(f"| {n} | {args.count} | {r['attempts']} | {r['shards']} | {r['wall']:.1f} | {r['cpu']:.1f} | "
          f"{r['rate']:.2f} | {args.count / r['cpu']:.2f} | {r['cpu'] / r['wall']:.2f} |"
          for n, r in ((1, one), (2, two))),
        "",
        f"Measured: two workers ran {speedup:.2f}x as fast as one in wall time (goal 1.8x), on one shard: with "
        f"several workers a shard is made in parts (about 4 per worker) and put together by the coordinating "
        f"process, so both workers have work. Two workers used {two['cpu'] / one['cpu']:.2f}x the CPU of one "
        f"(the second worker's start-up and the forkserver), so on two free cores they could run at best "
        f"{2 * one['cpu'] / two['cpu']:.2f}x as fast (an estimate from CPU, not a measurement; the parts are "
        f"handed out as workers free up, so the last part is the only imbalance). On this shared machine the "
        f"wall-time ratio also measures the other jobs: 'cores busy' below 2 with 2 workers means the cores "
        f"were not free.",
        "",
        f"Disk: {per_sample_disk / 1024:.1f} kB per sample (64 x 27 mat, all fields, gzip; synthetic images are "
        f"denser than physics ones, which are zero off the body).",
        f"Loading for training: {lt['count']} samples verified (sha256) in {lt['verify']:.2f} s and loaded into "
        f"memory (images float16) in {lt['load']:.2f} s, {lt['memory'] / lt['count'] / 1024:.1f} kB per sample "
        f"in memory. Extrapolated linearly (not measured) to 100K samples: {scale * (lt['verify'] + lt['load']):.0f} s, "
        f"{scale * lt['memory'] / 2**30:.2f} GiB in memory, {scale * lt['disk'] / 2**30:.2f} GiB on disk.",
    ])
    print(text)
    if not args.no_write:
        write_section("data", text)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
