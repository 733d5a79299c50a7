"""What makes a PressureNet read real wedge-propped people as lying flat? Three diagnostics (issue 14).

    .venv/bin/python -m benchmarks.bench_wedge_cues [--model MODEL] [--data ../shared/data/pmd-experiment-i]
        [--count 24] [--seed 77] [--squeeze 1,0.85,0.75,0.65] [--sim DATASET ...]
        [--out runs/bench_wedge_cues] [--no-write]

1. **The wedge's print.** ``--count`` ``propped_lateral`` bodies per gender, drawn as ``pressurepose
   generate --seed`` draws them, are read twice: as made (the body and the wedge's footing on the
   mat) and with the wedge's load taken off the mat (``Simulated.wedge_force``), so only the body
   prints. If the model found a body's turn from the wedge's footprint (which real PMD-I wedge
   images do not show), it would read the second set as flat. Bodies are kept in OUT, so a rerun
   resumes.
2. **Width across the bed.** The width of the contact (taxels above 5 mmHg) in each region along the
   body, measured as the run of contact through the image's load centroid column, median over the
   region's rows: real PMD-I groups (supine, flat side lying and fetal, 30 and 60 degree wedges)
   against the simulated sets (the propped bodies above, and any ``--sim`` datasets). Arms lying
   against the trunk join its run, so the figure mixes posture with physics.
3. **Squeezing real images across the bed.** The real images as ``evaluate-real`` prepares them,
   squeezed across the bed about their load centroid by each ``--squeeze`` factor (load kept), are
   read again: if width alone set the turn the model reads, narrower real wedge images would read
   as more turned. A diagnostic of the model, not a fix: nothing is trained or tuned on real images.

Replaces the ``bench:wedge-cues`` section of docs/RESULTS.md (``--no-write`` only prints).
"""

from __future__ import annotations

import argparse
import datetime
import platform
from pathlib import Path

import numpy as np
from tqdm import tqdm

from benchmarks.results import write_section

REPO = Path(__file__).resolve().parents[1]
DEFAULT_DATA = REPO.parent / "shared" / "data" / "pmd-experiment-i"
REAL_GROUPS = {
    "supine": lambda d: d.startswith("supine"),
    "side and fetal": lambda d: d.endswith(" side") or "fetal" in d,
    "30 deg wedge": lambda d: "30 deg" in d,
    "60 deg wedge": lambda d: "60 deg" in d,
}


def propped_set(path: Path, gender: str, count: int, seed: int) -> dict:
    """``count`` accepted ``propped_lateral`` bodies of ``gender`` as ``generate --seed`` draws them:
    {'with': (N, R, C) mmHg as made, 'body': (N, R, C) mmHg without the wedge's load, 'pose',
    'joints', 'gender'}; kept in ``path`` (.npz)."""
    if path.is_file():
        with np.load(path) as z:
            return {k: z[k] for k in z.files}
    from pressurepose.data.physics import sampler_config, setup
    from pressurepose.data.producers import attempt_rng
    from pressurepose.data.schema import GenerationConfig
    from pressurepose.files import save_npz_atomic
    from pressurepose.sim.sensor import read_sensor
    from pressurepose.sim.simulate import simulate_one

    config = GenerationConfig(partition="propped_lateral", gender=gender, count=count, seed=seed)
    body, bed = setup(config)
    out = {k: [] for k in ("with", "body", "pose", "joints")}
    for i in tqdm(range(count), desc=f"propped_lateral {gender}", unit="body"):
        for attempt in range(config.max_attempts):
            s = simulate_one(body, bed, config.partition, gender, attempt_rng(config, i, attempt),
                             config.limbs_on_bed, sampler_config(config))
            if not isinstance(s, str):
                break
        else:
            continue
        out["with"].append(s.image.pressure)
        out["body"].append(read_sensor(s.image.force - s.wedge_force, bed))
        out["pose"].append(s.pose)
        out["joints"].append(s.joints)
    arrays = {k: np.asarray(v) for k, v in out.items()} | {"gender": np.array([gender] * len(out["pose"]))}
    path.parent.mkdir(parents=True, exist_ok=True)
    save_npz_atomic(path, **arrays)
    return arrays


def read_propped(net, sets: dict) -> list[dict]:
    """The model's reading of the propped bodies with and without the wedge's print."""
    from pressurepose.eval.posture import posture_of
    from pressurepose.net.infer import estimate
    from pressurepose.pose.posture import roll_angle

    pose = np.concatenate([s["pose"] for s in sets.values()])
    joints = np.concatenate([s["joints"] for s in sets.values()])
    genders = list(np.concatenate([s["gender"] for s in sets.values()]))
    true_roll = np.degrees(np.abs(roll_angle(pose)))
    true_class = posture_of(pose)
    rows = []
    for key, what in (("with", "as made: body and wedge on the mat"), ("body", "the wedge's load taken off the mat")):
        x = np.concatenate([s[key] for s in sets.values()])
        est = estimate(x, genders, model=net)
        roll = np.degrees(np.abs(roll_angle(est.pose)))
        rows.append({"images": what, "n": len(x), "posture": float(np.mean(posture_of(est.pose) == true_class)),
                     "true_roll": float(np.median(true_roll)), "read_roll": float(np.median(roll)),
                     "roll_err": float(np.median(np.abs(roll - true_roll))),
                     "mpjpe_cm": float(100 * np.linalg.norm(est.joints - joints, axis=-1).mean())})
    return rows


def squeeze_across(images: np.ndarray, factor: float) -> np.ndarray:
    """(N, R, C) images squeezed across the bed (columns) about each image's load-centroid column by
    ``factor`` (< 1 narrower), linearly interpolated, each image's total load kept."""
    p = np.asarray(images, dtype=np.float64)
    n_cols = p.shape[2]
    cols = np.arange(n_cols, dtype=np.float64)
    total = p.sum((1, 2))
    axis = (p.sum(1) @ cols) / np.where(total > 0, total, 1.0)  # (N,)
    src = axis[:, None] + (cols[None, :] - axis[:, None]) / factor  # (N, C) source column of each column
    lo = np.floor(src).astype(np.int64)
    w = src - lo

    def take(k):  # (N, R, C): each image's column k[n, c] of every row, 0 beyond the mat
        got = np.take_along_axis(p, np.clip(k, 0, n_cols - 1)[:, None, :].repeat(p.shape[1], 1), 2)
        return np.where(((k >= 0) & (k < n_cols))[:, None, :], got, 0.0)

    inside = ((src >= 0) & (src <= n_cols - 1))[:, None, :]  # as np.interp with zero beyond the ends
    out = np.where(inside, take(lo) * (1 - w)[:, None, :] + take(lo + 1) * w[:, None, :], 0.0)
    now = out.sum((1, 2))
    out *= (total / np.where(now > 0, now, 1.0))[:, None, None]
    out[total <= 0] = 0.0
    return out


def real_inputs(net, folder: Path):
    """PMD-I's images as ``evaluate-real`` reads them with ``net`` (:func:`pressurepose.eval.real.model_inputs`),
    each once per body model: (images (K, R, C), genders (K,), posture labels (K,), details (K,))."""
    from pressurepose.data.readers.real import read_real
    from pressurepose.eval.real import model_inputs

    r, x, idx, genders, _ = model_inputs(read_real(folder), net)
    return x[idx], genders, r.posture[idx], np.asarray(r.detail, dtype=str)[idx]


def read_squeezed(net, x, genders, labels, details, factors) -> list[dict]:
    from pressurepose.eval.posture import posture_correct, posture_of
    from pressurepose.net.infer import estimate
    from pressurepose.pose.posture import roll_angle

    rows = []
    for f in tqdm(factors, desc="squeezed real images", unit="factor"):
        est = estimate(squeeze_across(x, f) if f != 1 else x, genders, model=net)
        ok = posture_correct(labels, posture_of(est.pose))
        roll = np.degrees(np.abs(roll_angle(est.pose)))
        row = {"factor": f, "all": float(ok.mean())}
        for g, keep in REAL_GROUPS.items():
            sel = np.array([keep(d) for d in details])
            row[g] = (float(ok[sel].mean()), float(np.median(roll[sel])))
        rows.append(row)
    return rows


def region_widths(images, mat, floor_mmhg: float = 5.0) -> np.ndarray:
    """(N, 7) cm: per region of :data:`pressurepose.eval.realism.REGIONS` (fractions of the body's
    extent along the bed), the median over its rows of the width of the contact run (taxels above
    ``floor_mmhg``) through the image's load-centroid column (or the nearest contact within 2
    columns of it); NaN where unmeasured."""
    from scipy import ndimage

    from pressurepose.eval import realism as R

    p_all = np.asarray(images, dtype=np.float64)
    ext = R.body_extent(p_all, mat)
    cuts = np.concatenate([[0.0], R.DEFAULT_RULE.bounds, [1.0]])
    out = np.full((len(p_all), len(R.REGIONS)), np.nan)
    n_rows, n_cols = p_all.shape[1:]
    cols, rows = np.arange(n_cols), np.arange(n_rows)
    along_rows = np.array([[0, 0, 0], [1, 1, 1], [0, 0, 0]])  # runs within a row only
    for i, p in enumerate(p_all):
        a, b = ext[i]
        if not np.isfinite(a) or p.sum() <= 0:
            continue
        runs, _ = ndimage.label(p > floor_mmhg, structure=along_rows)
        size = np.bincount(runs.ravel())
        size[0] = 0
        axis = int(round((p.sum(0) @ cols) / p.sum()))
        near = runs[:, np.clip(axis + np.array([0, -1, 1, -2, 2]), 0, n_cols - 1)]  # (R, 5), nearest first
        width = size[near[rows, np.argmax(near > 0, axis=1)]]
        frac = (rows + 0.5 - a) / (b - a)
        for k in range(len(R.REGIONS)):
            sel = (frac >= cuts[k]) & (frac < cuts[k + 1])
            if sel.any():
                out[i, k] = np.median(width[sel]) * mat.pitch_col_m * 100
    return out


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--model", default=None, help="model to read with (default: the shipped one)")
    ap.add_argument("--data", type=Path, default=DEFAULT_DATA, help="PMD experiment I folder")
    ap.add_argument("--count", type=int, default=24, help="propped bodies per gender [24]")
    ap.add_argument("--seed", type=int, default=77, help="their seed [77]")
    ap.add_argument("--squeeze", default="1,0.85,0.75,0.65", help="squeeze factors across the bed")
    ap.add_argument("--sim", type=Path, nargs="*", default=[], help="more simulated datasets for the width table")
    ap.add_argument("--out", type=Path, default=REPO / "runs" / "bench_wedge_cues")
    ap.add_argument("--no-write", action="store_true", help="print only; leave docs/RESULTS.md alone")
    args = ap.parse_args(argv)
    from pressurepose.eval import realism as R
    from pressurepose.eval.realism_report import load_synthetic
    from pressurepose.mat import MatSpec
    from pressurepose.net.infer import resolve_model

    factors = [float(v) for v in args.squeeze.split(",")]
    net = resolve_model(args.model)
    sets = {g: propped_set(args.out / f"propped_{g}_{args.count}_{args.seed}.npz", g, args.count, args.seed)
            for g in ("f", "m")}
    prop = read_propped(net, sets)
    x, genders, labels, details = real_inputs(net, args.data)
    sq = read_squeezed(net, x, genders, labels, details, factors)
    grid = net.config.grid
    mat = MatSpec("model", *grid.shape, grid.pitch_row_m, grid.pitch_col_m)
    widths = []
    once = np.arange(0, len(x), 2)  # each real image once
    for g, keep in REAL_GROUPS.items():
        sel = once[np.array([keep(details[i]) for i in once])]
        widths.append((f"real, {g}", len(sel), np.nanmedian(region_widths(x[sel], mat), 0)))
    for key, what in (("with", "as made"), ("body", "without the wedge's load")):
        imgs = np.concatenate([s[key] for s in sets.values()])
        widths.append((f"simulated propped_lateral, {what}", len(imgs), np.nanmedian(region_widths(imgs, mat), 0)))
    for path in args.sim:
        s = load_synthetic(path)
        widths.append((f"simulated {path.name}", len(s.pressure), np.nanmedian(region_widths(s.pressure, mat), 0)))

    lines = [f"## Wedge postures: what the model reads a turn from (`benchmarks/bench_wedge_cues.py`)", "",
             f"{datetime.date.today()}, {platform.platform()}, model: {args.model or 'the shipped one'}; "
             f"{args.count} `propped_lateral` bodies per gender, seed {args.seed} (default physics, nominal bed). "
             "Reproduce: `python -m benchmarks.bench_wedge_cues" + (" --sim DATASET ...`, the `--sim` sets being "
             + ", ".join(p.name for p in args.sim) + " of a training set made by `tools/train_shipped_model.py`."
             if args.sim else "`."),
             "", "**1. The wedge's print.** The same bodies read with the wedge's load on the mat and without it:", "",
             "| images | n | posture acc. | true roll, median (deg) | read roll, median (deg) | roll error, median (deg) | MPJPE (cm) |",
             "|---|---|---|---|---|---|---|"]
    for r in prop:
        lines.append(f"| {r['images']} | {r['n']} | {r['posture']:.2f} | {r['true_roll']:.0f} | {r['read_roll']:.0f} | "
                     f"{r['roll_err']:.0f} | {r['mpjpe_cm']:.2f} |")
    lines += ["", "**2. Contact width across the bed** (cm; the run of contact above 5 mmHg through the load-centroid "
              "column, median over each region's rows; arms lying against the trunk join the run):", "",
              "| images | n | " + " | ".join(R.REGIONS) + " |", "|---|---|" + "---|" * len(R.REGIONS)]
    for name, n, w in widths:
        lines.append(f"| {name} | {n} | " + " | ".join("-" if not np.isfinite(v) else f"{v:.0f}" for v in w) + " |")
    lines += ["", "**3. Real images squeezed across the bed** (load kept; posture accuracy, and the median "
              "|roll| read in degrees; every image with both body models):", "",
              "| squeeze | all | " + " | ".join(REAL_GROUPS) + " |", "|---|---|" + "---|" * len(REAL_GROUPS)]
    for r in sq:
        lines.append(f"| {r['factor']:.2f} | {r['all']:.3f} | "
                     + " | ".join(f"{r[g][0]:.2f} ({r[g][1]:.0f})" for g in REAL_GROUPS) + " |")
    text = "\n".join(lines)
    print(text)
    if not args.no_write:
        write_section("wedge-cues", text)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
