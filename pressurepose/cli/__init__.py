"""The one command-line entry point: ``pressurepose <verb> [options]``.

Each verb is a pair of functions ``add_<name>_arguments(parser)`` and ``run_<name>(args) -> int``
in a module of this package named for the floor that does its work (``cli.data`` for ``generate``,
``cli.net`` for ``train``...); :data:`VERBS` is the only place verbs are registered. A verb's module
is imported only when it runs.
"""

from __future__ import annotations

import argparse
import importlib
import os
import sys

# verb -> (module, function stem, one-line help)
VERBS: dict[str, tuple[str, str, str]] = {
    "convert": ("pressurepose.cli.data", "convert", "convert the official PressurePose release to pressurepose datasets, or back"),
    "demo": ("pressurepose.cli.demo", "demo", "run the whole pipeline on built-in defaults and draw it"),
    "simulate": ("pressurepose.cli.sim", "simulate",
                 "settle bodies on the bed and press them: pressure images and labels (.npz, --plot)"),
    "calibrate": ("pressurepose.cli.calibrate", "calibrate", "fit the bed's foundation and sensor constants with CMA-ES"),
    "generate": ("pressurepose.cli.data", "generate", "generate a labelled dataset (resumable; local cores or Ray)"),
    "repress": ("pressurepose.cli.data", "repress",
                "press a dataset's resting bodies again on another bed (tissue, sensor): new images, no settling"),
    "info": ("pressurepose.cli.data", "info", "summarise a dataset: counts, rejection rates, pressure stats, PNG"),
    "view-body": ("pressurepose.cli.body", "view_body", "draw a body mesh (front and side) with its capsules"),
    "sample": ("pressurepose.cli.pose", "sample", "draw initial bodies of a posture partition (rejection sampler)"),
    "train": ("pressurepose.cli.net", "train", "train PressureNet (Mod1 then Mod2) on a generated dataset; resumable"),
    "pack": ("pressurepose.cli.net", "pack",
             "write a dataset's training arrays to one .npz file to copy to a GPU machine (train --data takes it)"),
    "train-sites": ("pressurepose.cli.net", "train_sites",
                    "train a site network for a PressureNet (which body site carries each loaded taxel); resumable"),
    "infer": ("pressurepose.cli.net", "infer", "estimate 3D pose and shape and the pressure per body site from pressure images"),
    "monitor": ("pressurepose.cli.monitor", "monitor",
                "read a recording over time (a night): posture, turns, pressure per body site, time above a "
                "threshold, alerts past a repositioning interval (JSON, CSV, PNG)"),
    "evaluate": ("pressurepose.cli.eval", "evaluate", "MPJPE and v2v of a trained PressureNet vs the mean-pose baseline"),
    "evaluate-real": ("pressurepose.cli.eval", "evaluate_real",
                      "score a PressureNet on real pressure images: posture, stature, mass, contact (PMD or labelled folder)"),
    "realism": ("pressurepose.cli.eval", "realism",
                "compare simulated pressure images with real ones by posture: area, region loads, pressures (JSON, PNG)"),
}


def build_parser() -> argparse.ArgumentParser:
    from pressurepose import __version__

    parser = argparse.ArgumentParser(
        prog="pressurepose",
        description="3D body pose and shape from bed pressure images: data engine, PressureNet, evaluation.")
    parser.add_argument("--version", action="version", version=f"pressurepose {__version__}")
    sub = parser.add_subparsers(dest="verb", metavar="VERB")
    for verb, (module, stem, help_text) in VERBS.items():
        p = sub.add_parser(verb, help=help_text, description=help_text)
        p.set_defaults(_module=module, _stem=stem)
        if verb in sys.argv[1:2]:  # only the chosen verb's module is imported
            getattr(importlib.import_module(module), f"add_{stem}_arguments")(p)
    return parser


def main(argv: list[str] | None = None) -> int:
    from pressurepose.errors import BadInput

    # no verb renders with MuJoCo (pictures are matplotlib's): importing it then skips loading an
    # OpenGL library (glfw, about 0.07 s of start-up, in every worker too); a user's setting stands
    os.environ.setdefault("MUJOCO_GL", "disable")
    argv = sys.argv[1:] if argv is None else argv
    sys_argv, sys.argv = sys.argv, [sys.argv[0], *argv]
    try:
        parser = build_parser()
        args = parser.parse_args(argv)
    finally:
        sys.argv = sys_argv
    if not getattr(args, "verb", None):
        parser.print_help(sys.stderr)  # a verb is required: usage goes to stderr with argparse's status
        return 2
    run = getattr(importlib.import_module(args._module), f"run_{args._stem}")
    try:
        return int(run(args) or 0)
    except BadInput as exc:
        print(f"error: {exc}", file=sys.stderr)
        return 2
    except KeyboardInterrupt:  # files are written atomically: finished ones are kept, none is half-written
        print("\ninterrupted: files already written are complete, none is half-written "
              "(generate, repress, train and simulate resume when rerun)", file=sys.stderr)
        return 130
    except BrokenPipeError:  # output piped into a reader that stopped (`| head`): quiet, as other tools
        os.dup2(os.open(os.devnull, os.O_WRONLY), sys.stdout.fileno())
        return 141


if __name__ == "__main__":
    raise SystemExit(main())
