"""Running ``pressurepose`` as a user does, for the benchmarks: a fresh process per command, timed by
the CPU time of its whole process tree (the CLI, worker processes, the forkserver; start-up
included) and by wall time.

The forkserver that starts the worker processes outlives the CLI by a moment and is nobody's child
to wait for, so ``RUSAGE_CHILDREN`` alone would miss it and its workers. This process therefore
makes itself a child subreaper (Linux ``prctl(PR_SET_CHILD_SUBREAPER)``): orphaned descendants are
handed to it, and it waits for every one of them, so their CPU is counted."""

from __future__ import annotations

import ctypes
import json
import os
import resource
import subprocess
import sys
import time
from pathlib import Path

REPO = Path(__file__).resolve().parents[1]


PR_SET_CHILD_SUBREAPER = 36


def _become_subreaper() -> None:
    libc = ctypes.CDLL(None, use_errno=True)
    if libc.prctl(PR_SET_CHILD_SUBREAPER, 1, 0, 0, 0) != 0:
        raise OSError(ctypes.get_errno(), "prctl(PR_SET_CHILD_SUBREAPER) failed: process-tree CPU would be undercounted")


def _reap_all() -> None:
    """Wait for every remaining descendant handed to this process (blocks until they exit)."""
    while True:
        try:
            os.waitpid(-1, 0)
        except ChildProcessError:
            return


def _children_cpu() -> float:
    ru = resource.getrusage(resource.RUSAGE_CHILDREN)
    return ru.ru_utime + ru.ru_stime


def run_cli(args: list[str], env: dict | None = None) -> dict:
    """Run ``python -m pressurepose.cli *args`` to completion. Returns cpu (s, user + system, of the
    process and all its descendants, which this process waits for), wall (s), and the output tail.
    Raises RuntimeError when the command fails."""
    full_env = dict(os.environ, OMP_NUM_THREADS="1", PYTHONPATH=str(REPO), **(env or {}))
    _become_subreaper()
    _reap_all()
    cpu0, t0 = _children_cpu(), time.perf_counter()
    proc = subprocess.run([sys.executable, "-m", "pressurepose.cli", *args], cwd=REPO, env=full_env,
                          capture_output=True, text=True)
    wall = time.perf_counter() - t0
    _reap_all()
    cpu = _children_cpu() - cpu0
    if proc.returncode != 0:
        raise RuntimeError(f"pressurepose {' '.join(args)} failed ({proc.returncode}):\n{proc.stderr[-2000:]}")
    return {"cpu": cpu, "wall": wall, "stdout": proc.stdout[-2000:]}


def manifests(out: Path) -> list[dict]:
    """The manifests of the dataset in ``out`` or of the datasets below it (a recipe's output)."""
    return [json.loads(p.read_text()) for p in sorted(Path(out).rglob("manifest.json"))]


def dataset_counts(out: Path) -> dict:
    """Samples, attempts, rejections by cause and shard files over the dataset(s) in ``out``."""
    samples = attempts = shards = 0
    rejections: dict[str, int] = {}
    for m in manifests(out):
        for record in m["shards"].values():
            samples += record["count"]
            attempts += record["attempts"]
            shards += 1
            for cause, n in record.get("rejections", {}).items():
                rejections[cause] = rejections.get(cause, 0) + n
    return {"samples": samples, "attempts": attempts, "rejections": rejections, "shards": shards}
