"""``pressurepose demo``: the main job on built-in defaults.

Draws a body of random shape and pose from the shipped open model, writes a PNG and prints a
summary. Each later stage of the pipeline (sample, settle, press, estimate) joins here as it lands.
"""

from __future__ import annotations

import argparse
from pathlib import Path

import numpy as np


def add_demo_arguments(p: argparse.ArgumentParser) -> None:
    p.add_argument("--gender", default="f", help="f or m [f]")
    p.add_argument("--seed", type=int, default=0, help="random seed [0]")
    p.add_argument("--out", default="demo_out", help="output folder [demo_out]")


def run_demo(args) -> int:
    from pressurepose.body import BodyModel
    from pressurepose.viz.body_figure import body_figure

    out = Path(args.out)
    out.mkdir(parents=True, exist_ok=True)
    rng = np.random.default_rng(args.seed)
    body = BodyModel(args.gender)
    betas = rng.uniform(-2, 2, body.num_betas)
    pose = np.zeros(72)
    pose[3:] = rng.uniform(-0.3, 0.3, 69)  # a gentle random pose; the sampler gives real ones
    fig, summary = body_figure(body, betas, pose, title="a random body (shape and pose)")
    path = out / "body.png"
    fig.savefig(path, dpi=110)
    print(summary)
    print(f"wrote {path}")
    return 0
