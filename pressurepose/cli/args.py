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
