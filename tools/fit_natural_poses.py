#!/usr/bin/env python3
"""Fit the natural pose model (``pressurepose/pose/assets/natural_poses.npz``) to SMPL fits of real
lying people.

    OMP_NUM_THREADS=1 .venv/bin/python tools/fit_natural_poses.py --fits PATH [--out FILE]
        [--subjects 1-60] [--choose]

``--fits``: an SMPL pose file with ``subject`` and ``posture`` arrays, as the SMPL fits to the SLP
dataset (``slp_3dfits_train.npz``; default ``$PRESSUREPOSE_SLP_FITS``). The fits themselves never
enter the package: the model holds only each mixture's weights, means and covariances, every
component averaging over at least 50 poses (:mod:`pressurepose.pose.natural`; NOTICE.md). Subjects
61-80 are left out of the fit so ``benchmarks/bench_real_poses.py`` measures the model on people it
was not fitted to.

``--choose`` prints how the settings were chosen instead: each candidate fitted to subjects 1-45 and
measured (end-joint distance of 3000 draws, :func:`pressurepose.pose.fidelity.end_joint_distances`)
against subjects 46-60, two EM starts each; nothing is written.
"""

from __future__ import annotations

import argparse
import itertools
import os
import sys
from pathlib import Path

import numpy as np

REPO = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(REPO))

from pressurepose.errors import BadInput  # noqa: E402
from pressurepose.pose.fidelity import end_joint_distances  # noqa: E402
from pressurepose.pose.natural import (  # noqa: E402
    ASSET,
    FITS_ENV,
    GROUPS,
    FitSettings,
    fit_natural_poses,
    posture_groups,
)
from pressurepose.pose.posefile import read_poses  # noqa: E402


def subject_range(text: str) -> tuple[int, int]:
    lo, sep, hi = text.partition("-")
    try:
        lo_hi = (int(lo), int(hi if sep else lo))
    except ValueError:
        raise argparse.ArgumentTypeError(f"{text!r}: expected subjects like 1-60") from None
    if lo_hi[0] > lo_hi[1]:
        raise argparse.ArgumentTypeError(f"{text!r} runs backwards")
    return lo_hi


def load(path: str, subjects: tuple[int, int]):
    """(poses (N, 72), posture classes (N,)) of the given subjects."""
    poses = read_poses(path)
    if poses.subject is None:
        raise BadInput(f"pose file {path!r} has no subject array; the fit is split by subject")
    keep = (poses.subject >= subjects[0]) & (poses.subject <= subjects[1])
    if not keep.any():
        raise BadInput(f"pose file {path!r} holds no subject in {subjects[0]}-{subjects[1]}")
    poses = poses.select(keep)
    return poses.pose, posture_groups(poses)


def choose(path: str) -> None:
    fit_pose, fit_group = load(path, (1, 45))
    val_pose, val_group = load(path, (46, 60))
    for group in GROUPS:
        ref = val_pose[val_group == group]
        floor = end_joint_distances(fit_pose[fit_group == group], ref).mean
        print(f"{group}: subjects 1-45 against 46-60 (the floor): {100 * floor:.2f} cm")
        for k, reg, mirror in itertools.product((8, 12, 16), (1.0, 2.0), (False, True)):
            got = []
            for seed in (0, 1):
                model = fit_natural_poses(fit_pose, fit_group, FitSettings(k, reg, seed=seed, mirror_supine=mirror))
                draws = np.zeros((3000, 72))
                rng = np.random.default_rng(1)
                if group == "supine" or not mirror:  # mirror_supine changes only the supine mixture
                    draws[:, 3:] = [model.draw(rng, group) for _ in range(3000)]
                    got.append(f"{100 * end_joint_distances(draws, ref).mean:.2f}")
            if got:
                print(f"  components <= {k:2d}, reg {reg:.0f} deg, mirrored {mirror!s:5}: {' / '.join(got)} cm")


def main(argv=None) -> int:
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0],
                                formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument("--fits", default=os.environ.get(FITS_ENV), help=f"SMPL fits .npz [${FITS_ENV}]")
    p.add_argument("--out", default=str(ASSET), help=f"model file to write [{ASSET.relative_to(REPO)}]")
    p.add_argument("--subjects", type=subject_range, default=(1, 60), help="subjects to fit to [1-60]")
    p.add_argument("--choose", action="store_true", help="print the settings' comparison on subjects 1-60 only")
    args = p.parse_args(argv)
    if not args.fits:
        p.error(f"give --fits or set ${FITS_ENV}")
    try:
        if args.choose:
            choose(args.fits)
            return 0
        pose, group = load(args.fits, args.subjects)
        lo, hi = args.subjects
        model = fit_natural_poses(pose, group, FitSettings(),
                                  f"SMPL fits to SLP (Clever and Grady; Liu and Ostadabbas), subjects {lo}-{hi}")
        model.save(args.out)
    except BadInput as exc:
        print(f"error: {exc}", file=sys.stderr)
        return 2
    for g, mix in model.mixtures.items():
        counts = np.sort(np.round(mix.weights * model.poses[g])).astype(int)
        print(f"{g}: {len(mix.weights)} components over {model.poses[g]} poses (weights x poses: "
              f"{', '.join(map(str, counts))})")
    size = Path(args.out).stat().st_size // 1024
    print(f"{len(model.dims)} of 69 body pose values modelled; wrote {args.out} ({size} kB)")
    return 0


if __name__ == "__main__":
    sys.exit(main())
