"""Rebuild the PressureNet that ships in ``pressurepose/net/assets/`` (CPU-sized recipe).

Generates physics data with the data engine, trains Mod1 then Mod2, evaluates on a held-out test
set against the mean-pose baseline, and copies the model into the package::

    .venv/bin/python tools/train_shipped_model.py --work runs/shipped            # everything
    .venv/bin/python tools/train_shipped_model.py --work runs/shipped --skip-generate

Every step is a ``pressurepose`` CLI call, so each one resumes if interrupted: rerun the same
command. The defaults are sized for a 2-core laptop-class CPU: about 40 minutes of generation and
35 of training (7,200 + 300 samples); they are far below the paper's 184K samples x 100 epochs x 2 modules, and
the model is correspondingly weaker (see docs/RESULTS.md for what it achieves). For the paper's
scale use ``pressurepose generate --recipe paper`` and ``pressurepose train`` with its defaults on
a GPU.
"""

from __future__ import annotations

import argparse
import subprocess
import sys
from pathlib import Path

REPO = Path(__file__).resolve().parents[1]
ASSETS = REPO / "pressurepose" / "net" / "assets"

# (folder under WORK/data, gender, count, seed): the shipped model's data, all general_supine
DATA = (("test/f", "f", 150, 902), ("test/m", "m", 150, 903), ("train/f", "f", 3600, 900), ("train/m", "m", 3600, 901))


def cli(*args: str) -> None:
    cmd = [sys.executable, "-m", "pressurepose.cli", *args]
    print("+", " ".join(cmd), flush=True)
    subprocess.run(cmd, check=True, cwd=REPO)


def main() -> int:
    p = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument("--work", default="runs/shipped", help="work folder for data and the run [runs/shipped]")
    p.add_argument("--partition", default="general_supine")
    p.add_argument("--scale", type=float, default=1.0, help="multiply the sample counts")
    p.add_argument("--workers", type=int, default=2)
    p.add_argument("--epochs-mod1", type=int, default=10)
    p.add_argument("--epochs-mod2", type=int, default=4)
    p.add_argument("--lr", type=float, default=5e-4, help="Adam lr for Mod1 (paper 2e-5 for 100 epochs)")
    p.add_argument("--lr-mod2", type=float, default=1e-4)
    p.add_argument("--batch-size", type=int, default=32)
    p.add_argument("--skip-generate", action="store_true", help="use the data already in WORK/data")
    p.add_argument("--no-install", action="store_true", help="do not copy the model into the package")
    args = p.parse_args()

    work = Path(args.work).resolve()
    data = work / "data"
    if not args.skip_generate:
        for where, gender, count, seed in DATA:
            cli("generate", "--partition", args.partition, "--gender", gender, "--count",
                str(max(1, round(count * args.scale))), "--seed", str(seed), "--shard-size", "50",
                "--workers", str(args.workers), "--out", str(data / where))
    run = work / "run"
    cli("train", "--data", str(data / "train"), "--out", str(run), "--epochs-mod1", str(args.epochs_mod1),
        "--epochs-mod2", str(args.epochs_mod2), "--lr", str(args.lr), "--lr-mod2", str(args.lr_mod2),
        "--batch-size", str(args.batch_size), "--seed", "0")
    cli("evaluate", "--model", str(run), "--data", str(data / "test"), "--out", str(work / "eval"))
    if not args.no_install:
        install(run)
    return 0


def install(run: Path) -> None:
    """Copy the run's model into the package: weights as float16 (half the size; joint estimates
    moved by at most 1.4 mm on 40 test images) in one file per module, each small enough for git."""
    import torch

    from pressurepose.net.checkpoint import body_model, load_model, read_model_files, save_model

    specs = read_model_files(run)[0]["bodies"]
    bodies = tuple(body_model(specs[g]["spec"]) for g in ("female", "male"))
    net, meta = load_model(run, bodies=bodies)
    ASSETS.mkdir(parents=True, exist_ok=True)
    for old in ASSETS.glob("pressurenet*"):
        old.unlink()
    save_model(ASSETS / "pressurenet.json", net, bodies, meta,
               split_modules=True, dtype=torch.float16)


if __name__ == "__main__":
    raise SystemExit(main())
