"""Rebuild the site network that ships in ``pressurepose/net/assets/`` (``sitenet.json`` and
``sitenet.safetensors``; :mod:`pressurepose.net.sitenet`).

Generates 170 samples per gender of each of the eight partitions that do not draw from real lying
poses (seed 7001, which no other run of the project uses; each sample records the body site under
every taxel), reads every image with the shipped PressureNet to get its estimated body's site map,
and trains the site network on it (:func:`pressurepose.net.sitenet_train.train_site_net`, seed
``--seed``)::

    python tools/train_site_net.py --work runs/sitenet               # data and training
    python tools/train_site_net.py --work runs/sitenet --install     # ... then ship the network

Every step resumes if interrupted: rerun the same command and it keeps the finished datasets and
the last saved epoch. Budget on a 2-core CPU: data about 27 minutes with 2 workers (2,720
samples), reading them with PressureNet about 4 minutes, training (12 epochs) about 15 minutes on
one thread. The shipped network is seed 0's; how it was chosen: docs/monitoring.md, "How well, and
how fast"; how well it reads: docs/RESULTS.md, "Pressure per body site".
"""

from __future__ import annotations

import argparse
import shutil
import sys
from pathlib import Path

from pressurepose.cli import main as _main

PARTITIONS = ("general", "general_supine", "hands_behind_head", "prone_hands_up", "supine_crossed_legs",
              "supine_straight_limbs", "general_lateral", "propped_lateral")
SEED, COUNT, SHARD = 7001, 170, 34
ASSETS = Path(__file__).resolve().parents[1] / "pressurepose" / "net" / "assets"


def cli(*args: str) -> None:
    if _main(list(args)) != 0:
        raise SystemExit(f"pressurepose {' '.join(args)} failed")


def make_data(root: Path, count: int = COUNT, workers: str = "auto") -> Path:
    """Generate ``count`` samples per gender of every partition of :data:`PARTITIONS` under ``root``."""
    for part in PARTITIONS:
        for gender in "fm":
            cli("generate", "--partition", part, "--gender", gender, "--count", str(count), "--seed", str(SEED),
                "--shard-size", str(SHARD), "--workers", workers, "--out", str(root / part / gender))
    return root


def install(trained: Path, assets: Path = ASSETS) -> list[Path]:
    """Copy a trained site network (``sitenet.json`` and its weights) into ``assets``."""
    from pressurepose.net.sitenet import load_site_net

    load_site_net(trained)  # refuse anything that is not a whole site network
    out = []
    for src in (trained, trained.with_suffix(".safetensors")):
        out.append(Path(shutil.copy2(src, assets / src.name)))
    return out


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--work", type=Path, required=True, help="folder for the data and the training run")
    ap.add_argument("--count", type=int, default=COUNT, help=f"samples per gender and partition (default {COUNT})")
    ap.add_argument("--seed", type=int, default=0, help="training seed (default 0, the shipped network's)")
    ap.add_argument("--workers", default="auto", help="generate's worker processes (default auto)")
    ap.add_argument("--install", action="store_true", help="copy the trained network into the package")
    args = ap.parse_args(argv)
    from pressurepose.net.sitenet_train import SiteTrainConfig, load_site_data, train_site_net

    data = load_site_data(make_data(args.work / "data", args.count, args.workers))
    train_site_net(data, SiteTrainConfig(seed=args.seed), out=args.work / "train")
    trained = args.work / "train" / "sitenet.json"
    print(f"site network: {trained}")
    if args.install:
        for path in install(trained):
            print(f"installed {path}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
