"""CLI verb ``sample``: draw initial bodies of a posture partition and save (and draw) them."""

from __future__ import annotations

import argparse

from pressurepose.cli.args import add_progress_argument, seed_arg
from pressurepose.pose.config import HEIGHT_REFERENCES
from pressurepose.pose.partitions import ALIASES, PARTITIONS

MAX_COUNT = 100_000  # bodies per file: about 1.4 kB each in memory, and the file is written at the end


def add_body_arguments(p: argparse.ArgumentParser) -> None:
    """The sampler's shape, placement, hanging-limb, height-reference and pose-file options (shared by sample,
    simulate, generate)."""
    p.add_argument("--shapes", choices=("normal", "uniform"), default="normal",
                   help="body shapes: betas ~ N(0, 1) within +-3, SMPL's population (normal, default), or "
                        "U(-3, 3), the paper's (uniform: a sixth of the bodies are extremely thin or heavy)")
    p.add_argument("--placement", choices=("centred", "uniform"), default="centred",
                   help="where bodies lie: centred across the bed (sd --across-sd), crown about 16 cm from the head "
                        "end, yaw sd 0.1 rad (centred, default), or the paper's uniform +-0.2 m shift and "
                        "+-pi/6 yaw from the mattress centre (uniform)")
    p.add_argument("--across-sd", type=float, default=0.03, metavar="M",
                   help="sd of a supine or prone pelvis across the bed for --placement centred, metres [0.03; "
                        "real supine people's load centroid: 1.5 cm, PhysioNet PMD experiment I]")
    p.add_argument("--across-sd-lateral", type=float, default=0.08, metavar="M",
                   help="the same for a body on its side (in between: by the roll's sine and cosine) [0.08; "
                        "real lateral people's load centroid: 8-9 cm]")
    p.add_argument("--hanging-limbs", action="store_true",
                   help="let limbs start beyond the mattress and rest hanging over its edge (the paper's "
                        "partitions without limbs-on-bed); default: limbs start over the mattress and a body "
                        "resting with a limb hanging over the edge is rejected")
    p.add_argument("--height-reference", choices=HEIGHT_REFERENCES, default="proximal",
                   help="where ankles and wrists start: within 0.2 m of their hip's or shoulder's height "
                        "(proximal, the public code's rule, default) or between 0.1 m below and 0.3 m above the "
                        "surface the body lies on (bed: the upper limbs of a body on its side start near the bed, "
                        "so fewer side-lying bodies roll over while settling, and settling is faster: set it when "
                        "side-lying bodies are what you need; docs/physics.md, 'Bodies on their side')")
    p.add_argument("--poses", default=None, metavar="FILE",
                   help="draw every body's pose from this SMPL pose file instead of the partition's limb draws: "
                        "an .npz with global_orient (N x 3) and body_pose (N x 69), as SMPL fits are written, or "
                        "pose (N x 72), as `sample` writes; axis-angle, SMPL's joint order. Each body takes a "
                        "pose of its roll's posture (supine, left or right side, prone: by the pose's root) "
                        "plus --pose-noise, clipped to the joint limits, moved apart where limbs collide "
                        "(pressurepose.pose.whole); the partition then gives only the roll, so use one without "
                        "limb rules (general, general_supine, general_lateral, propped_lateral, natural_*). "
                        "Use poses you have the rights to train on")
    p.add_argument("--pose-noise", type=float, default=5.0, metavar="DEG",
                   help="with --poses: sd of the Gaussian noise added to each axis-angle component of each "
                        "body joint, degrees [5]")
    p.add_argument("--pose-frame", choices=("auto", "bed", "camera"), default="auto",
                   help="with --poses: the frame of the file's root orientations: bed (z up, y toward the "
                        "feet), camera (an overhead camera's: x image-right, y toward the feet, z into the bed), "
                        "or auto: the file's own 'frame' entry, else camera for global_orient/body_pose files "
                        "and bed for pose files [auto]")


def body_settings(args) -> dict:
    """SamplerConfig / GenerationConfig keywords from :func:`add_body_arguments`' options."""
    from pressurepose.errors import BadInput
    from pressurepose.pose.posefile import PoseFile

    if args.poses is None and (args.pose_noise != 5.0 or args.pose_frame != "auto"):
        raise BadInput("--pose-noise and --pose-frame go with --poses FILE")
    poses = PoseFile.of(args.poses, args.pose_frame, args.pose_noise) if args.poses else None
    return {"shapes": args.shapes, "placement": args.placement, "hanging_limbs": bool(args.hanging_limbs),
            "across_sd_m": args.across_sd, "across_sd_lateral_m": args.across_sd_lateral,
            "height_reference": args.height_reference, "poses": poses}


def add_sample_arguments(p: argparse.ArgumentParser) -> None:
    p.description = (
        "Draw initial bodies (shape, pose, root on the bed) by rejection sampling as in the paper's "
        "appendix A.1, and write them to an .npz with arrays betas (N x 10), pose (N x 72, SMPL "
        "axis-angle, root first), transl (N x 3), joints (N x 24 x 3, bed frame, m), bins, roll, yaw, "
        "gender, partition and the rejection counts by cause (rejection_causes, rejection_counts).")
    p.add_argument("--partition", required=True,
                   help=f"posture partition: {', '.join(PARTITIONS)} "
                        f"(also {', '.join(f'{a}={c}' for a, c in ALIASES.items())})")
    p.add_argument("--gender", required=True, help="f or m (the shipped female or male body model)")
    p.add_argument("--limbs-on-bed", action="store_true",
                   help="every elbow, wrist, hand, knee, ankle and foot starts over the mattress")
    add_body_arguments(p)
    p.add_argument("--count", type=int, required=True, help=f"number of bodies (at most {MAX_COUNT})")
    p.add_argument("--seed", type=seed_arg, required=True, help="random seed (whole number >= 0)")
    p.add_argument("--model", default=None,
                   help="an SMPL-format .npz or SMPL .pkl to use instead of the shipped model of --gender")
    p.add_argument("--out", required=True, help="output .npz")
    p.add_argument("--plot", default=None, help="also draw up to 16 of the bodies from above into this PNG")
    add_progress_argument(p)


def run_sample(args) -> int:
    import time

    import numpy as np
    from tqdm import tqdm

    from pressurepose.body import BodyModel
    from pressurepose.errors import BadInput
    from pressurepose.files import (
        FIGURE_SUFFIXES,
        check_output_path,
        save_figure_atomic,
    )
    from pressurepose.pose.config import DEFAULT_SENSING, SamplerConfig
    from pressurepose.pose.partitions import get_partition
    from pressurepose.pose.sampler import (
        BLOCK,
        GENDER_NAMES,
        check_gender,
        sample_bodies,
    )
    from pressurepose.pose.samples import SampleBatch

    check_output_path(args.out, "--out", suffixes=(".npz",))
    if args.plot:
        check_output_path(args.plot, "--plot", suffixes=FIGURE_SUFFIXES)
    if not 1 <= args.count <= MAX_COUNT:
        raise BadInput(f"--count is {args.count}; expected 1 to {MAX_COUNT} bodies per file "
                       f"(for more, run again with another --seed, or use `generate`)")
    partition = get_partition(args.partition).name
    gender = check_gender(args.gender)
    body = BodyModel(args.model or GENDER_NAMES[gender])
    config = SamplerConfig(**body_settings(args))
    t0 = time.perf_counter()
    parts = []
    with tqdm(total=args.count, desc="sample", unit="body", disable=args.count <= BLOCK or args.no_progress) as bar:
        for start in range(0, args.count, BLOCK):  # body k uses (seed, k) whatever the blocks
            parts.append(sample_bodies(partition, gender, min(BLOCK, args.count - start), args.seed,
                                       limbs_on_bed=args.limbs_on_bed, body=body, config=config, start=start))
            bar.update(len(parts[-1]))
    first = parts[0]
    batch = SampleBatch(*(np.concatenate([getattr(b, k) for b in parts])
                          for k in ("betas", "pose", "transl", "joints", "bins", "roll", "yaw", "counts")),
                        first.gender, first.partition, first.limbs_on_bed, first.seed)
    dt = time.perf_counter() - t0
    batch.save(args.out)
    print(f"{len(batch)} {batch.partition} bodies ({gender}{', limbs on bed' if batch.limbs_on_bed else ''}) "
          f"in {dt:.1f} s ({len(batch) / dt:.0f}/s); wrote {args.out}")
    attempts = batch.attempts
    drawn = (f"{attempts['limb_candidates']} limb candidates, " if attempts["limb_candidates"] else "")
    print("rejected: " + (", ".join(f"{c} {n}" for c, n in batch.rejections.items() if n) or "none")
          + f" (of {drawn}{attempts['full_poses']} whole poses)")
    if args.plot:
        from pressurepose.viz.samples import plot_samples

        fig = plot_samples(batch, body, config.mattress, DEFAULT_SENSING)
        save_figure_atomic(fig, args.plot, dpi=110)
        print(f"wrote {args.plot}")
    return 0
