"""Calibration check: CMA-ES recovering five hidden bed constants from synthetic capsule measurements.

    python -m benchmarks.bench_calibrate [--popsize 50] [--seed 0] [--no-write]

Ten capsules as in the paper (20 cm long with 1.3-14 kg, 40 cm long with 1.3-18 kg) are pressed on the
BodiTrak bed with hidden constants; their images and sinks become the "measurements"; the fit starts
from the shipped constants. Prints the figures and replaces the ``bench:calibrate`` section of
docs/RESULTS.md. Takes a few minutes on one core.
"""

from __future__ import annotations

import argparse
import datetime
import os
import time

import numpy as np

from benchmarks.common import machine
from benchmarks.results import write_section
from pressurepose.calibrate.measurements import CapsuleMeasurements
from pressurepose.calibrate.objects import (
    bed_params,
    calibrate,
    measurement_heightfields,
    readings,
    with_params,
)
from pressurepose.sim import get_bed
from pressurepose.sim.stiffness import press_objects

HIDDEN = {"stiffness": 7.0e4, "spread": 0.03, "c0": 3.0, "c1": 1.3, "c2": 0.004}


def paper_capsules(bed, seed: int = 0) -> CapsuleMeasurements:
    """The paper's ten capsule loads at random places and angles on the mat, measured on a bed
    with the HIDDEN constants."""
    rng = np.random.default_rng(seed)
    rows = [(r, length, w) for r, length, ws in ((0.05, 0.2, (1.3, 2.3, 4.5, 9.1, 14.0)),
                                                 (0.075, 0.4, (1.3, 4.5, 9.1, 14.0, 18.0))) for w in ws]
    rad, length, mass = (np.array(c) for c in zip(*rows))
    centre = np.stack([rng.uniform(0.25, 0.52, len(rows)), rng.uniform(0.4, 1.4, len(rows))], 1)
    yaw = rng.uniform(0, np.pi, len(rows))
    blank = CapsuleMeasurements(bed.mat, rad, length, mass, centre, yaw, np.zeros((len(rows),) + bed.mat.shape),
                                np.ones(len(rows)))
    truth = with_params(bed, HIDDEN)
    force, sink = press_objects(truth, measurement_heightfields(blank, bed), mass)
    return CapsuleMeasurements(bed.mat, rad, length, mass, centre, yaw, readings(force, truth), sink)


def main(argv=None) -> int:
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    p.add_argument("--popsize", type=int, default=50, help="CMA-ES population [50]")
    p.add_argument("--seed", type=int, default=0, help="CMA-ES seed [0]")
    p.add_argument("--max-evals", type=int, default=6000, help="most loss evaluations [6000]")
    p.add_argument("--no-write", action="store_true", help="print only; leave docs/RESULTS.md alone")
    args = p.parse_args(argv)
    load = os.getloadavg()[0]
    bed = get_bed()
    data = paper_capsules(bed)
    t0 = time.perf_counter()
    res = calibrate(data, bed, popsize=args.popsize, seed=args.seed, max_evals=args.max_evals)
    seconds = time.perf_counter() - t0
    start = bed_params(bed)
    lines = [
        "## Calibration recovers hidden constants (`benchmarks/bench_calibrate.py`)",
        "",
        f"`python -m benchmarks.bench_calibrate`; {datetime.date.today().isoformat()}, {machine()}, "
        f"{os.cpu_count()} CPUs (one used; load "
        f"average {load:.1f} at the start). {len(data)} synthetic capsule measurements (the paper's loads) on the "
        f"BodiTrak bed, all five constants fitted by CMA-ES, population {args.popsize}, seed {args.seed}: "
        f"{res.evaluations} evaluations, {seconds:.0f} s, final loss {res.loss:.2e}, stopped on "
        f"{', '.join(res.stop)}.",
        "",
        "| constant | start (shipped) | hidden | fitted | error |",
        "|---|---|---|---|---|",
        *[f"| {k} | {start[k]:.4g} | {v:.4g} | {res.fitted[k]:.4g} | "
          f"{abs(res.fitted[k] - v) / abs(v) * 100:.2f} % |" for k, v in HIDDEN.items()],
    ]
    text = "\n".join(lines)
    print(text)
    if not args.no_write:
        write_section("calibrate", text)
    return 0




if __name__ == "__main__":
    raise SystemExit(main())
