"""Sampler fidelity: our supine joint-angle marginals against the public sampler's own output.

    OMP_NUM_THREADS=1 .venv/bin/python -m benchmarks.bench_sampler_fidelity [--official PATH] [--count 2700]
        [--seed 0] [--no-write]

The reference is the 2700 supine female initial poses the paper's public repository ships
(Healthcare-Robotics/bodies-at-rest, ``all_rand_nom_endhtbicheck_roll0_f_lay_set10_2700_fix.npy``;
found at ``--official``, ``$PRESSUREPOSE_OFFICIAL_SAMPLER`` or ``../shared/data/official-sampler/
supine_f_2700.npy`` beside the checkout). Draws ``pressurepose sample --partition general_supine
--gender f --count 2700 --seed 0`` and prints, per sampled degree of freedom, both means and the
1-D Wasserstein distance (degrees), with the mean and largest distance (goal: mean <= 2.5, none
above 6); then replaces the ``bench:sampler-fidelity`` section of docs/RESULTS.md.

Also measured: the same with the opt-in into_bed test at its former default (5 cm), the drift's
main cause; and, as evidence for the residual: the share of wrists more than 10 cm medial of their
shoulder (over the chest), both pose sets posed on our mean female body, and the share of leg
poses whose ankle lies more than 0.2 m from the hip's height on that body.
"""

from __future__ import annotations

import argparse
import datetime
import os
import platform
import time
from pathlib import Path

import numpy as np

from benchmarks.results import write_section
from pressurepose.pose import SamplerConfig, sample_bodies
from pressurepose.pose.config import PAPER_SETTINGS, paper_sampler
from pressurepose.pose.fidelity import (
    SAMPLED_DOFS,
    marginal_distances,
    pose_from_indexed,
)

REPO = Path(__file__).resolve().parents[1]
OFFICIAL_NAME = "supine_f_2700.npy"
GOAL_MEAN, GOAL_MAX = 2.5, 6.0


def official_path(given: str | None = None) -> Path | None:
    """The official supine file: ``given``, else $PRESSUREPOSE_OFFICIAL_SAMPLER, else the shared data
    folder beside the checkout (main or a worktree); None if none exists."""
    candidates = [given, os.environ.get("PRESSUREPOSE_OFFICIAL_SAMPLER")]
    for root in (REPO.parent, REPO.parent.parent):
        candidates.append(str(root / "shared" / "data" / "official-sampler" / OFFICIAL_NAME))
    for c in candidates:
        if c and Path(c).is_file():
            return Path(c)
    return None


def load_official(path: Path) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """betas (N, 10), pose (N, 72) and yaw (N,) of the public sampler's file.

    It is a Python 2 object array, so reading it unpickles: do this only for this one public file
    from a known source (its README in the shared data folder), never for files a user passes in.
    """
    rows = np.load(path, allow_pickle=True, encoding="latin1")
    betas = np.array([np.asarray(r[0], dtype=np.float64) for r in rows])
    pose = pose_from_indexed([r[1] for r in rows], [r[2] for r in rows])
    yaw = np.array([float(np.ravel(r[3])[0]) for r in rows])
    return betas, pose, yaw


def geometry_shares(pose: np.ndarray, body) -> dict:
    """On the body's mean shape, limbs only (root at rest): the share of wrists more than 0.1 m
    medial of their shoulder, and of ankles more than 0.2 m above or below their hip (SMPL frame,
    face +z = up for a supine body)."""
    from pressurepose.body.joints import joint_index as J
    from pressurepose.body.lbs_numpy import forward_kinematics, rodrigues, shaped_rest

    p = pose.reshape(-1, 24, 3).copy()
    p[:, 0] = 0.0
    _, rest = shaped_rest(body.arrays, np.zeros((1, 10)))
    pos = forward_kinematics(rodrigues(p), np.repeat(rest, len(p), 0), body.parents)[..., :3, 3]
    medial = [-sign * (pos[:, J(f"{s}_wrist"), 0] - pos[:, J(f"{s}_shoulder"), 0]) > 0.1
              for s, sign in (("left", 1.0), ("right", -1.0))]
    out_of_band = [np.abs(pos[:, J(f"{s}_ankle"), 2] - pos[:, J(f"{s}_hip"), 2]) > 0.2 for s in ("left", "right")]
    return {"medial_wrists": float(np.mean(medial)), "ankles_out_of_band": float(np.mean(out_of_band))}


def main(argv=None) -> int:
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    p.add_argument("--official", default=None, help="the public sampler's supine file (see the module doc)")
    p.add_argument("--count", type=int, default=2700, help="bodies to draw [2700, as many as the reference]")
    p.add_argument("--seed", type=int, default=0, help="sampler seed [0]")
    p.add_argument("--no-write", action="store_true", help="print only; leave docs/RESULTS.md alone")
    args = p.parse_args(argv)
    path = official_path(args.official)
    if path is None:
        print(f"official sampler file {OFFICIAL_NAME} not found (give --official PATH); nothing measured")
        return 2
    from pressurepose.body import BodyModel

    body = BodyModel("female")
    _, ref, _ = load_official(path)
    c0 = time.process_time()
    batch = sample_bodies("general_supine", "f", args.count, seed=args.seed, body=body, config=paper_sampler())
    cpu = time.process_time() - c0
    w1 = marginal_distances(batch.pose, ref)
    # the main cause of the drift, measured live: the opt-in into_bed test at its former default
    sunk = sample_bodies("general_supine", "f", args.count, seed=args.seed, body=body,
                         config=paper_sampler(max_limb_sink=0.05))
    w1_sunk = marginal_distances(sunk.pose, ref)
    # the project's defaults (no hanging limbs, centred placement, normal shapes): not the paper's sampler
    w1_default = marginal_distances(sample_bodies("general_supine", "f", args.count, seed=args.seed, body=body).pose,
                                    ref)
    unit = SamplerConfig(collision_radius_scale=1.0, **PAPER_SETTINGS)
    w1_unit = marginal_distances(sample_bodies("general_supine", "f", args.count, seed=args.seed, body=body,
                                               config=unit).pose, ref)
    ours_geo, ref_geo = geometry_shares(batch.pose, body), geometry_shares(ref, body)
    lines = [
        "## Sampler fidelity (`benchmarks/bench_sampler_fidelity.py`)",
        "",
        f"{datetime.date.today().isoformat()}, {platform.platform()}, one thread. `pressurepose sample "
        f"--partition general_supine --gender f --count {args.count} --seed {args.seed} --shapes uniform "
        f"--placement uniform --hanging-limbs` (the paper's sampler settings; {args.count / cpu:.0f} "
        f"bodies per CPU second) against the public sampler's {len(ref)} supine female initial poses "
        f"(`{OFFICIAL_NAME}`). Per sampled degree of freedom: means and the 1-D Wasserstein distance W1, "
        "degrees (goal: mean W1 <= 2.5, none above 6).",
        "",
        "| DOF | official mean | ours mean | W1 | W1 with into_bed 5 cm |",
        "|---|---|---|---|---|",
    ]
    for (name, i), d, d_sunk in zip(SAMPLED_DOFS, w1, w1_sunk):
        lines.append(f"| {name} | {np.rad2deg(ref[:, i]).mean():.1f} | {np.rad2deg(batch.pose[:, i]).mean():.1f} "
                     f"| {d:.2f} | {d_sunk:.2f} |")
    worst = SAMPLED_DOFS[int(np.argmax(w1))][0]
    lines += [
        "",
        f"Mean W1 {w1.mean():.2f} deg, largest {w1.max():.2f} deg ({worst}); with the into_bed test "
        f"(`SamplerConfig(max_limb_sink=0.05)`, the default before issue 15) {w1_sunk.mean():.2f} and "
        f"{w1_sunk.max():.2f}. Before issue 15 (into_bed on, bins along the body): mean 4.31, largest 13.86 "
        f"(left hip x). With the self-collision capsules at their own radii (`collision_radius_scale=1.0`, "
        f"before this section's 1.2) {w1_unit.mean():.2f} and {w1_unit.max():.2f}. The project's default "
        f"sampler (no limb over the mattress's edge, centred placement, normal shapes) is not the paper's "
        f"and is not held to its marginals: {w1_default.mean():.2f} and {w1_default.max():.2f} (the rule that "
        "keeps every limb joint 10 cm inside the mattress's sides folds the arms in).",
        "",
        "Posed on our mean female body (limbs only): wrists more than 10 cm medial of their shoulder "
        f"(over the chest) official {100 * ref_geo['medial_wrists']:.1f}%, "
        f"ours {100 * ours_geo['medial_wrists']:.1f}%; "
        f"ankles more than 0.2 m from their hip's height official {100 * ref_geo['ankles_out_of_band']:.1f}%, "
        f"ours {100 * ours_geo['ankles_out_of_band']:.1f}% (the public code held them within 0.2 m on SMPL, whose rest "
        "ankle lies ~5 cm behind the hip; ours lies level with it).",
        "",
        "The residual is the body model, not the procedure (diagnostics run once, not by this script): "
        "moving our rest ankles 4.8 cm back in the limb tests (SMPL's rest ankle lies that far behind "
        "the hip) brings knee flexion from W1 2.4-3.5 to 0.8-1.0, and 4.5 cm medially (SMPL's ankle lies "
        "2 cm lateral of the hip, ours 6.4 cm) brings hip twist (y) from 2.2-2.9 to 0.4-1.1 (both: mean "
        "2.36), though hip abduction (z) then drifts to 4.5. The public code's collision capsules "
        "(SMPLify's regressor, each shifted 4 cm footward in its DART skeleton) cannot be rebuilt here, "
        "but its poses put fewer wrists over the "
        "chest (above), as fuller capsules would: scaling every capsule radius by 1.2 in our collision tests "
        "brings the largest W1, right shoulder y, from 7.1 to 4.6 and the mean to 2.24; that scale is "
        "applied (`SamplerConfig.collision_radius_scale`, default 1.2), the ankle offsets are not.",
    ]
    text = "\n".join(lines)
    print(text)
    if not args.no_write:
        write_section("sampler-fidelity", text)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
