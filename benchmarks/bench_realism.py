"""Realism of simulated pressure images against real ones, and the realism goals met or not.

    python -m benchmarks.bench_realism --real PATH [--count 40] [--seeds 31,21]
        [--synthetic DATA] [--out runs/bench_realism] [--no-write]

1. Unless ``--synthetic`` names simulated images made already (a dataset, a folder of datasets or a
   ``pressurepose simulate`` .npz), generates ``general_supine`` and ``general_lateral`` bodies with
   the default physics, ``--count`` per gender and seed (``pressurepose generate --seed S``), into
   OUT/synthetic; sets made before are reused, so a rerun resumes.
2. Compares them with the real images of ``--real`` as ``pressurepose realism`` does
   (:mod:`pressurepose.eval.realism_report`): contact area, head imprint, pressure, and each body
   region's share of the load, first with the images as drawn, then with like postures compared
   (``--match-extent``: the simulated images resampled so that how long the body lies follows the
   real images'), and judges the goals (:func:`~pressurepose.eval.realism_report.goal_verdicts`):
   contact area within 20 %, a head imprint in at least 80 % of images, every region's load share
   within 5 percentage points.

Replaces the ``bench:realism`` section of docs/RESULTS.md (``--no-write`` only prints).
``--real`` defaults to ``$PRESSUREPOSE_PMD``; without real data the benchmark says so and measures
nothing. Real images only measure; nothing is trained or tuned on them.
"""

from __future__ import annotations

import argparse
from pathlib import Path

from benchmarks.common import add_real_argument, real_folder, stamp
from benchmarks.results import write_section
from pressurepose.cli import main as cli
from pressurepose.cli.eval import format_goals, format_real_intervals, format_realism
from pressurepose.errors import BadInput
from pressurepose.eval.realism_report import (
    goal_verdicts,
    headline,
    load_real,
    load_synthetic,
    realism_report,
)

PARTITIONS = ("general_supine", "general_lateral")
MATCH_SEEDS = 5  # resamples of the like-postures comparison, to show how much the draw alone moves it


def seeds_of(text: str) -> list[int]:
    """The whole numbers of a ``--seeds`` text (comma-separated); SystemExit naming it otherwise."""
    try:
        seeds = [int(s) for s in text.split(",") if s.strip()]
    except ValueError:
        raise SystemExit(f"--seeds {text!r}: expected whole numbers separated by commas") from None
    if not seeds:
        raise SystemExit("--seeds needs at least one seed")
    return seeds


def generate_sets(out: Path, count: int, seeds: list[int]) -> Path:
    """``pressurepose generate`` of every partition, gender and seed under ``out`` (kept sets reused)."""
    for seed in seeds:
        for partition in PARTITIONS:
            for gender in "fm":
                where = out / f"{partition}_{gender}_s{seed}"
                if (where / "manifest.json").is_file():
                    continue
                if cli(["generate", "--partition", partition, "--gender", gender, "--count", str(count), "--seed",
                        str(seed), "--workers", "1", "--no-progress", "--out", str(where)]):
                    raise SystemExit(f"pressurepose generate {partition} {gender} seed {seed} failed")
    return out


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    add_real_argument(ap)
    ap.add_argument("--count", type=int, default=40, help="samples per partition, gender and seed [40]")
    ap.add_argument("--seeds", default="31,21", help="seeds of the draws [31,21]")
    ap.add_argument("--synthetic", type=Path, default=None,
                    help="simulated images made already (dataset, folder of datasets or simulate .npz)")
    ap.add_argument("--out", type=Path, default=Path("runs/bench_realism"))
    ap.add_argument("--no-write", action="store_true", help="print only; leave docs/RESULTS.md alone")
    args = ap.parse_args(argv)
    seeds = seeds_of(args.seeds)
    if args.count < 1:
        raise SystemExit("--count needs a positive number")
    real_path = real_folder(args.real, "bench_realism")
    if real_path is None:
        return 0
    try:
        sim = load_synthetic(args.synthetic or generate_sets(args.out / "synthetic", args.count, seeds))
        real = load_real(real_path, sim.mat)
    except BadInput as e:
        raise SystemExit(f"bench_realism: {e}") from None
    drawn = headline(realism_report(real, sim))
    matched = [headline(realism_report(real, sim, match=True, seed=seed)) for seed in range(MATCH_SEEDS)]
    gaps: dict[str, list[float]] = {}
    for rows in matched:
        for v in goal_verdicts(rows):
            if v["goal"].startswith("worst region share gap"):
                gaps.setdefault(v["posture"], []).append(v["value"])
    supine, lateral = int((sim.posture == "supine").sum()), int((sim.posture == "lateral").sum())
    command = "python -m benchmarks.bench_realism --real PATH" + (
        " --synthetic DATA" if args.synthetic else f" --count {args.count} --seeds {args.seeds}")
    source = ("the simulated images of `--synthetic`" if args.synthetic else
              f"{', '.join(PARTITIONS)}, {args.count} per gender and seed, made by `pressurepose generate` with the "
              "default physics and bed")
    text = "\n".join([
        "## Realism: simulated against real pressure images (`benchmarks/bench_realism.py`)", "",
        f"`{command}` (PATH: PhysioNet PMD experiment I); {stamp()}.", "",
        f"Simulated: {source} ({supine} supine and {lateral} side-lying images by the bodies' roll). Real: the "
        "folder's flat-bed supine and side-lying images as `pressurepose realism` reads them (one per recording, "
        "weight-normalised to mmHg, resampled onto the simulated mat; the wedge postures left out). Areas are "
        "taxels over 5 mmHg; shares are mean shares of the image's load per region along the body's contact "
        "extent. The interval is the worst gap's 90 % interval from resampling the real people; where it reaches "
        "5 pp, a miss cannot be told from the goal with this many people.", "",
        "All simulated images as drawn (`pressurepose realism`):", "",
        format_realism(drawn), "", format_goals(goal_verdicts(drawn)), "",
        "Like postures compared (`pressurepose realism --match-extent`):", "",
        format_realism(matched[0]), "", format_goals(goal_verdicts(matched[0])), "",
        "The real people's 90 % interval of each statistic (resampling the people; a simulated value inside it "
        "cannot be told from the real one with this many people):", "", format_real_intervals(matched[0]), "",
        f"The resample is seeded (seed 0 above). Over {MATCH_SEEDS} seeds the worst share gap spans "
        + ", ".join(f"{g} {min(x):.1f}-{max(x):.1f} pp" for g, x in gaps.items())
        + ": the draw alone moves it by that much.", ""])
    print(text)
    if not args.no_write:
        write_section("realism", text)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
