"""Press speed: physics simulation #2 (mesh on the foundation, sensor read-out) per body.

    python -m benchmarks.bench_press [--bodies 6] [--repeats 3] [--no-write]

Bodies: the shipped female model (supine and prone, arms toward the sides, mean and random shapes)
when it is baked, else a body-sized stand-in built from trimesh capsules. Prints the figures and
replaces the ``bench:press`` section of docs/RESULTS.md.
"""

from __future__ import annotations

import argparse
import datetime
import os
import platform
import time

import numpy as np

from benchmarks.common import machine
from benchmarks.results import write_section
from pressurepose.sim import PressFailed, get_bed, press
from pressurepose.sim.press import body_heightfield


def stand_in_body(bed):
    """About 5,500 vertices: flattened torso capsule, head, two legs, two arms (supine)."""
    import trimesh

    def capsule(p0, p1, r, count):
        p0, p1 = np.asarray(p0, float), np.asarray(p1, float)
        c = trimesh.creation.capsule(height=np.linalg.norm(p1 - p0), radius=r, count=[count, count])
        c.apply_translation(-(c.vertices.max(0) + c.vertices.min(0)) / 2)
        c.apply_transform(trimesh.geometry.align_vectors([0, 0, 1], (p1 - p0) / np.linalg.norm(p1 - p0)))
        return c.apply_translation((p0 + p1) / 2)

    torso = capsule([0, 0, 0], [0, 0.55, 0], 0.16, 40)
    torso.vertices[:, 2] *= 0.65
    parts = [torso, trimesh.creation.icosphere(3, 0.1).apply_translation([0, -0.28, 0])]
    for s in (-1, 1):
        parts.append(capsule([s * 0.1, 0.65, 0], [s * 0.11, 1.5, 0], 0.075, 32))
        parts.append(capsule([s * 0.2, 0.02, 0], [s * 0.26, 0.6, 0], 0.045, 24))
    m = trimesh.util.concatenate(parts)
    v = m.vertices - (m.vertices.max(0) + m.vertices.min(0)) / 2
    v += [bed.mat.width_m / 2, bed.mat.length_m / 2, 0]
    v[:, 2] -= v[:, 2].min()
    return [("stand-in, supine", v, np.asarray(m.faces), 62.5)]


def model_bodies(bed, count: int):
    """The shipped female model lying supine and prone (alternately), the first two of mean shape,
    the rest with random shapes and small random limb angles. (A rigid body rolled part-way onto its
    side has no equilibrium: it rolls back, which the press reports as a tip-over.)"""
    from pressurepose.body import BodyModel
    from pressurepose.calibrate.objects import supine_body_mesh

    body = BodyModel("female")
    rng = np.random.default_rng(0)
    out = []
    rolls = {"supine": 0.0, "prone": np.pi}
    for i in range(count):
        name = list(rolls)[i % 2]
        betas = rng.uniform(-2, 2, body.num_betas) if i >= 2 else np.zeros(body.num_betas)
        limbs = rng.normal(0, 0.1, 3 * body.num_joints) if i >= 2 else None
        v, f, _ = supine_body_mesh(body, bed, betas, pose_offset=limbs)
        c, s = np.cos(rolls[name]), np.sin(rolls[name])
        centre = (v.max(0) + v.min(0)) / 2
        v = (v - centre) @ np.array([[c, 0, s], [0, 1, 0], [-s, 0, c]]).T + centre  # roll about the bed's axis
        v[:, 2] -= v[:, 2].min()
        mass = float(body.mass(betas)[0])
        out.append((f"female, {name}, {'mean shape' if i < 2 else 'random shape and limbs'}", v, f, mass))
    return out, f"{body!r}"


def time_press(v, f, mass, bed, repeats):
    times, res = [], None
    for _ in range(repeats):
        t0 = time.perf_counter()
        res = press(v, f, mass, bed)
        times.append(time.perf_counter() - t0)
    return min(times), res


def main(argv=None) -> int:
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    p.add_argument("--bodies", type=int, default=6, help="bodies to press (model only) [6]")
    p.add_argument("--repeats", type=int, default=3, help="timed repeats per press; the best is kept [3]")
    p.add_argument("--no-write", action="store_true", help="print only; leave docs/RESULTS.md alone")
    args = p.parse_args(argv)

    load = os.getloadavg()[0]
    bed = get_bed()
    try:
        bodies, label = model_bodies(bed, args.bodies)
    except Exception as exc:  # the shipped model is not baked yet
        bodies, label = stand_in_body(bed), f"stand-in body (no shipped model: {type(exc).__name__})"
    configs = [("boditrak_bt3510, default constants", bed),
               ("boditrak_bt3510, Winkler only (G = 0)", get_bed(coupling_n_m=0.0)),
               ("boditrak_bt3510, 1.43 cm cells", get_bed(press_cell_m=0.0143)),
               ("slp (1 cm taxels)", get_bed("slp")),
               ("tip (31.1 x 19.5 mm)", get_bed("tip"))]
    rows, failures = [], 0
    for cname, b in configs:
        times, iters, passes_ok = [], [], 0
        raster = []
        for name, v, f, mass in bodies:
            try:
                t, res = time_press(v, f, mass, b, args.repeats)
            except PressFailed as exc:
                failures += 1
                print(f"{cname}: {name}: {exc}")
                continue
            t0 = time.perf_counter()
            body_heightfield(v, f, b)
            raster.append(time.perf_counter() - t0)
            times.append(t)
            iters.append(res.iterations)
            passes_ok += 1
            print(f"{cname}: {name}: {t * 1e3:.1f} ms, {res.iterations} iterations, sink {100 * res.sink_m:.1f} cm, "
                  f"peak {res.pressure.max():.1f} mmHg, tilt {np.degrees(np.abs(res.tilt_rad)).max():.2f} deg")
        if times:
            rows.append(f"| {cname} | {passes_ok} | {1e3 * np.median(times):.0f} | {1e3 * max(times):.0f} | "
                        f"{1e3 * np.median(raster):.0f} | {np.median(iters):.0f} |")
    nverts = len(bodies[0][1])
    lines = [
        "## Press speed (`benchmarks/bench_press.py`)",
        "",
        f"`python -m benchmarks.bench_press`; {datetime.date.today().isoformat()}, {machine()}, "
        f"{platform.processor() or platform.machine()}, {os.cpu_count()} CPUs (one used; load average {load:.1f} at the start); "
        f"{label}, {nverts} vertices. Time per press: the best of "
        f"{args.repeats} runs of `press()` (raster, contact solve, sensor), then the median and worst over bodies.",
        "",
        "| bed | bodies pressed | median ms | worst ms | of which raster, ms | solver iterations |",
        "|---|---|---|---|---|---|",
        *rows,
        "",
        f"{failures} presses found no equilibrium (PressFailed).",
    ]
    text = "\n".join(lines)
    print(text)
    if not args.no_write:
        write_section("press", text)
    return 0




if __name__ == "__main__":
    raise SystemExit(main())
