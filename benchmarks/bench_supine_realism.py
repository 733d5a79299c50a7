"""How real simulated supine images look: contact area, head imprint, load off the mat, pressures.

    .venv/bin/python -m benchmarks.bench_supine_realism [--bodies 30] [--seed 7] [--label now]
        [--json out.json] [--write]

Simulates ``--bodies`` accepted ``general_supine`` bodies per gender (female, male) with the
project's defaults (``simulate_one``; attempt ``i`` uses ``body_rng(seed, i)``) and measures on the
BodiTrak image: contact area (taxels > 5 mmHg; real BodiTrak supine median about 420, issue 12),
head imprint (a taxel > 5 mmHg within 0.1 m of the head joint on the crown's side of the neck
joint; real 99 %), load off the mat (1 - mat force / m g), mean pressure over the contact and the
peak; and the CPU seconds of settle and press per accepted body. ``--write`` replaces the
``bench:supine_realism`` section of docs/RESULTS.md with the table of every ``--json`` given
by ``--table`` (before/after runs).
"""

from __future__ import annotations

import argparse
import datetime
import json
import os
import platform
import time

import numpy as np

CONTACT_MMHG = 5.0
HEAD_RADIUS_M = 0.10
HEAD, NECK = 15, 12


def head_imprint(pressure: np.ndarray, joints: np.ndarray, bed) -> bool:
    """A taxel over CONTACT_MMHG within HEAD_RADIUS_M (xy) of the head joint, crown side of the neck."""
    xy = bed.taxel_centers()
    up = joints[HEAD, :2] - joints[NECK, :2]
    up = up / max(np.linalg.norm(up), 1e-9)
    near = np.linalg.norm(xy - joints[HEAD, :2], axis=-1) < HEAD_RADIUS_M
    crown = (xy - joints[NECK, :2]) @ up > 0
    return bool(np.any((pressure > CONTACT_MMHG) & near & crown))


def image_stats(sim, bed) -> dict:
    p = sim.image.pressure
    on = p > CONTACT_MMHG
    weight = sim.mass * 9.81
    return {"contact_taxels": int(on.sum()), "head_imprint": head_imprint(p, sim.joints, bed),
            "off_mat": float(1.0 - sim.image.force.sum() / weight),
            "mean_mmhg": float(p[on].mean()) if on.any() else 0.0, "peak_mmhg": float(p.max())}


def run(bodies: int, seed: int, partition: str = "general_supine", **simulate_kw) -> dict:
    import sys

    import pressurepose.sim.press  # noqa: F401  (the package exports a function of the same name)
    import pressurepose.sim.settle  # noqa: F401
    from pressurepose.body import BodyModel
    from pressurepose.pose.sampler import body_rng
    from pressurepose.sim import get_bed
    from pressurepose.sim.simulate import simulate_one

    press_mod, settle_mod = sys.modules["pressurepose.sim.press"], sys.modules["pressurepose.sim.settle"]
    bed = get_bed()
    cpu = {"settle": 0.0, "press": 0.0}

    def timed(name, fn):
        def wrapper(*a, **k):
            t0 = time.process_time()
            try:
                return fn(*a, **k)
            finally:
                cpu[name] += time.process_time() - t0
        return wrapper

    orig = settle_mod.settle, press_mod.press
    settle_mod.settle, press_mod.press = timed("settle", orig[0]), timed("press", orig[1])
    rows, causes = [], {}
    try:
        for gender in ("female", "male"):
            body = BodyModel(gender)
            got, i = 0, 0
            while got < bodies and i < 4 * bodies:
                out = simulate_one(body, bed, partition, gender, body_rng(seed, i), **simulate_kw)
                i += 1
                if isinstance(out, str):
                    causes[out] = causes.get(out, 0) + 1
                    continue
                got += 1
                bmi = out.mass / out.height**2
                rows.append(dict(image_stats(out, bed), gender=gender, mass=out.mass, height=out.height, bmi=bmi))
    finally:
        settle_mod.settle, press_mod.press = orig
    n = len(rows)
    col = {k: np.array([r[k] for r in rows], dtype=float) for k in rows[0] if k != "gender"}
    return {"bodies": n, "rejected": causes, "partition": partition, "seed": seed,
            "contact_taxels_median": float(np.median(col["contact_taxels"])),
            "head_imprint_rate": float(col["head_imprint"].mean()),
            "off_mat_median": float(np.median(col["off_mat"])),
            "mean_mmhg_median": float(np.median(col["mean_mmhg"])),
            "peak_mmhg_median": float(np.median(col["peak_mmhg"])),
            "bmi_extreme_share": float(np.mean((col["bmi"] < 17) | (col["bmi"] > 35))),
            "settle_cpu_s_per_accepted": cpu["settle"] / n, "press_cpu_s_per_accepted": cpu["press"] / n,
            "rows": rows}


TABLE_KEYS = [("contact_taxels_median", "contact area, median taxels > 5 mmHg (real ~420)", "{:.0f}"),
              ("head_imprint_rate", "head imprint rate (real 0.99)", "{:.2f}"),
              ("off_mat_median", "load off the mat, median share", "{:.3f}"),
              ("mean_mmhg_median", "mean contact pressure, median, mmHg", "{:.1f}"),
              ("peak_mmhg_median", "peak pressure, median, mmHg", "{:.1f}"),
              ("bmi_extreme_share", "bodies with BMI < 17 or > 35", "{:.2f}"),
              ("settle_cpu_s_per_accepted", "settle CPU s per accepted body", "{:.2f}"),
              ("press_cpu_s_per_accepted", "press CPU s per accepted body", "{:.3f}")]


def table(results: list[tuple[str, dict]]) -> str:
    head = "| measure | " + " | ".join(label for label, _ in results) + " |"
    lines = [head, "|---" * (len(results) + 1) + "|"]
    for key, name, fmt in TABLE_KEYS:
        lines.append(f"| {name} | " + " | ".join(fmt.format(r[key]) for _, r in results) + " |")
    lines.append("| accepted bodies (rejected) | " + " | ".join(
        f"{r['bodies']} ({sum(r['rejected'].values())})" for _, r in results) + " |")
    return "\n".join(lines)


def main(argv=None) -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--bodies", type=int, default=30)
    ap.add_argument("--seed", type=int, default=7)
    ap.add_argument("--json", help="write this run's figures here")
    ap.add_argument("--table", nargs="*", default=[], help="LABEL=FILE.json runs to tabulate")
    ap.add_argument("--write", action="store_true", help="write the table to docs/RESULTS.md")
    args = ap.parse_args(argv)
    if args.table:
        runs = [(s.split("=", 1)[0], json.load(open(s.split("=", 1)[1]))) for s in args.table]
        text = table(runs)
        print(text)
        if args.write:
            from benchmarks.results import write_section

            n = runs[0][1]
            write_section("supine_realism", f"### Supine realism (issue 12): simulated `{n['partition']}` "
                          f"bodies, {n['bodies']} per run, both genders, seed {n['seed']}\n\n"
                          f"`python -m benchmarks.bench_supine_realism`; {platform.processor() or platform.machine()}, "
                          f"{os.cpu_count()} CPUs, {datetime.date.today()}.\n\n{text}\n")
        return
    res = run(args.bodies, args.seed)
    print(json.dumps({k: v for k, v in res.items() if k != "rows"}, indent=1))
    if args.json:
        from pressurepose.files import write_json_atomic

        write_json_atomic(args.json, res)


if __name__ == "__main__":
    main()
