"""Run every maintained benchmark in turn (``make bench``); each writes its own section of docs/RESULTS.md.

Takes a while on a 2-core machine (the data generation runs and the calibration recovery take
minutes each). The benchmarks on real images (bench_real, bench_realism) read the folder named by
``$PRESSUREPOSE_PMD`` and skip without it; bench_sampler_fidelity reads the paper's public sampler
output (``$PRESSUREPOSE_OFFICIAL_SAMPLER``) and skips without it.
"""

from __future__ import annotations

import importlib
import sys

BENCHMARKS = (("bench_body", []), ("bench_sampler", []), ("bench_sampler_fidelity", []), ("bench_press", []),
              ("bench_settle", []), ("bench_settle", ["--agreement", "6", "--seed", "7"]), ("bench_simulate", []),
              ("bench_data", []), ("bench_net", []), ("bench_calibrate", []), ("bench_real", []),
              ("bench_realism", []), ("bench_real_poses", []), ("bench_sites", []))


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
