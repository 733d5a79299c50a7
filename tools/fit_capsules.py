"""Fit the shipped capsule regressors: pressurepose/body/assets/capsules_{female,male,neutral}.npz.

For each gender: sample betas ~ U(-3, 3)^10 (seeded), fit the 20 capsules directly to each shaped
mesh (``pressurepose.body.capsules.fit_capsules``), solve least squares for the linear maps
``[betas, 1] @ betas2*`` and write them with the fit's residuals. Then check on fresh betas how far the
regressed capsules are from the direct fit and how well they cover the mesh, and print it all.

    .venv/bin/python tools/fit_capsules.py                   # all genders, 300 samples, seed 0
    .venv/bin/python tools/fit_capsules.py --gender f --samples 100 --out /tmp/caps
"""

from __future__ import annotations

import argparse
import sys
import time
from pathlib import Path

import numpy as np

from pressurepose.body import BodyModel
from pressurepose.body.capsules import (
    fit_capsules,
    fit_regressors,
    point_capsule_distance,
    posed_capsules,
    regressed_capsules,
    regressor_path,
    save_regressors,
)
from pressurepose.body.model import canonical_gender


def coverage(body, caps, betas, within: float = 0.03) -> float:
    """Share of rest-mesh vertices inside or within ``within`` m of some capsule."""
    verts, _ = body.rest(betas[None])
    ends, radius = posed_capsules(body, caps, betas, np.zeros((1, 72)))
    out = np.maximum(point_capsule_distance(verts[0], ends[0]) - radius, 0.0).min(1)
    return float(np.mean(out <= within))


def check(body, reg, num: int, seed: int) -> dict[str, float]:
    """Regressed vs direct capsules on ``num`` fresh betas ~ U(-3, 3): max errors (m), coverage."""
    rng = np.random.default_rng(seed)
    err = {"length": 0.0, "radius": 0.0, "center": 0.0}
    cov_fit, cov_reg = [], []
    for betas in rng.uniform(-3, 3, (num, body.num_betas)):
        direct, fast = fit_capsules(body, betas), regressed_capsules(reg, betas)
        err["length"] = max(err["length"], float(np.abs(fast.length - direct.length).max()))
        err["radius"] = max(err["radius"], float(np.abs(fast.radius - direct.radius).max()))
        err["center"] = max(err["center"], float(np.abs(fast.center - direct.center).max()))
        cov_fit.append(coverage(body, direct, betas))
        cov_reg.append(coverage(body, fast, betas))
    mean_cov = coverage(body, regressed_capsules(reg, np.zeros(body.num_betas)), np.zeros(body.num_betas))
    return {**{f"max_err_{k}": v for k, v in err.items()}, "min_coverage_direct": min(cov_fit),
            "min_coverage_regressed": min(cov_reg), "coverage_mean_shape": mean_cov}


def main(argv=None) -> int:
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    p.add_argument("--gender", action="append", help="f, m or n (repeatable; default all three)")
    p.add_argument("--samples", type=int, default=300, help="sampled shapes per gender (default 300)")
    p.add_argument("--seed", type=int, default=0, help="seed of the sampled shapes (default 0)")
    p.add_argument("--check", type=int, default=20, help="fresh shapes to check the regressors on (default 20)")
    p.add_argument("--out", type=Path, help="folder to write to (default: the package assets)")
    args = p.parse_args(argv)
    genders = [canonical_gender(g) for g in (args.gender or ["female", "male", "neutral"])]
    for g in genders:
        t0 = time.perf_counter()
        body = BodyModel(g)
        reg, _ = fit_regressors(body, num_samples=args.samples, seed=args.seed)
        path = regressor_path(g) if args.out is None else args.out / f"capsules_{g}.npz"
        path.parent.mkdir(parents=True, exist_ok=True)
        save_regressors(reg, path)
        stats = check(body, reg, args.check, args.seed + 1)
        print(f"{g}: wrote {path} in {time.perf_counter() - t0:.1f} s")
        for k, v in {**{k: v for k, v in reg.meta.items() if k.startswith("fit_")}, **stats}.items():
            print(f"  {k:24s} {v:.4g}" if isinstance(v, float) else f"  {k:24s} {v}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
