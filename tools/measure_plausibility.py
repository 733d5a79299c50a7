"""Measure the statistics of the plausibility check (pressurepose.net.plausibility) on real,
simulated and non-body images, and what the check says of each group: the figures behind its
thresholds (docs/real-mats.md).

    python tools/measure_plausibility.py --real experiment-i/ --synthetic data/a data/b ...

--real: a PMD experiment I folder (every flat-bed and inclined-bed frame, made model input as
``infer`` makes it); --synthetic: dataset folders made by ``pressurepose generate``. The non-body
images (noise, empty, constant, blocks, a few taxels, the pelvis rows of real images, noise read as
a recording on a mat) are made here with a fixed seed.
"""

from __future__ import annotations

import argparse
from pathlib import Path

import numpy as np


def non_bodies(shape: tuple[int, int], real: np.ndarray | None, seed: int = 0) -> dict[str, np.ndarray]:
    """{name: (N, R, C) mmHg} images that are not a person lying on the mat."""
    rng = np.random.default_rng(seed)
    R, C = shape
    out = {f"uniform noise 0-{hi} mmHg": rng.uniform(0, hi, (20, R, C)) for hi in (10, 20, 100)}
    out["empty mat"] = np.zeros((1, R, C))
    out["constant 10 / 40 mmHg"] = np.stack([np.full((R, C), 10.0), np.full((R, C), 40.0)])
    blocks = []
    for h, w in [(5, 5), (10, 8), (18, 14), (25, 20), (35, 20), (60, 20), (40, C), (R, C)]:
        im = np.zeros((R, C))
        im[(R - h) // 2:(R - h) // 2 + h, (C - w) // 2:(C - w) // 2 + w] = 40.0
        blocks.append(im)
    out["block of 40 mmHg (5x5 to 64x27 taxels)"] = np.stack(blocks)
    few = []
    for k in (1, 3, 5, 10, 20):
        im = np.zeros((R, C))
        im.flat[rng.choice(R * C, k, replace=False)] = 80.0
        few.append(im)
    out["80 mmHg on 1-20 scattered taxels"] = np.stack(few)
    if real is not None:
        sit = np.zeros_like(real[:20])
        sit[:, 28:42] = real[:20, 28:42]
        out["pelvis and thigh rows of real images (sitting)"] = sit
        out["real image plus 0-20 mmHg noise"] = np.clip(real[:20] + rng.uniform(0, 20, real[:20].shape), 0, 100)
    return out


def read_noise(grid, seed: int = 1) -> dict[str, np.ndarray]:
    """{name: (N, R, C) mmHg on ``grid``} uniform noise read as a recording on a mat (raw and
    weight-normalised to 70 kg, or mmHg) and made model input as ``infer --mat`` makes it."""
    from pressurepose.data.readers.recording import read_recording
    from pressurepose.mat import get_mat

    rng = np.random.default_rng(seed)
    out = {}
    for name in ("boditrak_bt3510", "fsa_softflex_2048"):
        shape = get_mat(name).shape
        raw = rng.uniform(0, 1000, (20, *shape)).astype(np.float32)
        out[f"raw noise 0-1000 on {name}, 70 kg"] = read_recording(raw, name, "raw", weight_kg=70).model_input(grid)
        mmhg = rng.uniform(0, 20, (20, *shape)).astype(np.float32)
        out[f"noise 0-20 mmHg on {name}"] = read_recording(mmhg, name, "mmHg").model_input(grid)
    return out


def describe(name: str, images: np.ndarray, grid) -> None:
    from pressurepose.net.plausibility import check_plausible

    verdict = check_plausible(images, grid)
    s = verdict.stats
    cells = [f"{k} {v.min():.3f}-{v.max():.3f}" for k, v in
             (("share", s.loaded_share), ("length_m", s.length_m), ("peak/mean", s.peak_over_mean),
              ("smoothness", s.smoothness))]
    doubts = {}
    for d in verdict.doubt:
        if d is not None:
            doubts[d.name] = doubts.get(d.name, 0) + 1
    print(f"{name}: {len(images)} images; {', '.join(cells)}; flagged {len(verdict.doubtful)} {doubts or ''}")


def main() -> None:
    from pressurepose.data.readers.real import read_real
    from pressurepose.net.infer import load_pressure, resolve_model

    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--real", default=None, help="PMD experiment I folder")
    ap.add_argument("--synthetic", nargs="*", default=[], help="dataset folders from `pressurepose generate`")
    args = ap.parse_args()
    grid = resolve_model().config.grid
    real = None
    if args.real:
        frames = read_real(args.real, frames="all")
        real = frames.model_input(grid)
        flat = frames.posture != "inclined"
        describe("PMD-I flat-bed frames", real[flat], grid)
        describe("PMD-I inclined-bed frames", real[~flat], grid)
        real = real[flat]
    for folder in args.synthetic:
        shards = sorted(Path(folder).rglob("shard-*.h5"))
        describe(f"simulated {folder}", np.concatenate([load_pressure(s) for s in shards]), grid)
    for name, images in {**non_bodies(grid.shape, real), **read_noise(grid)}.items():
        describe(name, images, grid)


if __name__ == "__main__":
    main()
