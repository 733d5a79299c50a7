"""Pressure per body site from PressureNet's estimate against the simulator's truth, and the speed of
a night of monitoring.

    python -m benchmarks.bench_sites [--count 5] [--data DIR] [--model MODEL] [--night-hours 8]
                                     [--out runs/bench_sites] [--no-write]

1. generates ``--count`` samples per gender of every partition (seed 1420, which no other run of
   the project uses) into OUT/data, or takes the datasets under ``--data`` (made with the body sites
   recorded); the simulator says which body site carried each taxel's force (``Sample.sites``);
2. estimates every image with the model (the shipped one unless ``--model``) and splits its load
   over the body sites of the estimated body (``Estimate.sites``);
3. compares, per image, each site's share of the load and its peak pressure with the truth: the
   mean absolute share error over the 16 sites, the same over the sites that carry at least 5 % of
   the load in the truth or the estimate, the peak error of the sites loaded in the truth, and
   whether the most loaded site is named right (of all sites, and of the named sites: 'other' left
   out; and whether the named site the estimate loads most carries, in the truth, within 5 pp of the
   truly most loaded one's share);
4. with ``--night-hours H`` (default 8; 0 skips), times ``pressurepose.eval.monitor.monitor`` on one
   core over H hours of 1 Hz frames made from one image of each posture of the set (4 % noise,
   breathing, a 12 s roll per turn, a turn every 1-1.5 h);

and replaces the ``bench:sites`` section of docs/RESULTS.md. Goals: shares within 5 percentage
points of the truth on average; the most loaded site right in at least 90 % of images; a night
(28,800 frames) in under 10 minutes on one core.
"""

from __future__ import annotations

import argparse
import os
import time
from pathlib import Path

import numpy as np

from benchmarks.common import run_cli, stamp
from benchmarks.results import write_section
from pressurepose.cli import main as cli

SEED = 1420
LOADED = 0.05  # a site carrying this share of the load, in the truth or the estimate, counts as loaded
CLOSE = 0.05  # a named site carrying within this share of the truly most loaded one's is a near miss
SHARE_GOAL_PP, TOP_GOAL, NIGHT_GOAL_S = 5.0, 0.90, 600.0


def _cli(*args: str) -> None:
    if cli(list(args)) != 0:
        raise SystemExit(f"pressurepose {' '.join(args)} failed")


def held_out(out: Path, count: int) -> Path:
    """Generate ``count`` samples per gender of every partition into ``out`` (kept when there)."""
    from pressurepose.data.schema import PARTITIONS

    for part in PARTITIONS:
        for gender in "fm":
            where = out / part / gender
            if not (where / "manifest.json").is_file():
                _cli("generate", "--partition", part, "--gender", gender, "--count", str(count), "--seed", str(SEED),
                     "--shard-size", str(count), "--workers", "1", "--no-progress", "--out", str(where))
    return out


def read_samples(root: Path) -> dict:
    """pressure (N, R, C), sites (N, R, C), gender (N,), partition (N,) of every sample under ``root``."""
    from pressurepose.net.sitenet_train import sited_samples

    samples = sited_samples(root)
    return {"pressure": np.stack([s.pressure for s in samples]).astype(np.float32),
            "sites": np.stack([s.sites for s in samples]).astype(np.int8),
            "gender": np.array([s.gender for s in samples]), "partition": np.array([s.partition for s in samples]),
            "pose": np.stack([s.pose for s in samples])}


def compare(data: dict, model, fit: bool = False, site_net: bool = True) -> dict:
    """Per-image errors of the estimated site loads against the simulator's (arrays over images);
    fit: the estimates fitted to their prints (``estimate(..., fit=True)``, ``--fit``); site_net:
    False reads each taxel's site from the estimated body alone (``estimate(..., site_net=None)``)."""
    from pressurepose.body.sites import NO_SITE, OTHER, site_stats
    from pressurepose.net.infer import estimate

    p = data["pressure"]
    est = estimate(p, list(data["gender"]), model=model, fit=fit, site_net="auto" if site_net else None)
    truth = site_stats(p, np.where(p > 0, data["sites"], NO_SITE), est.grid)
    e, t = est.sites, truth
    diff = np.abs(e.share - t.share)
    loaded = (t.share >= LOADED) | (e.share >= LOADED)
    named = np.arange(e.share.shape[1]) != OTHER
    peak_err = np.where(t.share >= LOADED, np.abs(e.peak_mmhg - t.peak_mmhg), np.nan)
    return {"share_mae_pp": 100 * diff.mean(1),
            "loaded_mae_pp": 100 * np.array([d[m].mean() for d, m in zip(diff, loaded)]),
            "peak_mae_mmhg": np.nanmean(peak_err, axis=1),
            "top_right": e.share.argmax(1) == t.share.argmax(1),
            "named_top_right": (e.share * named).argmax(1) == (t.share * named).argmax(1),
            "named_top_close": (t.share * named).max(1) - t.share[np.arange(len(p)), (e.share * named).argmax(1)]
            <= CLOSE,
            "truth_top": t.share.argmax(1), "estimate": est}


def night_frames(data: dict, hours: float, seed: int = 0) -> tuple[np.ndarray, int]:
    """(T, R, C) mmHg at 1 Hz over ``hours``: one image of each posture of the set in turn, a posture
    held 1 to 1.5 h, 4 % noise per taxel, +-2 % breathing over the trunk, a 12 s roll per turn
    (the two images blended); and the number of turns."""
    from pressurepose.eval.posture import posture_of

    rng = np.random.default_rng(seed)
    postures = posture_of(data["pose"])
    images = [data["pressure"][np.flatnonzero(postures == c)[0]].astype(np.float64)
              for c in ("supine", "left", "supine", "right", "prone") if (postures == c).any()]
    total = int(hours * 3600)
    frames = np.empty((total, *data["pressure"].shape[1:]), np.float32)
    breath = np.zeros(frames.shape[1:])
    breath[10:35] = 1.0
    t, k, turns = 0, 0, 0
    while t < total:
        img, held = images[k % len(images)], int(rng.uniform(3600, 5400))
        if t:
            prev = images[(k - 1) % len(images)]
            for j in range(min(12, total - t)):
                frames[t] = prev + (j + 1) / 13 * (img - prev)
                t += 1
            turns += 1
        for _ in range(min(held, total - t)):
            frames[t] = img * (1 + 0.02 * np.sin(np.pi * t / 2) * breath) * rng.uniform(0.96, 1.04, img.shape)
            t += 1
        k += 1
    return np.clip(frames, 0, 100), turns


def time_night(data: dict, hours: float, model, out: Path, model_arg: str | None) -> dict:
    """Monitor ``hours`` of synthetic 1 Hz frames: in this process on one thread (seconds, frames,
    estimated, turns, found), then with the ``monitor`` verb end to end (``verb``: CPU and wall s)."""
    import torch

    from pressurepose.eval.monitor import frame_times, monitor

    torch.set_num_threads(1)
    frames, turns = night_frames(data, hours)
    t0 = time.perf_counter()
    tl = monitor(frames, frame_times(len(frames), fps=1.0), "f", model, progress=False)
    seconds = time.perf_counter() - t0
    out.mkdir(parents=True, exist_ok=True)
    np.save(out / "night.npy", frames)
    verb = run_cli(["monitor", str(out / "night.npy"), "--mat", "boditrak_bt3510", "--units", "mmHg", "--gender", "f",
                    "--fps", "1", "--out", str(out / "night"), *(["--model", model_arg] if model_arg else [])])
    return {"seconds": seconds, "frames": len(frames), "estimated": int(tl.estimated.sum()), "turns": turns,
            "found": len(tl.turns), "verb": verb}


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--count", type=int, default=5, help="samples per gender and partition to generate (default 5)")
    ap.add_argument("--data", type=Path, default=None, help="datasets to read instead of generating them")
    ap.add_argument("--model", default=None, help="model to read the images with [the shipped one]")
    ap.add_argument("--night-hours", type=float, default=8.0, help="hours of 1 Hz frames to monitor (0: skip)")
    ap.add_argument("--out", type=Path, default=Path("runs/bench_sites"))
    ap.add_argument("--no-write", action="store_true", help="print only; leave docs/RESULTS.md alone")
    args = ap.parse_args(argv)
    os.environ.setdefault("OMP_NUM_THREADS", "1")
    from pressurepose.body.sites import SITES
    from pressurepose.net.infer import resolve_model

    root = args.data if args.data is not None else held_out(args.out / "data", args.count)
    data = read_samples(root)
    model = resolve_model(args.model)
    r = compare(data, model)
    parts = sorted(set(data["partition"].tolist()))
    rows = ["| partition | images | share error, all sites (pp) | share error, loaded sites (pp) | "
            "peak error, loaded sites (mmHg) | most loaded site right | most loaded named site right | "
            "... or within 5 pp of it |",
            "|---|---|---|---|---|---|---|---|"]
    for name, m in [*[(f"`{p}`", data["partition"] == p) for p in parts], ("**all**", np.ones(len(data["gender"]), bool))]:
        rows.append(f"| {name} | {int(m.sum())} | {r['share_mae_pp'][m].mean():.2f} | {r['loaded_mae_pp'][m].mean():.1f} | "
                    f"{np.nanmean(r['peak_mae_mmhg'][m]):.1f} | {r['top_right'][m].mean():.2f} | "
                    f"{r['named_top_right'][m].mean():.2f} | {r['named_top_close'][m].mean():.2f} |")
    b = compare(data, model, site_net=False)
    rows.append(f"| all, each taxel the site of the estimated body over it (no site network) | {len(data['gender'])} | "
                f"{b['share_mae_pp'].mean():.2f} | {b['loaded_mae_pp'].mean():.1f} | {np.nanmean(b['peak_mae_mmhg']):.1f} | "
                f"{b['top_right'].mean():.2f} | {b['named_top_right'].mean():.2f} | {b['named_top_close'].mean():.2f} |")
    f = compare(data, model, fit=True)
    rows.append(f"| all, the estimates fitted to their prints (`--fit`) | {len(data['gender'])} | "
                f"{f['share_mae_pp'].mean():.2f} | {f['loaded_mae_pp'].mean():.1f} | {np.nanmean(f['peak_mae_mmhg']):.1f} | "
                f"{f['top_right'].mean():.2f} | {f['named_top_right'].mean():.2f} | {f['named_top_close'].mean():.2f} |")
    share, top, named_top = r["share_mae_pp"].mean(), r["top_right"].mean(), r["named_top_right"].mean()
    tops = {SITES[k]: int((r["truth_top"] == k).sum()) for k in np.unique(r["truth_top"])}
    source = (f"`--data {args.data}`" if args.data is not None else
              f"{args.count} samples per gender of each of the {len(parts)} partitions, freshly generated (seed {SEED})")
    command = "python -m benchmarks.bench_sites" + (f" --count {args.count}" if args.count != 5 else "") \
        + (" --data DIR" if args.data is not None else "") + (f" --model {args.model}" if args.model else "") \
        + (f" --night-hours {args.night_hours:g}" if args.night_hours != 8 else "")
    lines = [
        "## Pressure per body site (`benchmarks/bench_sites.py`)", "",
        f"`{command}`; {stamp()}; " + ("the shipped model" if args.model is None else f"model `{args.model}`")
        + f"; {len(data['gender'])} simulated images: {source}. The truth is the body site that carried each "
        "taxel's force in the press (`Sample.sites`); the estimate splits each image over the sites the site "
        "network reads from the image and the estimated body's site map (`pressurepose.net.sitenet`, trained on "
        "other simulated data: `tools/train_site_net.py`). Share errors in percentage points "
        f"(pp) of the image's load, averaged over images; 'loaded sites' are those carrying at least "
        f"{100 * LOADED:.0f} % of the load in the truth or the estimate; the peak error is over the sites "
        f"loaded in the truth. The most loaded site in the truth: "
        + ", ".join(f"{k} {v}" for k, v in sorted(tops.items(), key=lambda kv: -kv[1])) + ".", "",
        *rows, "",
        f"Goals: share within {SHARE_GOAL_PP:g} pp of the truth on average: {share:.2f} pp over all 16 sites "
        f"({'met' if share <= SHARE_GOAL_PP else 'not met'}), {r['loaded_mae_pp'].mean():.1f} pp over the loaded "
        f"sites; the most loaded site right in at least {100 * TOP_GOAL:.0f} % of images: {100 * top:.0f} % "
        f"({'met' if top >= TOP_GOAL else 'not met'}), {100 * named_top:.0f} % among the named sites "
        f"({'met' if named_top >= TOP_GOAL else 'not met'}) (the default estimates; the second last row gives "
        "each loaded taxel the site of the estimated body's skin over it, the body route without the site "
        "network; the last row reads the estimates fitted to their prints, docs/training.md).",
    ]
    if args.night_hours > 0:
        n = time_night(data, args.night_hours, model, args.out, args.model)
        per_night = n["verb"]["cpu"] * 28800 / n["frames"]
        lines += ["", f"A night: {n['frames']:,} frames at 1 Hz ({args.night_hours:g} h, {n['turns']} turns; frames made "
                  f"from the set's images with 4 % noise, breathing and a 12 s roll per turn). "
                  f"`pressurepose.eval.monitor.monitor` on one thread reads them in {n['seconds']:.0f} s, the network "
                  f"reading {n['estimated']} of them, and finds {n['found']} turns. The `monitor` verb end to end (the "
                  f".npy, every frame through the real-image road: baseline, taxel repair, resampling; the timeline "
                  f"written as JSON, CSV and PNG) takes {n['verb']['cpu']:.0f} CPU-seconds ({n['verb']['wall']:.0f} s "
                  f"wall). Goal {NIGHT_GOAL_S / 60:.0f} minutes of one core for 28,800 frames: "
                  f"{'met' if per_night <= NIGHT_GOAL_S else 'not met'}."]
    text = "\n".join(lines)
    print(text)
    if not args.no_write:
        write_section("sites", text)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
