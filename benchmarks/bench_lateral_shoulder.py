"""Why simulated side-lying shoulders carry less load than real ones: the pose, or the tissue? (issue 12)

    .venv/bin/python -m benchmarks.bench_lateral_shoulder [--count 40] [--seed 31]
        [--data ../shared/data/pmd-experiment-i] [--out runs/bench_lateral_shoulder] [--no-write]

Real people lying on their side put about a quarter of their load on the shoulder band, simulated
ones a fifth, and more on the band below it (``realism``, docs/RESULTS.md section realism-matched).
Two diagnostics, on ``--count`` fresh ``general_lateral`` and ``general_supine`` bodies per gender
(``pressurepose generate --seed``, kept in OUT so a rerun resumes), beside PMD-I's flat-bed images:

1. **Where the down arm lies.** The side-lying bodies grouped by the angle between the lower
   upper arm (shoulder to elbow) and the trunk's axis (pelvis to neck): raised (under 60 degrees),
   forward (60-120: the arm out in front, as people lying on their side usually hold it) and along
   the side (over 120: the arm lies under or beside the trunk). Mean region shares of each group.
2. **Bone geometry, re-pressed.** The same rests pressed again (no settling) with the bones of the
   soft-tissue press changed where anatomy says the default is off for a body on its side: the
   lumbar bone shortened to a fraction of its capsule's axis (the waist's side has no bone; the
   capsule, fitted to the trunk, reaches its skin), the thorax's bones shortened too, and the
   humeral heads added as spheres at the shoulder joints. Supine bodies are pressed alike, to see
   what each change costs them.
3. **A supra-linear mat.** If the real mat read high pressures more than in proportion, peaks (a
   side-lying shoulder's) would carry more of the load. Each simulated image (default bones) is
   raised to a power ``g`` and scaled back to its load (:func:`supralinear`), then clipped at the
   mat's 100 mmHg as the real images are.

Replaces the ``bench:lateral-shoulder`` section of docs/RESULTS.md (``--no-write`` only prints).
"""

from __future__ import annotations

import argparse
import datetime
import platform
from pathlib import Path

import numpy as np
from tqdm import tqdm

from benchmarks.results import write_section

REPO = Path(__file__).resolve().parents[1]
DEFAULT_DATA = REPO.parent / "shared" / "data" / "pmd-experiment-i"
SHOULDERS, ELBOWS, PELVIS, NECK = (16, 17), (18, 19), 0, 12  # SMPL joint indices
ARM_GROUPS = (("raised (< 60 deg)", 0.0, 60.0), ("forward (60-120 deg)", 60.0, 120.0),
              ("along the side (> 120 deg)", 120.0, 180.1))
# name -> (capsule -> fraction of its axis kept as bone, humeral head radius m at 1.75 m of stature)
VARIANTS: dict[str, tuple[dict[str, float], float]] = {
    "default bones": ({}, 0.0),
    "lumbar bone 0.3 of its axis": ({"spine": 0.3}, 0.0),
    "humeral heads (r 3.5 cm)": ({}, 0.035),
    "lumbar 0.3, thorax 0.7, humeral heads": ({"spine": 0.3, "spine1": 0.7, "spine2": 0.7}, 0.035),
}


def down_arm_angle(joints) -> np.ndarray:
    """(N,) degrees between the lower arm's upper arm (shoulder to elbow; the lower of the two
    shoulder joints) and the trunk's axis (pelvis to neck), for joints (N, 24, 3) in the bed frame
    (z up): 0 arm raised over the head, 90 out in front or behind, 180 along the side toward the feet."""
    j = np.asarray(joints, dtype=np.float64)
    if j.ndim != 3 or j.shape[1:] != (24, 3):
        raise ValueError(f"joints have shape {j.shape}; expected (N, 24, 3)")
    down = j[:, SHOULDERS[1], 2] < j[:, SHOULDERS[0], 2]  # True: the right shoulder is the lower
    n = np.arange(len(j))
    shoulder = j[n, np.where(down, SHOULDERS[1], SHOULDERS[0])]
    elbow = j[n, np.where(down, ELBOWS[1], ELBOWS[0])]
    arm, axis = elbow - shoulder, j[:, NECK] - j[:, PELVIS]
    cos = (arm * axis).sum(1) / (np.linalg.norm(arm, axis=1) * np.linalg.norm(axis, axis=1))
    return np.degrees(np.arccos(np.clip(cos, -1.0, 1.0)))


def variant_bones(bones, joints, scale: float, shorten: dict[str, float], humeral_r: float):
    """``bones`` (:class:`pressurepose.sim.tissue.Bones` of the 20 capsules) with the capsules named
    in ``shorten`` cut to that fraction of their axis about its midpoint, and, if ``humeral_r`` > 0,
    two spheres of radius ``humeral_r * scale`` m at the shoulder joints of ``joints`` (24, 3)."""
    from pressurepose.body.capsules import CAPSULE_NAMES
    from pressurepose.sim.tissue import Bones

    ends, radius = bones.ends.copy(), bones.radius.copy()
    for name, keep in shorten.items():
        k = CAPSULE_NAMES.index(name)
        mid = ends[k].mean(0)
        ends[k] = mid + keep * (ends[k] - mid)
    if humeral_r > 0:
        heads = np.stack([np.stack([joints[j], joints[j]]) for j in SHOULDERS])
        ends = np.concatenate([ends, heads])
        radius = np.concatenate([radius, np.full(2, humeral_r * scale)])
    return Bones(ends, radius)


def supralinear(images, g: float, clip_mmhg: float = 100.0) -> np.ndarray:
    """Images (N, R, C) mmHg read by a mat whose reading grows as pressure**g: each image raised to
    ``g``, scaled back to its own total, then clipped at ``clip_mmhg``."""
    p = np.asarray(images, dtype=np.float64)
    if np.any(p < 0) or not np.all(np.isfinite(p)):
        raise ValueError("images must be finite and non-negative")
    q = p ** g
    total = q.sum((1, 2), keepdims=True)
    return np.minimum(q * np.divide(p.sum((1, 2), keepdims=True), total, out=np.zeros_like(total),
                                    where=total > 0), clip_mmhg)


def make_set(out: Path, partition: str, gender: str, count: int, seed: int) -> Path:
    from pressurepose.cli import main as cli

    path = out / f"{partition}_{gender}_{count}_{seed}"
    code = cli(["generate", "--partition", partition, "--gender", gender, "--count", str(count),
                "--seed", str(seed), "--out", str(path), "--no-progress"])
    if code:
        raise SystemExit(f"generate failed for {path}")
    return path


def press_variants(paths, side_lying: bool) -> tuple[dict[str, np.ndarray], np.ndarray]:
    """Every body of the datasets ``paths`` pressed with each of :data:`VARIANTS`' bones on its own
    bed: ({variant: (N, R, C) mmHg}, joints (N, 24, 3)); with ``side_lying`` only bodies whose roll
    is within 45 degrees of a side; bodies one variant cannot balance are left out of all."""
    from pressurepose.data.dataset import DatasetReader
    from pressurepose.data.physics import setup
    from pressurepose.pose.posture import roll_angle
    from pressurepose.sim.press import PressFailed, press
    from pressurepose.sim.tissue import body_bones

    images, joints = {v: [] for v in VARIANTS}, []
    for path in paths:
        reader = DatasetReader(path)
        body, bed = setup(reader.datasets[0].manifest.config)
        for s in tqdm(reader, desc=path.name, leave=False):
            if side_lying and abs(abs(np.degrees(roll_angle(s.pose))) - 90.0) > 45.0:
                continue
            b, p, t = (np.asarray(x, dtype=np.float64) for x in (s.betas, s.pose, s.transl))
            verts, j = body.forward(b, p, t)
            bones = body_bones(body, b, p, t, bed.tissue_bone_fraction)
            scale = float(body.height(b)[0]) / 1.75
            try:
                got = {v: press(verts[0], body.faces, float(s.mass), bed,
                                bones=variant_bones(bones, j[0], scale, *VARIANTS[v])).pressure for v in VARIANTS}
            except PressFailed:
                continue
            for v in VARIANTS:
                images[v].append(got[v])
            joints.append(j[0])
    return {v: np.array(x) for v, x in images.items()}, np.array(joints)


def parse_args(doc: str, argv=None) -> argparse.Namespace:
    """The options of this benchmark and of those that read its datasets (``bench_lateral_profile``)."""
    ap = argparse.ArgumentParser(description=doc, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--data", type=Path, default=DEFAULT_DATA, help="PMD experiment I folder")
    ap.add_argument("--count", type=int, default=40, help="bodies per partition and gender [40]")
    ap.add_argument("--seed", type=int, default=31, help="their seed [31]")
    ap.add_argument("--out", type=Path, default=REPO / "runs" / "bench_lateral_shoulder")
    ap.add_argument("--no-write", action="store_true", help="print only; leave docs/RESULTS.md alone")
    return ap.parse_args(argv)


def main(argv=None) -> int:
    args = parse_args(__doc__, argv)
    from pressurepose.eval import realism as R
    from pressurepose.eval.realism_report import load_real
    from pressurepose.mat import get_mat

    mat = get_mat("boditrak_bt3510")
    real = load_real(args.data, mat)
    sets = {post: [make_set(args.out, part, g, args.count, args.seed) for g in ("f", "m")]
            for post, part in (("lateral", "general_lateral"), ("supine", "general_supine"))}
    pressed = {post: press_variants(paths, post == "lateral") for post, paths in sets.items()}

    def row(name, n, shares, ref=None):
        m = 100 * np.nanmean(shares, 0)
        gap = "" if ref is None else f"{np.max(np.abs(m - ref)):.1f}"
        return f"| {name} | {n} | " + " | ".join(f"{v:.1f}" for v in m) + f" | {gap} |"

    head = "| images | n | " + " | ".join(R.REGIONS) + " | worst gap to real (pp) |"
    rule = "|---|---|" + "---|" * (len(R.REGIONS) + 1)
    real_shares = {p: R.region_shares(real.pressure[real.posture == p], mat) for p in ("lateral", "supine")}
    real_mean = {p: 100 * np.nanmean(x, 0) for p, x in real_shares.items()}
    lat_images, lat_joints = pressed["lateral"]
    base = lat_images["default bones"]
    shares = R.region_shares(base, mat)
    angle = down_arm_angle(lat_joints)
    lines = ["## The side-lying shoulder: pose or tissue? (`benchmarks/bench_lateral_shoulder.py`)", "",
             f"{datetime.date.today()}, {platform.platform()}; {args.count} `general_lateral` and {args.count} "
             f"`general_supine` bodies per gender, seed {args.seed}, default physics and bed, every body pressed "
             "again with each set of bones (the rests are the same). Real: PMD-I flat-bed images as `realism` "
             "reads them. Shares: mean share of each image's load per region along the body's contact extent "
             "(`pressurepose.eval.realism`, unmatched extents). Reproduce: `python -m benchmarks.bench_lateral_shoulder`.",
             "", "**1. Side-lying bodies by where the lower arm lies** (angle between the lower upper arm and "
             "the trunk's axis; default bones):", "", head, rule,
             row("real, flat side lying", len(real_shares["lateral"]), real_shares["lateral"]),
             row("simulated, all side-lying", len(base), shares, real_mean["lateral"])]
    for name, lo, hi in ARM_GROUPS:
        sel = (angle >= lo) & (angle < hi)
        if sel.any():
            lines.append(row(f"simulated, lower arm {name}", int(sel.sum()), shares[sel], real_mean["lateral"]))
    lines += ["", "**2. The same rests pressed with other bones** (every side-lying and supine body):", "",
              "| bones | side-lying: " + " | ".join(R.REGIONS) + " | worst gap (pp) | supine: shoulders | pelvis | "
              "worst gap (pp) |", "|---|" + "---|" * (len(R.REGIONS) + 4)]
    sup_images, _ = pressed["supine"]
    for v in VARIANTS:
        lat = 100 * np.nanmean(R.region_shares(lat_images[v], mat), 0)
        sup = 100 * np.nanmean(R.region_shares(sup_images[v], mat), 0)
        lines.append(f"| {v} | " + " | ".join(f"{x:.1f}" for x in lat)
                     + f" | {np.max(np.abs(lat - real_mean['lateral'])):.1f} | {sup[1]:.1f} | {sup[3]:.1f} | "
                     f"{np.max(np.abs(sup - real_mean['supine'])):.1f} |")
    lines.append(f"| real | " + " | ".join(f"{x:.1f}" for x in real_mean["lateral"])
                 + f" | | {real_mean['supine'][1]:.1f} | {real_mean['supine'][3]:.1f} | |")
    lines += ["", "**3. A supra-linear mat** (default bones; each image raised to the power g, scaled back to its "
              "load, clipped at 100 mmHg; contact taxels > 5 mmHg, median):", "",
              "| g | side-lying: shoulders | back | pelvis | worst gap (pp) | contact taxels | supine: shoulders | "
              "pelvis | worst gap (pp) | contact taxels |", "|---|" + "---|" * 9]
    for g in (1.0, 1.3, 1.6, 2.0):
        lat, sup = (supralinear(x["default bones"], g) for x in (lat_images, sup_images))
        ls, ss = (100 * np.nanmean(R.region_shares(x, mat), 0) for x in (lat, sup))
        lines.append(f"| {g:.1f} | {ls[1]:.1f} | {ls[2]:.1f} | {ls[3]:.1f} | "
                     f"{np.max(np.abs(ls - real_mean['lateral'])):.1f} | {np.median(R.contact_area(lat, mat)[0]):.0f} | "
                     f"{ss[1]:.1f} | {ss[3]:.1f} | {np.max(np.abs(ss - real_mean['supine'])):.1f} | "
                     f"{np.median(R.contact_area(sup, mat)[0]):.0f} |")
    real_area = {p: np.median(R.contact_area(real.pressure[real.posture == p], mat)[0]) for p in ("lateral", "supine")}
    lines.append(f"| real | {real_mean['lateral'][1]:.1f} | {real_mean['lateral'][2]:.1f} | {real_mean['lateral'][3]:.1f} "
                 f"| | {real_area['lateral']:.0f} | {real_mean['supine'][1]:.1f} | {real_mean['supine'][3]:.1f} | | "
                 f"{real_area['supine']:.0f} |")
    lines.append(f"\n({len(lat_images['default bones'])} side-lying and {len(sup_images['default bones'])} supine "
                 "bodies pressed with every set of bones.)")
    text = "\n".join(lines)
    print(text)
    if not args.no_write:
        write_section("lateral-shoulder", text)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
