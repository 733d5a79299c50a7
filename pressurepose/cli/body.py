"""CLI verb ``view-body``: draw a body of given shape and pose, front and side, with its capsules."""

from __future__ import annotations

import argparse

import numpy as np

from pressurepose.errors import BadInput


def add_view_body_arguments(p: argparse.ArgumentParser) -> None:
    p.add_argument("--gender", default="f", help="f, m or n (shipped open models) [f]")
    p.add_argument("--model", default=None, help="path of an SMPL-format .npz or SMPL .pkl (overrides --gender)")
    p.add_argument("--betas", type=float, nargs="*", default=[], help="shape coefficients (up to 10) [all 0]")
    p.add_argument("--pose", default=None, help=".npy file with 72 SMPL axis-angle values [T-pose]")
    p.add_argument("--no-capsules", action="store_true",
                   help="draw the mesh alone, without the capsules the settle simulates it with (default: overlaid)")
    p.add_argument("--out", default="body.png", help="output PNG [body.png]")


BETA_LIMIT = 10.0  # |beta| beyond this is far outside any training data of a body model (the sampler uses 3)


def run_view_body(args) -> int:
    from pressurepose.body import BodyModel
    from pressurepose.files import (
        FIGURE_SUFFIXES,
        check_output_path,
        read_npy,
        save_figure_atomic,
    )
    from pressurepose.viz.body_figure import body_figure

    check_output_path(args.out, "--out", suffixes=FIGURE_SUFFIXES)
    body = BodyModel(args.model or args.gender)
    betas = np.zeros(body.num_betas)
    if len(args.betas) > body.num_betas:
        raise BadInput(f"--betas has {len(args.betas)} values; this body model has {body.num_betas}")
    if not all(np.isfinite(b) and abs(b) <= BETA_LIMIT for b in args.betas):
        raise BadInput(f"--betas {' '.join(f'{b:g}' for b in args.betas)}: each shape coefficient must lie "
                       f"within -{BETA_LIMIT:g}..{BETA_LIMIT:g} (body models are built from about -3..3)")
    betas[: len(args.betas)] = args.betas
    pose = np.zeros(3 * body.num_joints)
    if args.pose:
        pose = read_npy(args.pose, "--pose").reshape(-1)
        if pose.shape != (3 * body.num_joints,):
            raise BadInput(f"--pose file holds {pose.size} values; expected {3 * body.num_joints}")
    fig, summary = body_figure(body, betas, pose, capsules=not args.no_capsules)
    save_figure_atomic(fig, args.out, dpi=120)
    print(summary)
    print(f"wrote {args.out}")
    return 0

