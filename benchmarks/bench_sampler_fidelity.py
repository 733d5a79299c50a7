"""Sampler fidelity: the pose sampler's supine joint-angle marginals against the paper's public
sampler's own output.

    python -m benchmarks.bench_sampler_fidelity [--official PATH] [--count 2700] [--seed 0] [--no-write]

The comparison set is the 2700 supine female initial poses the paper's public repository ships
(Healthcare-Robotics/bodies-at-rest, ``all_rand_nom_endhtbicheck_roll0_f_lay_set10_2700_fix.npy``,
here ``supine_f_2700.npy``; found at ``--official``, ``$PRESSUREPOSE_OFFICIAL_SAMPLER`` or a
``shared/data/official-sampler`` folder beside the checkout; without it the benchmark says so and
measures nothing). Draws ``pressurepose sample --partition general_supine --gender f --count 2700
--seed 0`` with the paper's sampler settings and prints, per sampled degree of freedom, both means
and the 1-D Wasserstein distance (degrees), with the mean and largest distance (goal: mean <= 2.5,
none above 6), and the same for the project's default sampler; then replaces the
``bench:sampler-fidelity`` section of docs/RESULTS.md.
"""

from __future__ import annotations

import argparse
import os
import time
from pathlib import Path

import numpy as np

from benchmarks.common import stamp
from benchmarks.results import write_section
from pressurepose.pose import sample_bodies
from pressurepose.pose.config import paper_sampler
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
    p.add_argument("--count", type=int, default=2700, help="bodies to draw [2700, as many as the public file holds]")
    p.add_argument("--seed", type=int, default=0, help="sampler seed [0]")
    p.add_argument("--no-write", action="store_true", help="print only; leave docs/RESULTS.md alone")
    args = p.parse_args(argv)
    path = official_path(args.official)
    if path is None:
        print(f"bench_sampler_fidelity: skipped, the public sampler's file {OFFICIAL_NAME} was not found (give "
              "--official PATH or set PRESSUREPOSE_OFFICIAL_SAMPLER). Nothing measured, docs/RESULTS.md left as it is.")
        return 0
    from pressurepose.body import BodyModel

    body = BodyModel("female")
    _, ref, _ = load_official(path)
    c0 = time.process_time()
    batch = sample_bodies("general_supine", "f", args.count, seed=args.seed, body=body, config=paper_sampler())
    cpu = time.process_time() - c0
    w1 = marginal_distances(batch.pose, ref)
    # the project's defaults (no hanging limbs, centred placement, normal shapes): not the paper's sampler
    w1_default = marginal_distances(sample_bodies("general_supine", "f", args.count, seed=args.seed, body=body).pose,
                                    ref)
    ours_geo, ref_geo = geometry_shares(batch.pose, body), geometry_shares(ref, body)
    lines = [
        "## Sampler fidelity (`benchmarks/bench_sampler_fidelity.py`)",
        "",
        f"`python -m benchmarks.bench_sampler_fidelity --official PATH`; {stamp()}, one thread. `pressurepose sample "
        f"--partition general_supine --gender f --count {args.count} --seed {args.seed} --shapes uniform "
        f"--placement uniform --hanging-limbs` (the paper's sampler settings; {args.count / cpu:.0f} "
        f"bodies per CPU second) against the public sampler's {len(ref)} supine female initial poses "
        f"(`{OFFICIAL_NAME}`). Per sampled degree of freedom: means and the 1-D Wasserstein distance W1, "
        f"degrees (goal: mean W1 <= {GOAL_MEAN:g}, none above {GOAL_MAX:g}).",
        "",
        "| DOF | official mean | ours mean | W1 |",
        "|---|---|---|---|",
    ]
    for (name, i), d in zip(SAMPLED_DOFS, w1):
        lines.append(f"| {name} | {np.rad2deg(ref[:, i]).mean():.1f} | {np.rad2deg(batch.pose[:, i]).mean():.1f} "
                     f"| {d:.2f} |")
    worst = SAMPLED_DOFS[int(np.argmax(w1))][0]
    met = w1.mean() <= GOAL_MEAN and w1.max() <= GOAL_MAX
    lines += [
        "",
        f"Mean W1 {w1.mean():.2f} deg, largest {w1.max():.2f} deg ({worst}): goal {'met' if met else '**not met**'}. "
        f"The project's default sampler (no limb over the mattress's edge, centred placement, normal shapes) is "
        f"not the paper's and is not held to its marginals: mean {w1_default.mean():.2f}, largest "
        f"{w1_default.max():.2f} (the rule that keeps every limb joint 10 cm inside the mattress's sides folds the "
        "arms in).",
        "",
        "Posed on the mean female body (limbs only): wrists more than 10 cm medial of their shoulder (over the "
        f"chest) official {100 * ref_geo['medial_wrists']:.1f} %, ours {100 * ours_geo['medial_wrists']:.1f} %; "
        f"ankles more than 0.2 m from their hip's height official {100 * ref_geo['ankles_out_of_band']:.1f} %, "
        f"ours {100 * ours_geo['ankles_out_of_band']:.1f} % (the public code held them within 0.2 m on SMPL, whose "
        "rest ankle lies about 5 cm behind the hip; ours lies level with it).",
    ]
    text = "\n".join(lines)
    print(text)
    if not args.no_write:
        write_section("sampler-fidelity", text)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
