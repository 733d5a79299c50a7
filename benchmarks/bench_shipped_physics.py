"""The shipped PressureNet on its own test bodies, rested with other settles (session 12).

    .venv/bin/python -m benchmarks.bench_shipped_physics [--out runs/bench_shipped_physics] [--no-write]

Makes the shipped model's held-out test set again (the paper recipe's test entries as
``tools/train_shipped_model.py`` draws them: 360 bodies, seed 1411, ``--randomize``) with each settle
below, then reads every set with the installed model (``pressurepose evaluate``). The draws are the
same in every set, so the rows are paired:

- ``shipped``: the settle of the shipped model's training data (session 8): relaxed neck, the
  paper's spine, 0.01 s throughout. It should reproduce docs/RESULTS.md's shipped_model table.
- ``shipped+coarse``: the same springs with the coarse step: what the step alone changes.
- ``default``: today's defaults (``generate`` as is).

The first two are no ``--settle`` preset, so this process swaps them in for 'paper' and runs
``generate`` with one worker (worker processes would import the presets afresh). Sets are kept in
OUT, so a rerun resumes. About 15 minutes of one core for the three sets. Replaces the
``shipped-physics`` section of docs/RESULTS.md (``--no-write`` only prints).
"""

from __future__ import annotations

import argparse
import datetime
import importlib.util
import json
import platform
from pathlib import Path

from benchmarks.results import write_section
from pressurepose.files import write_json_atomic
from pressurepose.sim import settle as settle_module
from pressurepose.sim.settle import SettleConfig

REPO = Path(__file__).resolve().parents[1]
MODEL = REPO / "pressurepose" / "net" / "assets" / "pressurenet.json"
# name -> the settle that replaces the 'paper' preset while its set is made (None: `generate` as is)
SETTLES = {
    "shipped": SettleConfig(spine_stiffness=None, coarse_factor=1.0),
    "shipped+coarse": SettleConfig(spine_stiffness=None),
    "default": None,
}
LABELS = {
    "shipped": "the shipped model's own: relaxed neck, the paper's spine, 0.01 s throughout",
    "shipped+coarse": "the same springs with the coarse step",
    "default": "today's defaults: relaxed neck and spine, coarse step",
}


def shipped_test_recipe() -> dict:
    """The shipped model's test entries, as ``tools/train_shipped_model.py`` makes them."""
    spec = importlib.util.spec_from_file_location("train_shipped_model", REPO / "tools" / "train_shipped_model.py")
    shipped = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(shipped)

    recipe = shipped.scaled_recipe(json.loads(shipped.PAPER_RECIPE.read_text()), shipped.TRAIN_SAMPLES,
                                   shipped.TEST_SAMPLES, shipped.TRAIN_SEED, shipped.TEST_SEED)
    return {**recipe, "entries": [e for e in recipe["entries"] if e["split"] == "test"]}


def make_set(name: str, recipe_file: Path, out: Path) -> None:
    """Generate the test set with settle ``name`` into ``out`` (a finished set is kept as it is)."""
    from pressurepose.cli import main

    original, swap = settle_module.settle_preset, SETTLES[name]
    if swap is not None:
        settle_module.settle_preset = lambda preset: swap if preset == "paper" else original(preset)
    try:
        code = main(["generate", "--recipe", str(recipe_file), "--randomize", "--settle",
                     "relaxed" if swap is None else "paper", "--workers", "1", "--no-progress", "--out", str(out)])
        if code != 0:
            raise SystemExit(f"generate for {name} failed ({code})")
    finally:
        settle_module.settle_preset = original


def evaluate(data: Path, out: Path) -> dict:
    """``pressurepose evaluate`` of the installed model; the report's summary."""
    from pressurepose.cli import main

    if main(["evaluate", "--model", str(MODEL), "--data", str(data), "--out", str(out)]) != 0:
        raise SystemExit(f"evaluate of {data} failed")
    return json.loads((out / "report.json").read_text())["summary"]


def row(name: str, s: dict) -> str:
    a = s["all"]
    cells = [LABELS[name], f"{a['mod2']['mpjpe_cm']:.2f}"]
    cells += [f"{s[f'partition:{p}']['mod2']['mpjpe_cm']:.2f}" for p in ("general", "general_supine")]
    worst = max(v["mod2"]["mpjpe_cm"] / v["baseline"]["mpjpe_cm"]
                for k, v in s.items() if k.startswith("partition:"))
    cells += [f"{worst:.2f}", f"{a['posture_accuracy']:.2f}", f"{a['stature_mae_cm']:.1f} ({a['stature_bias_cm']:+.1f})"]
    return "| " + " | ".join(cells) + " |"


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--out", type=Path, default=Path("runs/bench_shipped_physics"))
    ap.add_argument("--no-write", action="store_true")
    args = ap.parse_args(argv)
    args.out.mkdir(parents=True, exist_ok=True)
    recipe_file = args.out / "test_recipe.json"
    write_json_atomic(recipe_file, shipped_test_recipe())
    rows = []
    for name in SETTLES:
        make_set(name, recipe_file, args.out / name)
        rows.append(row(name, evaluate(args.out / name / "test", args.out / f"{name}_eval")))
    text = "\n".join([
        "### The shipped model on its test bodies made again (`benchmarks/bench_shipped_physics.py`)", "",
        f"`python -m benchmarks.bench_shipped_physics`; {platform.machine()}, {datetime.date.today()}. The shipped "
        "model's 360 test bodies (the paper recipe's test entries, seed 1411, `--randomize`) made again with each "
        "settle and read by the installed model (`pressurepose evaluate`). The draws are the same in every set, so "
        "the rows are paired.", "",
        "| settle | MPJPE (cm) | `general` | `general_supine` | worst partition / baseline | posture acc. | "
        "stature MAE (bias), cm |",
        "|---|---|---|---|---|---|---|",
        *rows, ""])
    print(text)
    if not args.no_write:
        write_section("shipped-physics", text)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
