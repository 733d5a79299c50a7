"""Run every benchmark in turn (``make bench``); each writes its own section of docs/RESULTS.md.

Takes a while on a 2-core machine (the calibration recovery alone is a few minutes).
"""

from __future__ import annotations

import importlib
import sys

BENCHMARKS = (("bench_body", []), ("bench_sampler", []), ("bench_press", []), ("bench_settle", []),
              ("bench_settle", ["--agreement", "4", "--seed", "7"]), ("bench_simulate", []), ("bench_data", []),
              ("bench_net", []), ("bench_calibrate", []), ("bench_real_poses", []))


def main() -> int:
    failed = []
    for name, argv in BENCHMARKS:
        print(f"=== {name} {' '.join(argv)}", flush=True)
        try:
            rc = importlib.import_module(f"benchmarks.{name}").main(argv)
        except SystemExit as exc:  # argparse or an explicit exit
            rc = exc.code
        if rc:
            failed.append(name)
    if failed:
        print(f"failed: {', '.join(failed)}", file=sys.stderr)
    return 1 if failed else 0


if __name__ == "__main__":
    raise SystemExit(main())
