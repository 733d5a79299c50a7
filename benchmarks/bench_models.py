"""Several trained PressureNets side by side: held-out simulated sets and real PMD-I images.

    .venv/bin/python -m benchmarks.bench_models --model shipped=pressurepose/net/assets/pressurenet.json \\
        --model new=runs/gpu/A/pressurenet.json --test runs/shipped/data/test \\
        [--extra runs/extra/data/test] [--real ../shared/data/pmd-experiment-i] [--out runs/bench_models] \\
        [--section NAME --title TEXT] [--mirrored]

Each model is read with ``pressurepose evaluate`` on ``--test`` (the paper recipe's held-out
partitions: issue 14's simulated goals) and on ``--extra`` (more held-out partitions, e.g.
``general_lateral`` and ``propped_lateral``: reported per partition, not in the goal), and with
``pressurepose evaluate-real`` on ``--real`` (nothing is tuned on it). Reports are kept in
OUT/NAME/, so a rerun skips what is done (delete a model's folder to read it again). One row per
model; with ``--section`` the table replaces that section of docs/RESULTS.md, otherwise it is only
printed.
"""

from __future__ import annotations

import argparse
import datetime
import json
import platform
from pathlib import Path

import numpy as np

from benchmarks.results import write_section

WEDGE = ("left 30 deg (wedge)", "left 60 deg (wedge)", "right 30 deg (wedge)", "right 60 deg (wedge)")
HEADER = ("| model | sim MPJPE (cm) | worst partition / BL | sim posture acc. | `general_lateral` MPJPE / posture | "
          "`propped_lateral` MPJPE / posture | turn bias, side-lying / propped (deg) | real posture acc. | "
          "real wedge postures right | "
          "real flat side lying, left / right | real stature MAE (bias), cm | real stature r |")


def _cli(*args: str) -> None:
    from pressurepose.cli import main

    if main(list(args)) != 0:
        raise SystemExit(f"pressurepose {' '.join(args)} failed")


def sim_report(model: str, data: Path, out: Path, mirror: bool = False) -> dict:
    """``pressurepose evaluate``'s summary of ``model`` on ``data`` (kept in ``out``)."""
    if not (out / "report.json").is_file():
        _cli("evaluate", "--model", model, "--data", str(data), "--out", str(out), *(["--mirror"] if mirror else []))
    return json.loads((out / "report.json").read_text())["summary"]


def real_report(model: str, data: Path, out: Path, mirror: bool = False) -> dict:
    """``pressurepose evaluate-real``'s metrics of ``model`` on ``data`` (kept in ``out``)."""
    if not (out / "metrics.json").is_file():
        _cli("evaluate-real", str(data), "--model", model, "--out", str(out), *(["--mirror"] if mirror else []))
    return json.loads((out / "metrics.json").read_text())


def row(name: str, test: dict, extra: dict | None, real: dict | None) -> str:
    """One table row (HEADER's columns); '-' where a set was not given."""
    a = test["all"]
    worst = max(v["mod2"]["mpjpe_cm"] / v["baseline"]["mpjpe_cm"] for k, v in test.items() if k.startswith("partition:"))
    cells = [name, f"{a['mod2']['mpjpe_cm']:.2f}", f"{worst:.2f}", f"{a['posture_accuracy']:.2f}"]
    for part in ("general_lateral", "propped_lateral"):
        s = (extra or {}).get(f"partition:{part}")
        cells.append(f"{s['mod2']['mpjpe_cm']:.2f} / {s['posture_accuracy']:.2f}" if s else "-")
    turn = [(extra or {}).get(f"partition:{part}", {}).get("turn_bias_deg") for part in ("general_lateral", "propped_lateral")]
    cells.append(" / ".join("-" if t is None else f"{t:+.1f}" for t in turn) if any(t is not None for t in turn) else "-")
    if real is None:
        return "| " + " | ".join(cells + ["-"] * 5) + " |"
    d = real["per_detail"]
    wedge_n = sum(d[k]["n"] for k in WEDGE)
    wedge_right = sum(round(d[k]["posture_accuracy"] * d[k]["n"]) for k in WEDGE)
    cells += [f"{real['posture_accuracy']:.2f}", f"{wedge_right} / {wedge_n}",
              f"{d['left side']['posture_accuracy']:.2f} / {d['right side']['posture_accuracy']:.2f}",
              f"{100 * real['stature_mae_m']:.1f} ({100 * real['stature_bias_m']:+.1f})", f"{real['stature_r']:+.2f}"]
    return "| " + " | ".join(cells) + " |"


def real_rows(out: Path) -> list[dict]:
    """The per-estimate rows ``evaluate-real`` kept in ``out`` (estimates.json)."""
    return json.loads((out / "estimates.json").read_text())["rows"]


def paired_differences(base: list[dict], other: list[dict], draws: int = 2000, seed: int = 0) -> dict:
    """``other`` minus ``base`` on the same real estimates, with 90 % intervals from resampling the
    subjects (whole people, with replacement; the same draws for both models): posture accuracy, wedge
    postures read right (share) and stature MAE (m). What these intervals hold is the spread that
    comes from PMD-I's few people, not from training."""
    key = [(r["image"], r["body_model"]) for r in base]
    if key != [(r["image"], r["body_model"]) for r in other]:
        raise SystemExit("the two models' real estimates are not of the same images")
    subjects = sorted({r["subject"] for r in base})
    sid = np.array([subjects.index(r["subject"]) for r in base])
    scored = np.array([bool(r["scored"]) for r in base])
    wedge = np.array([r["detail"] in WEDGE for r in base]) & scored
    stat = {}
    for name, rows in (("base", base), ("other", other)):
        correct = np.array([bool(r["correct"]) for r in rows]) & scored
        err = np.abs([r["stature_err_m"] for r in rows])
        stat[name] = np.stack([np.bincount(sid, w, len(subjects)) for w in (correct, scored, correct & wedge, wedge,
                                                                              err, np.ones(len(rows)))])
    rng = np.random.default_rng(seed)
    picks = rng.integers(0, len(subjects), (draws, len(subjects)))
    offsets = (picks + len(subjects) * np.arange(draws)[:, None]).ravel()
    counts = np.bincount(offsets, minlength=draws * len(subjects)).reshape(draws, -1)  # (draws, subjects)
    everyone = np.ones((1, len(subjects)))

    def measures(t, weights):  # t (6, subjects) -> (3, len(weights)): posture acc., wedge share, stature MAE
        c = weights @ t.T
        return c[:, [0, 2, 4]].T / c[:, [1, 3, 5]].T

    d_full = (measures(stat["other"], everyone) - measures(stat["base"], everyone))[:, 0]
    d_draws = measures(stat["other"], counts) - measures(stat["base"], counts)
    lo, hi = np.percentile(d_draws, [5, 95], axis=1)
    return {k: (float(d_full[i]), float(lo[i]), float(hi[i])) for i, k in enumerate(("posture", "wedge", "stature_m"))}


def parse_model(text: str) -> tuple[str, str]:
    name, sep, path = text.partition("=")
    if not sep or not name or not path:
        raise argparse.ArgumentTypeError(f"{text!r}: expected NAME=PATH (a model .json, .safetensors or run folder)")
    return name, path


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--model", type=parse_model, action="append", required=True, metavar="NAME=PATH")
    ap.add_argument("--test", type=Path, required=True, help="held-out dataset of the goal's partitions")
    ap.add_argument("--extra", type=Path, default=None, help="more held-out partitions, reported per partition")
    ap.add_argument("--real", type=Path, default=None, help="real images for evaluate-real (PMD or labelled folder)")
    ap.add_argument("--out", type=Path, default=Path("runs/bench_models"))
    ap.add_argument("--section", default=None, help="docs/RESULTS.md section to replace (default: print only)")
    ap.add_argument("--title", default="PressureNets side by side (`benchmarks/bench_models.py`)")
    ap.add_argument("--note", default="", help="text under the table (how the models were made)")
    ap.add_argument("--mirrored", action="store_true",
                    help="also read every model with test-time mirror averaging (`--mirror`), one more row each")
    args = ap.parse_args(argv)
    names = [n for n, _ in args.model]
    if len(set(names)) != len(names):
        ap.error(f"model names must differ: {names}")
    rows, diffs = [], []

    def diff_row(name: str, base_dir: Path, other_dir: Path) -> str:
        d = paired_differences(real_rows(base_dir / "real"), real_rows(other_dir / "real"))
        return (f"| {name} | {d['posture'][0]:+.3f} ({d['posture'][1]:+.3f} to {d['posture'][2]:+.3f}) | "
                f"{d['wedge'][0]:+.3f} ({d['wedge'][1]:+.3f} to {d['wedge'][2]:+.3f}) | "
                f"{100 * d['stature_m'][0]:+.2f} ({100 * d['stature_m'][1]:+.2f} to "
                f"{100 * d['stature_m'][2]:+.2f}) |")

    for name, path in args.model:
        for mirror in (False, True) if args.mirrored else (False,):
            label, out = (f"{name}, mirror-averaged", args.out / f"{name}-mirror") if mirror else (name, args.out / name)
            test = sim_report(path, args.test, out / "test", mirror)
            extra = sim_report(path, args.extra, out / "extra", mirror) if args.extra else None
            real = real_report(path, args.real, out / "real", mirror) if args.real else None
            rows.append(row(label, test, extra, real))
            if real is not None and mirror:
                diffs.append(diff_row(f"{label} minus {name}", args.out / name, out))
            elif real is not None and name != names[0]:
                diffs.append(diff_row(f"{name} minus {names[0]}", args.out / names[0], out))
    command = "python -m benchmarks.bench_models " + " ".join(f"--model {n}=..." for n in names)
    text = "\n".join([
        f"### {args.title}", "",
        f"`{command} --test {args.test}" + (f" --extra {args.extra}" if args.extra else "")
        + (f" --real {args.real}" if args.real else "") + (" --mirrored" if args.mirrored else "")
        + f"`; {platform.machine()}, {datetime.date.today()}. "
        "Simulated: `pressurepose evaluate` (MPJPE of Mod2; BL = the mean-pose baseline). Real: `pressurepose "
        "evaluate-real` (posture accuracy over every estimate, each image read with both body models; the wedge "
        "postures and flat side lying by PMD posture).", "",
        HEADER, "|" + "---|" * HEADER.count(" | ") + "---|", *rows, "",
        *([f"Real images, paired differences on the same estimates, with 90 % intervals from resampling "
           "PMD-I's people (2,000 draws of whole subjects; the spread a test set of so few people leaves, not the "
           "spread between trainings):", "",
           "| difference | posture accuracy | share of wedge postures right | stature MAE (cm) |", "|---|---|---|---|",
           *diffs, ""] if diffs else []),
        args.note])
    print(text)
    if args.section:
        write_section(args.section, text)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
