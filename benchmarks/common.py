"""What the benchmarks share: running ``pressurepose`` as a user does, the real-data argument, and
the machine/date stamp of a section.

Running the CLI: a fresh process per command, timed by the CPU time of its whole process tree (the
CLI, worker processes, the forkserver; start-up included) and by wall time. The forkserver that
starts the worker processes outlives the CLI by a moment and is nobody's child to wait for, so
``RUSAGE_CHILDREN`` alone would miss it and its workers. This process therefore makes itself a
child subreaper (Linux ``prctl(PR_SET_CHILD_SUBREAPER)``): orphaned descendants are handed to it,
and it waits for every one of them, so their CPU is counted.

Real data: a benchmark that needs real pressure images takes the folder by ``--real PATH``
(default: the environment variable ``PRESSUREPOSE_PMD``); without it, it prints why it skips and
returns 0, so ``make bench`` runs on a machine without the dataset."""

from __future__ import annotations

import argparse
import ctypes
import datetime
import json
import os
import platform
import resource
import subprocess
import sys
import time
from pathlib import Path

REPO = Path(__file__).resolve().parents[1]
REAL_ENV = "PRESSUREPOSE_PMD"


def add_real_argument(parser: argparse.ArgumentParser) -> None:
    """``--real PATH``: the real-data folder (PhysioNet PMD experiment I, or any folder
    ``pressurepose evaluate-real`` reads); default ``$PRESSUREPOSE_PMD``."""
    parser.add_argument("--real", type=Path, default=os.environ.get(REAL_ENV) or None, metavar="PATH",
                        help=f"real pressure images (PMD experiment I or a labelled folder) [${REAL_ENV}]")


def real_folder(path, benchmark: str) -> Path | None:
    """``path`` as a Path when it is a folder; otherwise None, after printing why ``benchmark`` skips."""
    if path is not None and Path(path).is_dir():
        return Path(path)
    why = (f"{path} is not a folder" if path is not None
           else f"no real data given (--real PATH, or set {REAL_ENV})")
    print(f"{benchmark}: skipped, {why}; it needs real pressure images such as PhysioNet PMD experiment I. "
          "Nothing measured, docs/RESULTS.md left as it is.")
    return None


def machine() -> str:
    """'<platform>, <CPU model>': the machine a figure was measured on (CPU speed and instruction
    sets, bf16 among them, differ between machines that share a platform string)."""
    model = platform.processor()
    try:
        with open("/proc/cpuinfo", encoding="utf-8") as f:
            model = next((line.split(":", 1)[1].strip() for line in f if line.startswith("model name")), model)
    except OSError:
        pass
    return f"{platform.platform()}, {model or 'CPU model unknown'}"


def stamp() -> str:
    """'YYYY-MM-DD, <platform>, <CPU model>, N CPUs': when and where a section was measured."""
    return f"{datetime.date.today().isoformat()}, {machine()}, {os.cpu_count()} CPUs"


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
