"""Body speed: torch forward pass at batch 128 on CPU, and the per-sample capsule computation.

    python -m benchmarks.bench_body [--threads 1] [--repeats 5]

Prints the figures and replaces the ``bench:body`` section of docs/RESULTS.md.
"""

from __future__ import annotations

import argparse
import datetime
import os
import platform
import time

import numpy as np
import torch

from benchmarks.common import machine
from benchmarks.results import write_section
from pressurepose.body import BodyModel
from pressurepose.body.capsules import (
    capsules_for,
    fit_capsules,
    point_capsule_distance,
    posed_capsules,
)
from pressurepose.body.masses import PAPER_VOXEL, RUNTIME_VOXEL, segment_masses
from pressurepose.body.model import asset_path
from pressurepose.body.toy import toy_body_arrays


def best_time(fn, repeats: int) -> float:
    """Best wall time (s) of ``repeats`` calls after one warm-up call."""
    fn()
    times = []
    for _ in range(repeats):
        t0 = time.perf_counter()
        fn()
        times.append(time.perf_counter() - t0)
    return min(times)


def bench_forward(body, batch: int, repeats: int) -> dict[str, float]:
    rng = np.random.default_rng(0)
    out = {}
    for dtype in (torch.float32, torch.float64):
        layer = body.torch_layer(dtype=dtype)
        betas = torch.as_tensor(rng.normal(0, 1, (batch, 10)), dtype=dtype)
        pose = torch.as_tensor(rng.normal(0, 0.3, (batch, 72)), dtype=dtype)
        transl = torch.zeros(batch, 3, dtype=dtype)

        def run():
            with torch.no_grad():
                layer(betas=betas, global_orient=pose[:, :3], body_pose=pose[:, 3:], transl=transl)

        def run_grad():
            p = pose.clone().requires_grad_(True)
            o = layer(betas=betas, global_orient=p[:, :3], body_pose=p[:, 3:], transl=transl)
            o.vertices.sum().backward()

        name = str(dtype).split(".")[-1]
        out[f"forward {name}"] = best_time(run, repeats)
        out[f"forward+backward {name}"] = best_time(run_grad, repeats)
    return out


def bench_capsules(body, repeats: int) -> tuple[dict[str, float], dict[str, float]]:
    """Per-sample times (s) of the capsule steps, and the largest relative change of any capsule
    mass against the paper's 2 mm grid over a few random shapes."""
    rng = np.random.default_rng(1)
    betas = rng.uniform(-2, 2, 10)
    pose = rng.normal(0, 0.3, (1, 72))
    caps = capsules_for(body, betas)
    out = {
        "capsules_for (regressors)": best_time(lambda: capsules_for(body, betas), repeats),
        "fit_capsules (direct fit)": best_time(lambda: fit_capsules(body, betas), repeats),
        "posed_capsules (1 pose)": best_time(lambda: posed_capsules(body, caps, betas, pose), repeats),
    }
    for voxel in (PAPER_VOXEL, 0.003, RUNTIME_VOXEL):
        out[f"segment_masses, {voxel * 1000:.0f} mm voxels"] = best_time(
            lambda: segment_masses(body, betas, caps=caps, voxel=voxel), repeats)
    errs = {"3 mm": 0.0, "5 mm": 0.0, "8 mm": 0.0}
    for b in rng.uniform(-3, 3, (4, 10)):
        c = capsules_for(body, b)
        ref = segment_masses(body, b, caps=c, voxel=PAPER_VOXEL).mass
        for key in errs:
            m = segment_masses(body, b, caps=c, voxel=float(key.split()[0]) / 1000).mass
            errs[key] = max(errs[key], float(np.max(np.abs(m - ref) / ref)))
    return out, errs


def fit_quality(body, num: int = 10) -> dict[str, float]:
    """Regressed vs direct capsules and mesh coverage over betas ~ U(-3, 3)."""
    rng = np.random.default_rng(2)
    q = {"max length error (mm)": 0.0, "max radius error (mm)": 0.0, "min share of vertices within 3 cm": 1.0}
    for b in rng.uniform(-3, 3, (num, 10)):
        direct, fast = fit_capsules(body, b), capsules_for(body, b)
        q["max length error (mm)"] = max(q["max length error (mm)"], 1e3 * np.abs(fast.length - direct.length).max())
        q["max radius error (mm)"] = max(q["max radius error (mm)"], 1e3 * np.abs(fast.radius - direct.radius).max())
        verts, _ = body.rest(b[None])
        ends, radius = posed_capsules(body, fast, b, np.zeros((1, 72)))
        outside = np.maximum(point_capsule_distance(verts[0], ends[0]) - radius, 0.0).min(1)
        q["min share of vertices within 3 cm"] = min(q["min share of vertices within 3 cm"],
                                                     float(np.mean(outside <= 0.03)))
    return q




def main(argv=None) -> int:
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    p.add_argument("--threads", type=int, default=1, help="torch CPU threads (default 1)")
    p.add_argument("--repeats", type=int, default=5, help="timed repeats; the best is reported (default 5)")
    p.add_argument("--batch", type=int, default=128, help="forward-pass batch size (default 128)")
    p.add_argument("--no-write", action="store_true", help="print only; leave docs/RESULTS.md alone")
    args = p.parse_args(argv)
    torch.set_num_threads(args.threads)
    has_model = asset_path("female.npz").is_file()
    if has_model:
        body, label = BodyModel("female"), "shipped female model"
    else:
        body, label = BodyModel(toy_body_arrays()), "toy body (shipped models not baked yet)"
    fwd = bench_forward(body, args.batch, args.repeats)
    caps, errs = bench_capsules(body, args.repeats)
    lines = [
        "## Body model speed (`benchmarks/bench_body.py`)",
        "",
        f"`python -m benchmarks.bench_body`; {datetime.date.today().isoformat()}, {machine()}, "
        f"{platform.processor() or platform.machine()}, {os.cpu_count()} CPUs, torch {torch.__version__} with {args.threads} thread(s); {label}, "
        f"{body.num_vertices} vertices. Best of {args.repeats}.",
        "",
        f"| torch body layer, batch {args.batch}, CPU | ms per batch | ms per body |",
        "|---|---|---|",
        *[f"| {k} | {v * 1e3:.1f} | {v * 1e3 / args.batch:.3f} |" for k, v in fwd.items()],
        "",
        "| capsules, one sample (numpy) | ms |",
        "|---|---|",
        *[f"| {k} | {v * 1e3:.2f} |" for k, v in caps.items()],
        "",
        "Largest relative change of any capsule mass against the paper's 2 mm voxels (4 shapes, betas in "
        "[-3, 3]): " + ", ".join(f"{k} {v * 100:.2f} %" for k, v in errs.items())
        + f"; `segment_masses` uses {RUNTIME_VOXEL * 1000:.0f} mm by default.",
    ]
    if has_model:
        lines += ["", "Capsule regressors against the direct fit, and coverage of the rest mesh by the regressed "
                  "capsules (10 shapes, betas ~ U(-3, 3)):",
                  "; ".join(f"{k} {v:.3g}" for k, v in fit_quality(body).items()) + "."]
    text = "\n".join(lines)
    print(text)
    if not args.no_write:
        write_section("body", text)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
