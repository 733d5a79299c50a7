"""Issue 12's realism goals on today's default physics, met or not, in one command.

    .venv/bin/python -m benchmarks.bench_realism_goals [--real ../shared/data/pmd-experiment-i]
        [--count 40] [--seeds 31,21] [--out runs/bench_relaxed_limbs] [--no-write]

Settles and presses ``general_supine`` and ``general_lateral`` bodies with the default settle, ``--count``
per gender and seed, drawn as ``pressurepose generate --seed`` draws them. They are
``bench_relaxed_limbs``' sets for the paper's limb damping (the default): its OUT/paper/s<seed>/ files are
reused, and missing ones made, so a rerun resumes. It then judges them against the real images of
``--real`` as ``pressurepose realism`` does (:func:`pressurepose.eval.realism_report.goal_verdicts`):
contact area within 20 %, head imprint in at least 80 % of images, every region's load share within 5
percentage points. Each is judged with the images as drawn and with like postures compared
(``--match-extent``). ``--real`` may be any folder ``realism`` reads, e.g. PMD experiment II, which the
issue means by "a mat the calibration did not use".

Replaces the ``bench:realism-goals`` section of docs/RESULTS.md (``--no-write`` only prints). Real
images only measure; nothing is trained on them.
"""

from __future__ import annotations

import argparse
import datetime
import platform
from pathlib import Path

from benchmarks.bench_realism import DEFAULT_DATA
from benchmarks.bench_relaxed_limbs import image_set, sets_of
from benchmarks.bench_spine import PAPER, PARTITIONS, seeds_and_count
from benchmarks.results import write_section
from pressurepose.cli.eval import format_goals
from pressurepose.errors import BadInput
from pressurepose.eval.realism_report import (
    goal_verdicts,
    headline,
    load_real,
    realism_report,
)
from pressurepose.mat import get_mat

MATCH_SEEDS = 5  # resamples of the like-postures comparison, to show how much the draw alone moves it


def verdicts(real, sim, match: bool, seed: int = 0) -> list[dict]:
    return goal_verdicts(headline(realism_report(real, sim, match=match, seed=seed)))


def worst_gap_range(per_seed: list[list[dict]]) -> dict[str, tuple[float, float]]:
    """Per posture, the smallest and largest worst share gap (pp) over :func:`verdicts` of several
    matching seeds."""
    gaps: dict[str, list[float]] = {}
    for seed_verdicts in per_seed:
        for v in seed_verdicts:
            if v["goal"].startswith("worst region share gap"):
                gaps.setdefault(v["posture"], []).append(v["value"])
    return {g: (min(x), max(x)) for g, x in gaps.items()}


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--real", type=Path, default=DEFAULT_DATA, help="real-data folder [PMD experiment I]")
    ap.add_argument("--count", type=int, default=40, help="samples per partition, gender and seed [40]")
    ap.add_argument("--seeds", default="31,21", help="seeds of the draws [31,21]")
    ap.add_argument("--out", type=Path, default=Path("runs/bench_relaxed_limbs"),
                    help="where the simulated sets live (shared with bench_relaxed_limbs)")
    ap.add_argument("--no-write", action="store_true")
    args = ap.parse_args(argv)
    seeds = seeds_and_count(args.seeds, args.count)
    mat = get_mat("boditrak_bt3510")
    try:
        real = load_real(args.real, mat)
    except BadInput as e:
        raise SystemExit(f"--real: {e}") from None
    sim = image_set(sets_of(args.out, PAPER, seeds, args.count), "simulated (default physics)")
    supine, lateral = int((sim.posture == "supine").sum()), int((sim.posture == "lateral").sum())
    matched = [verdicts(real, sim, match=True, seed=seed) for seed in range(MATCH_SEEDS)]
    text = "\n".join([
        "### Issue 12's realism goals on the default physics (`benchmarks/bench_realism_goals.py`)", "",
        f"`python -m benchmarks.bench_realism_goals --count {args.count} --seeds {args.seeds}`; real images: "
        f"`{args.real.name}`; {platform.machine()}, {datetime.date.today()}.", "",
        f"Simulated: {', '.join(PARTITIONS)}, {args.count} per gender and seed, default settle and bed "
        f"({supine} supine and {lateral} side-lying images by the bodies' roll). Real: the folder's flat-bed "
        "supine and side-lying images as `pressurepose realism` reads them. Shares are fractions of the body's "
        "contact extent. The interval is the worst gap's 90 % interval from resampling the real people; where it "
        "reaches 5 pp, a miss cannot be told from the goal with this many people.", "",
        "All simulated images as drawn (`realism`):", "", format_goals(verdicts(real, sim, match=False)), "",
        "Like postures compared (`realism --match-extent`: the simulated images resampled so that how long the "
        "body lies follows the real images'):", "", format_goals(matched[0]), "",
        f"The resample is seeded (seed 0 above). Over {MATCH_SEEDS} seeds the worst share gap spans "
        + ", ".join(f"{g} {lo:.1f}-{hi:.1f} pp" for g, (lo, hi) in worst_gap_range(matched).items())
        + ": the draw alone moves it by that much.", ""])
    print(text)
    if not args.no_write:
        write_section("realism-goals", text)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
