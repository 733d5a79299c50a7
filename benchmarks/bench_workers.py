"""Worker scaling of ``pressurepose generate`` as users run it: the same dataset made with 1 and
with 2 (or ``--workers N``) worker processes, each in a fresh process, timed by wall time and by the
CPU time of the whole process tree; the datasets must come out byte-identical.

    .venv/bin/python -m benchmarks.bench_workers [--partition general_supine] [--gender f] [--count 64]
                                                 [--seed 77] [--workers 1 2] [--no-write]

Run it on an otherwise idle machine: the speed-up is a wall-time ratio, and neighbours' load
changes it. Goal (issue 13): two workers at least 1.8x one. Replaces the ``bench:workers`` section
of docs/RESULTS.md.
"""

from __future__ import annotations

import argparse
import datetime
import hashlib
import os
import platform
import tempfile
from pathlib import Path

from benchmarks.results import write_section
from benchmarks.user_path import dataset_counts, run_cli


def shard_digests(out: Path) -> dict[str, str]:
    """sha256 of every shard file below ``out``, by path relative to it."""
    return {str(p.relative_to(out)): hashlib.sha256(p.read_bytes()).hexdigest() for p in sorted(out.rglob("*.h5"))}


def main() -> int:
    p = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument("--partition", default="general_supine")
    p.add_argument("--gender", default="f")
    p.add_argument("--count", type=int, default=64)
    p.add_argument("--seed", type=int, default=77)
    p.add_argument("--workers", type=int, nargs="+", default=[1, 2])
    p.add_argument("--no-write", action="store_true", help="print only; leave docs/RESULTS.md alone")
    args = p.parse_args()
    runs = {}
    with tempfile.TemporaryDirectory() as tmp:
        for w in args.workers:
            out = Path(tmp) / f"w{w}"
            r = run_cli(["generate", "--partition", args.partition, "--gender", args.gender, "--count",
                         str(args.count), "--seed", str(args.seed), "--workers", str(w), "--no-progress",
                         "--out", str(out)])
            runs[w] = {**r, "samples": dataset_counts(out)["samples"], "digests": shard_digests(out)}
            print(f"{w} worker(s): {r['wall']:.1f} s wall, {r['cpu']:.1f} s CPU", flush=True)
    base = runs[args.workers[0]]
    identical = all(r["digests"] == base["digests"] for r in runs.values())
    rows = [f"| {w} | {r['samples']} | {r['wall']:.1f} | {r['cpu']:.1f} | {r['samples'] / r['wall']:.2f} | "
            f"{r['samples'] / r['cpu']:.2f} | {base['wall'] / r['wall']:.2f} |" for w, r in runs.items()]
    text = "\n".join([
        "## Worker scaling of `generate` (`benchmarks/bench_workers.py`)",
        "",
        f"{datetime.date.today().isoformat()}, {platform.platform()}, {os.cpu_count()} CPUs, otherwise idle. "
        f"`pressurepose generate --partition {args.partition} --gender {args.gender} --count {args.count} "
        f"--seed {args.seed} --workers N`, a fresh process each; CPU of the whole process tree, start-up "
        "included. Goal (issue 13): 2 workers at least 1.8x one.",
        "",
        "| workers | samples | wall (s) | CPU (s) | per wall-second | per CPU-second | speed-up (wall) |",
        "|---|---|---|---|---|---|---|",
        *rows,
        "",
        f"Shard files byte-identical across worker counts: {'yes' if identical else '**no**'} "
        f"({len(base['digests'])} shards).",
    ])
    print(text)
    if not args.no_write:
        write_section("workers", text)
    return 0 if identical else 1


if __name__ == "__main__":
    raise SystemExit(main())
