"""Argument types and groups shared by several verbs."""

from __future__ import annotations

import argparse

MAX_EXAMPLES = 50  # example images a picture may show per set and posture (more are unreadable, and costly)


def seed_arg(text: str) -> int:
    """argparse type of --seed: any whole number >= 0 (what numpy's SeedSequence takes)."""
    try:
        value = int(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"{text!r}: expected a whole number >= 0") from None
    if value < 0:
        raise argparse.ArgumentTypeError(f"{text}: seeds are whole numbers >= 0")
    return value


def add_recording_arguments(p: argparse.ArgumentParser, required: bool) -> None:
    """``--mat``, ``--units``, ``--weight-kg``, ``--gain``, ``--head-row``: a recording on its own mat
    (shared by ``infer``, where they are optional, and ``monitor``, where mat and units are needed)."""
    when = "" if required else "with --mat: "
    p.add_argument("--mat", required=required, default=None, metavar="PRESET|mat.json",
                   help="the recording's mat: a preset (boditrak_bt3510, fsa_softflex_2048, slp, tip) or a mat.json "
                        "(preset, or rows, cols, pitch_m and optional pitch_col_m)"
                        + ("" if required else "; default: the images are mmHg on the model's mat"))
    p.add_argument("--units", choices=("raw", "mmHg"), required=required, default=None,
                   help=f"{when}the readings' units, raw (the mat's own; needs --weight-kg or --gain) or mmHg")
    p.add_argument("--weight-kg", type=float, default=None, metavar="W",
                   help="raw readings to mmHg by the person's weight: each frame's total load set to W x g")
    p.add_argument("--gain", type=float, default=None, metavar="G",
                   help="raw readings to mmHg by your mat's calibration: G mmHg per raw unit")
    p.add_argument("--head-row", choices=("first", "last"), default="first",
                   help=f"{when}which end of the rows is the head: first (row 0, default) or last (flipped)")


def add_progress_argument(p: argparse.ArgumentParser, also: str = "") -> None:
    """``--no-progress``: no progress bar on stderr (shared by every verb that draws one; ``also`` names
    what else the flag keeps off stderr). The verb passes ``progress=not args.no_progress`` on."""
    p.add_argument("--no-progress", action="store_true",
                   help="no progress bar on stderr (for output going to a log file)" + (f"; {also}" if also else ""))


def bed_of(mat: str | None, bed_file: str | None):
    """The bed of ``--mat`` and ``--bed`` (``generate``, ``simulate``): the one in ``bed_file``
    (whose mat must be ``mat`` where both are given), else the default bed carrying ``mat``: a
    preset's name (default :data:`~pressurepose.mat.DEFAULT_MAT`) or a mat.json of any grid."""
    from pressurepose.mat import MATS
    from pressurepose.sim.bed import bed_for

    if mat is None or str(mat).strip().lower() in MATS:
        return bed_for(mat, bed_file)
    from pressurepose.data.readers.recording import resolve_mat

    return bed_for(resolve_mat(mat)[0], bed_file)
