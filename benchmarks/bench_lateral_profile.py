"""Where along the bed side-lying people load the mat, simulated against real, and the neck's part in it
(issue 12).

    .venv/bin/python -m benchmarks.bench_lateral_profile [--count 40] [--seed 31]
        [--data ../shared/data/pmd-experiment-i] [--out runs/bench_lateral_shoulder] [--no-write]

Simulated side-lying bodies put less of their load on the shoulder band than PMD-I's people
(``bench_lateral_shoulder``). The region shares are cut at fixed fractions of the contact extent
from its head end, so they also depend on where the shoulder lies below that end. Three measures:

1. **The load along the bed from the head end**, in bands of 5 % of the stature (real people's
   measured heights, simulated bodies' model statures), for real and simulated side-lying and
   supine images: where the shoulder's load lies below the head.
2. **The same rests re-posed and pressed again** (no settling; the lowest point kept where it was):
   the lower collar raised toward the head (a shrugged lower shoulder), the neck and head flexed
   forward (chin toward the chest), or the lower shoulder girdle glided toward the head along the
   ribs (joint offsets, ``BodyModel.forward``), to see which moves the simulated profile toward the
   real one.
3. **Settled with the neck's springs resting flexed** (``SettleConfig.lateral_neck_flexion_deg``,
   for bodies drawn on their side): the region shares against all of PMD-I and against its two
   groups of people (a setting chosen on some people should suit the others), as drawn and with
   like postures compared (``realism --match-extent``), the head imprint rate, and the attempts
   and CPU it takes per accepted body.

Reads (and makes if missing) ``bench_lateral_shoulder``'s datasets in OUT, and keeps its settled
sets in OUT/neck_flexion_<deg>/, so a rerun resumes. Replaces the ``bench:lateral-profile`` section
of docs/RESULTS.md and draws docs/sim_to_real_lateral.png, real and simulated side-lying images side by side
(``--no-write`` only prints). Real images only measure; nothing is trained on them.
"""

from __future__ import annotations

import datetime
import platform
from pathlib import Path

import numpy as np
from tqdm import tqdm

from benchmarks.bench_lateral_shoulder import make_set, parse_args
from benchmarks.bench_people_fit import subject_range
from benchmarks.bench_spine import simulate_set, subset
from benchmarks.results import write_section

REPOSED = (("shrug", 20.0), ("shrug", 35.0), ("tilt", 20.0), ("tilt", 40.0), ("flex", 20.0), ("flex", 40.0),
           ("flex", 60.0), ("glide", 3.0), ("glide", 5.0), ("glide", 8.0), ("flex40_glide", 5.0), ("widen", 2.0),
           ("widen", 4.0))
HEAD_BAND = 0.11                 # the head's load: within this fraction of the stature below the head end
SHOULDER_BAND = (0.08, 0.35)     # where the shoulder's peak row is looked for, fraction of the stature
SETTLED_FLEXION = (0.0, 40.0, 60.0)  # 0: the default settle, the same draws (its CPU measured alike)
COLLARS, SHOULDERS, NECK_HEAD, CHEST = (13, 14), (16, 17), (12, 15), (6, 9)  # SMPL joint indices


def first_rows(images, fraction: float = 0.02) -> np.ndarray:
    """(N,) the first row of each image (N, rows, cols) whose load exceeds ``fraction`` of its most
    loaded row's: where the head end lies on the mat as recorded."""
    p = np.asarray(images, dtype=np.float64)
    rows = p.sum(2)
    return np.argmax(rows > fraction * rows.max(1, keepdims=True), axis=1)


def real_first_rows(folder) -> np.ndarray:
    """(N,) :func:`first_rows` of the raw recordings behind ``load_real(folder, ...)``'s images, in
    its order (row 0: the mat's top edge, beyond which a head could lie unrecorded)."""
    from pressurepose.data.readers.real import read_real
    from pressurepose.eval.realism_report import real_selection

    real = read_real(folder, frames="one")
    return first_rows(np.asarray(real.images)[real_selection(real)])


def _compose(pose: np.ndarray, joint: int, rotvec) -> None:
    from scipy.spatial.transform import Rotation

    own = slice(3 * joint, 3 * joint + 3)
    turn = Rotation.from_rotvec(np.asarray(rotvec, dtype=np.float64))
    pose[own] = (turn * Rotation.from_rotvec(pose[own])).as_rotvec()


def repose(pose, joints, how: str, deg: float) -> np.ndarray:
    """A copy of the SMPL pose (72,) of a body whose joints (24, 3) lie in the bed frame (z up),
    re-posed: ``shrug`` raises the lower collar by ``deg`` toward the head (SMPL z: + raises the
    left shoulder, - the right); ``tilt`` bends the neck and head sideways toward the lower shoulder
    by ``deg`` in all, half at each (SMPL z: + toward the right); ``flex`` flexes them forward
    (SMPL x)."""
    p = np.array(pose, dtype=np.float64, copy=True).reshape(-1)
    j = np.asarray(joints, dtype=np.float64)
    if p.shape != (72,) or j.shape != (24, 3):
        raise ValueError(f"pose {p.shape} and joints {j.shape}: expected (72,) and (24, 3)")
    a = np.radians(deg)
    left_lower = j[SHOULDERS[0], 2] < j[SHOULDERS[1], 2]
    if how == "shrug":
        _compose(p, COLLARS[0] if left_lower else COLLARS[1], [0.0, 0.0, a if left_lower else -a])
    elif how in ("tilt", "flex"):
        turn = [a / 2, 0.0, 0.0] if how == "flex" else [0.0, 0.0, -a / 2 if left_lower else a / 2]
        for k in NECK_HEAD:
            _compose(p, k, turn)
    else:
        raise ValueError(f"repose how={how!r}: expected 'shrug', 'tilt' or 'flex'")
    return p


def glide_offsets(joints, cm: float, outward: bool = False) -> np.ndarray:
    """Joint offsets (24, 3) (``BodyModel.forward``) that move the lower shoulder girdle of a body
    whose joints (24, 3) lie in the bed frame by ``cm``: toward the head along the trunk (its collar's
    rest place moved along the parent's +y: the scapula riding up the ribs, which no SMPL rotation
    expresses), or with ``outward`` away from the trunk's mid-plane (a broader shoulder that stands
    further out beyond the ribs). The arm and the skin on it follow."""
    j = np.asarray(joints, dtype=np.float64)
    if j.shape != (24, 3):
        raise ValueError(f"joints {j.shape}: expected (24, 3)")
    left_lower = j[SHOULDERS[0], 2] < j[SHOULDERS[1], 2]
    off = np.zeros((24, 3))
    if outward:  # the model's +x is the body's left
        off[COLLARS[0] if left_lower else COLLARS[1], 0] = (1.0 if left_lower else -1.0) * cm / 100.0
    else:
        off[COLLARS[0] if left_lower else COLLARS[1], 1] = cm / 100.0
    return off


def posed_variant(pose, joints, how, amount: float) -> tuple[np.ndarray, np.ndarray | None]:
    """A rest's pose (72,) and joint offsets (or None) re-posed by ``how``: None (as it is), ``glide``
    or ``widen`` (:func:`glide_offsets` toward the head or outward, ``amount`` cm), ``flex40_glide`` (the neck and head flexed 40 degrees and
    the girdle glided ``amount`` cm), or one of :func:`repose`'s (``amount`` degrees)."""
    if how is None:
        return np.asarray(pose, dtype=np.float64), None
    if how in ("glide", "widen"):
        return np.asarray(pose, dtype=np.float64), glide_offsets(joints, amount, outward=how == "widen")
    if how == "flex40_glide":
        return repose(pose, joints, "flex", 40.0), glide_offsets(joints, amount)
    return repose(pose, joints, how, amount), None


def head_to_shoulder(images, mat, heights) -> np.ndarray:
    """(N, 3) per image (N, rows, cols) of people ``heights`` (N,) m tall, as fractions of the
    stature below the head end of the contact: the head's load centroid (the rows within
    :data:`HEAD_BAND`), the shoulder's peak row (the most loaded row within :data:`SHOULDER_BAND`)
    and the gap between them; NaN rows for images without a head load."""
    from pressurepose.eval import realism as R

    p = np.asarray(images, dtype=np.float64)
    h = np.asarray(heights, dtype=np.float64).reshape(-1)
    ext = R.body_extent(p, mat)
    below = ((np.arange(p.shape[1]) + 0.5)[None] - ext[:, :1]) * mat.pitch_row_m / h[:, None]
    out = np.full((len(p), 3), np.nan)
    for i, rows in enumerate(p.sum(2)):
        head = (below[i] >= 0) & (below[i] < HEAD_BAND)
        band = (below[i] >= SHOULDER_BAND[0]) & (below[i] < SHOULDER_BAND[1])
        if rows[head].sum() <= 0 or not band.any():
            continue
        centroid = (rows[head] * below[i, head]).sum() / rows[head].sum()
        peak = below[i, band][np.argmax(rows[band])]
        out[i] = centroid, peak, peak - centroid
    return out


def side_lying(poses) -> np.ndarray:
    """(N,) bool for SMPL poses (N, 72): the root rolled within 45 degrees of either side."""
    from pressurepose.pose.posture import roll_angle

    return np.abs(np.abs(np.degrees(roll_angle(np.asarray(poses).reshape(-1, 72)))) - 90.0) <= 45.0


def side_lying_rests(paths, desc: str | None = None):
    """Yield (body, bed, sample) for every side-lying rest (:func:`side_lying`) of the datasets
    ``paths``, each with the body model and bed it was made with (a progress bar when ``desc``)."""
    from pressurepose.data.dataset import DatasetReader
    from pressurepose.data.physics import setup

    for path in paths:
        reader = DatasetReader(path)
        body, bed = setup(reader.datasets[0].manifest.config)
        for s in (tqdm(reader, desc=f"{desc} {path.name}", leave=False) if desc else reader):
            if side_lying(s.pose)[0]:
                yield body, bed, s


def repressed(paths, variants) -> tuple[dict, np.ndarray]:
    """Every side-lying rest of the datasets ``paths`` (:func:`side_lying_rests`) re-posed by each of
    ``variants`` ((how, amount) as :func:`posed_variant` takes them; (None, 0) the rest as it is) and
    pressed again with its lowest point where it rested: ({variant: (N, R, C) mmHg}, statures (N,));
    bodies one variant cannot balance are left out of all."""
    from pressurepose.sim.press import PressFailed, press
    from pressurepose.sim.tissue import body_bones

    images, heights = {v: [] for v in variants}, []
    for body, bed, s in side_lying_rests(paths, "re-posed"):
        b, t = (np.asarray(x, dtype=np.float64) for x in (s.betas, s.transl))
        lowest = body.forward(b, np.asarray(s.pose, np.float64), t)[0][0, :, 2].min()
        got = {}
        try:
            for how, amount in variants:
                p, off = posed_variant(s.pose, s.joints, how, amount)
                t2 = t.copy()
                t2[2] += lowest - body.forward(b, p, t, off)[0][0, :, 2].min()
                verts, _ = body.forward(b, p, t2, off)
                bones = body_bones(body, b, p, t2, bed.tissue_bone_fraction, offsets=off)
                got[(how, amount)] = press(verts[0], body.faces, float(s.mass), bed, bones=bones).pressure
        except PressFailed:
            continue
        for v in variants:
            images[v].append(got[v])
        heights.append(float(s.height))
    return {v: np.array(x) for v, x in images.items()}, np.array(heights)


def settled_flexed(out: Path, deg: float, count: int, seed: int) -> list[Path]:
    """``general_lateral`` bodies of both genders settled with the neck's springs flexed by ``deg``
    (0: the default settle), made if missing."""
    from pressurepose.sim.settle import SettleConfig

    folder = out / f"neck_flexion_{deg:g}"
    folder.mkdir(parents=True, exist_ok=True)
    paths = []
    for g in ("f", "m"):
        path = folder / f"general_lateral_{g}_{count}_{seed}.npz"
        if not path.is_file():
            simulate_set(path, "general_lateral", g, count, seed, SettleConfig(lateral_neck_flexion_deg=deg))
        paths.append(path)
    return paths


def _cost(paths) -> tuple[int, int, float]:
    """(accepted bodies, attempts, CPU s) of :func:`settled_flexed`'s sets."""
    acc = att = 0
    cpu = 0.0
    for p in paths:
        with np.load(p, allow_pickle=False) as z:
            acc += len(z["pressure"])
            att += int(z["attempts"])
            cpu += float(z["cpu_s"])
    return acc, att, cpu


def head_touches(paths, radius_m: float = 0.10) -> float:
    """Share of the side-lying bodies (roll within 45 degrees of a side) of :func:`settled_flexed`'s
    sets with contact (over 5 mmHg) within ``radius_m`` of their head joint: whether heads touch,
    whatever the image-only imprint rule finds."""
    from pressurepose.sim.bed import get_bed

    centres = get_bed().taxel_centers()
    hits = []
    for p in paths:
        with np.load(p, allow_pickle=False) as z:
            side = side_lying(z["pose"])
            for img, j in zip(z["pressure"][side], z["joints"][side]):
                hits.append(bool((img[np.linalg.norm(centres - j[15, :2], axis=-1) < radius_m] > 5.0).any()))
    return float(np.mean(hits))


def standout(body, betas, pose, transl, offsets=None) -> tuple[float, float]:
    """How high the lower shoulder's and the chest's skin lie above a posed body's lowest point (m):
    the lowest vertex skinned mostly to the lower collar or shoulder joint (the top of the shoulder and
    the upper arm), and to the spine2 or spine3 joint (the ribcage); ``offsets`` as ``BodyModel.forward``
    takes them. A body lying on its side whose shoulder stands out beyond its ribs, as a real shoulder
    does, has the chest higher than the shoulder."""
    v, j = body.forward(betas, pose, transl, offsets)
    v, j = v[0], j[0]
    dom = body.arrays.weights.argmax(1)
    lower = (COLLARS[0], SHOULDERS[0]) if j[SHOULDERS[0], 2] < j[SHOULDERS[1], 2] else (COLLARS[1], SHOULDERS[1])
    low = v[:, 2].min()
    return float(v[np.isin(dom, lower), 2].min() - low), float(v[np.isin(dom, CHEST), 2].min() - low)


def standouts(paths) -> np.ndarray:
    """(N, 2) :func:`standout` of every side-lying rest of the datasets ``paths`` (:func:`side_lying_rests`)."""
    out = [standout(body, *(np.asarray(x, dtype=np.float64) for x in (s.betas, s.pose, s.transl)))
           for body, _, s in side_lying_rests(paths)]
    return np.array(out).reshape(-1, 2)


FIGURE = Path(__file__).resolve().parents[1] / "docs" / "sim_to_real_lateral.png"


def head_aligned(images, mat, rows: int = 40) -> np.ndarray:
    """(N, rows, C) each image (N, R, C) cut from the head end of its contact extent
    (``realism.body_extent``) for ``rows`` rows, zero-padded: images lined up by the head."""
    from pressurepose.eval import realism as R

    p = np.asarray(images, dtype=np.float64)
    ext = R.body_extent(p, mat)
    out = np.zeros((len(p), rows, p.shape[2]))
    for i, im in enumerate(p):
        part = im[max(0, int(np.floor(ext[i, 0]))):][:rows]
        out[i, :len(part)] = part
    return out


def side_by_side_figure(real_images, sim_images, mat, path: Path, n: int = 6, seed: int = 0) -> None:
    """Save ``n`` real and ``n`` simulated side-lying images (drawn with ``seed``) and the mean of each
    set lined up by the head end, one colour scale (mmHg), to ``path``."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    rng = np.random.default_rng(seed)
    aspect = mat.pitch_row_m / mat.pitch_col_m
    fig, ax = plt.subplots(2, n + 1, figsize=(1.6 * (n + 1) + 1, 7.5), layout="constrained")
    for r, (imgs, name) in enumerate(((real_images, "real"), (sim_images, "simulated"))):
        for k, i in enumerate(rng.choice(len(imgs), n, replace=False)):
            im = ax[r, k].imshow(imgs[i], cmap="magma", vmin=0, vmax=60, aspect=aspect)
            ax[r, k].set_title(f"{name} #{i}", fontsize=8)
        mean = head_aligned(imgs, mat).mean(0)
        ax[r, n].imshow(mean, cmap="magma", vmin=0, vmax=mean.max(), aspect=aspect)
        ax[r, n].set_title(f"{name}: mean of {len(imgs)},\nlined up by the head end", fontsize=8)
    for a in ax.ravel():
        a.set_xticks([])
        a.tick_params(labelsize=6)
    fig.colorbar(im, ax=ax[:, n], shrink=0.5, label="mmHg (examples)")
    fig.suptitle("Side lying: PMD-I (top) against today's default settle (bottom), row 0 at the head end.\n"
                 "Real shoulders carry a compact peak just below the head; simulated chests load the mattress "
                 "along the ribs.", fontsize=9)
    fig.savefig(path, dpi=70)
    plt.close(fig)


def main(argv=None) -> int:
    args = parse_args(__doc__, argv)
    from pressurepose.eval import realism as R
    from pressurepose.eval.realism_report import (
        ImageSet,
        headline,
        load_real,
        load_synthetic,
        realism_report,
    )
    from pressurepose.mat import get_mat

    mat = get_mat("boditrak_bt3510")
    real = load_real(args.data, mat)
    lateral = [make_set(args.out, "general_lateral", g, args.count, args.seed) for g in ("f", "m")]
    supine = [make_set(args.out, "general_supine", g, args.count, args.seed) for g in ("f", "m")]

    def images(paths) -> ImageSet:
        sets = [load_synthetic(p) for p in paths]
        cat = lambda k: np.concatenate([getattr(s, k) for s in sets])  # noqa: E731
        return ImageSet("simulated", cat("pressure"), cat("posture"), mat, cat("force"), cat("mass"), cat("height"))

    sim_lat, sim_sup = images(lateral), images(supine)
    flexed = {d: settled_flexed(args.out, d, args.count, args.seed) for d in SETTLED_FLEXION}
    sim_flex = {d: images(p) for d, p in flexed.items()}

    # 1. profiles
    def prof(s: ImageSet, posture: str) -> np.ndarray:
        keep = s.posture == posture
        return np.nanmean(R.load_profile(s.pressure[keep], mat, s.height[keep]), 0)

    clear = real_first_rows(args.data) >= 2
    lat_clear = (real.posture == "lateral") & clear
    columns = [("real side-lying", prof(real, "lateral")),
               (f"real side-lying, head 2+ rows below the mat's edge ({lat_clear.sum()})",
                np.nanmean(R.load_profile(real.pressure[lat_clear], mat, real.height[lat_clear]), 0)),
               ("simulated side-lying", prof(sim_lat, "lateral")),
               ("simulated side-lying, neck flexed 40 deg", prof(sim_flex[40.0], "lateral")),
               ("real supine", prof(real, "supine")), ("simulated supine", prof(sim_sup, "supine"))]
    lines = ["## Side-lying load along the bed, and the neck (`benchmarks/bench_lateral_profile.py`)", "",
             f"{datetime.date.today()}, {platform.platform()}; the {args.count} `general_lateral` and "
             f"`general_supine` bodies per gender (seed {args.seed}) of section lateral-shoulder, default physics "
             "and bed. Real: PMD-I flat-bed images as `realism` reads them. Reproduce: "
             "`python -m benchmarks.bench_lateral_profile`.", "",
             "**1. Percent of the load in bands of 5 % of the stature below the head end of the contact** "
             "(real: measured heights; simulated: model statures; mean over images):", "",
             "| below the head end | " + " | ".join(n for n, _ in columns) + " |",
             "|---|" + "---|" * len(columns)]
    for k in range(len(columns[0][1])):
        lines.append(f"| {100 * R.PROFILE_BAND * k:.0f}-{100 * R.PROFILE_BAND * (k + 1):.0f} % | "
                     + " | ".join(f"{c[k]:.1f}" for _, c in columns) + " |")
    lines += ["", "From the head to the shoulder (medians, fractions of the stature below the head end: the head's "
              "load centroid, the most loaded row 0.08-0.35 below it, and the gap):", "",
              "| images | head centroid | shoulder peak | gap |", "|---|---|---|---|"]
    for name, st, posture in (("real side-lying", real, "lateral"), ("simulated side-lying", sim_lat, "lateral"),
                              ("simulated side-lying, neck flexed 40 deg", sim_flex[40.0], "lateral"),
                              ("real supine", real, "supine"), ("simulated supine", sim_sup, "supine")):
        keep = st.posture == posture
        hs = np.nanmedian(head_to_shoulder(st.pressure[keep], mat, st.height[keep]), 0)
        lines.append(f"| {name} | {hs[0]:.3f} | {hs[1]:.3f} | {hs[2]:.3f} |")

    lines += ["", "Per region (medians over images): contact taxels over 5 mmHg and the mean reading over them, real / "
              "simulated (`realism.region_contact`):", "",
              "| region | side-lying taxels | side-lying mmHg | supine taxels | supine mmHg |", "|---|---|---|---|---|"]
    rc = {(who, post): np.nanmedian(R.region_contact(st.pressure[st.posture == post], mat), 0)
          for who, post, st in (("real", "lateral", real), ("real", "supine", real), ("sim", "lateral", sim_lat),
                                ("sim", "supine", sim_sup))}
    for k, region in enumerate(R.REGIONS):
        lines.append(f"| {region} | " + " | ".join(
            f"{rc[('real', post)][k, q]:.{0 if q == 0 else 1}f} / {rc[('sim', post)][k, q]:.{0 if q == 0 else 1}f}"
            for post in ("lateral", "supine") for q in (0, 1)) + " |")

    so = standouts(lateral)
    gap = so[:, 1] - so[:, 0]
    lines += ["", f"Where the side-lying rests touch ({len(so)} bodies as settled; medians, 25-75 %, cm above the "
              "body's lowest point): the lower shoulder's skin (vertices skinned mostly to its collar or shoulder "
              f"joint: the top of the shoulder and the upper arm) {100 * np.median(so[:, 0]):.1f} ({100 * np.percentile(so[:, 0], 25):.1f}-"
              f"{100 * np.percentile(so[:, 0], 75):.1f}), the chest's (spine2, spine3) {100 * np.median(so[:, 1]):.1f} "
              f"({100 * np.percentile(so[:, 1], 25):.1f}-{100 * np.percentile(so[:, 1], 75):.1f}); the chest lies "
              f"{100 * np.median(gap):.1f} cm above the shoulder (median per body), and below it in "
              f"{np.mean(gap < 0):.2f} of the bodies."]

    # 2. re-posed rests
    side = real.posture == "lateral"
    real_lat = 100 * np.nanmean(R.region_shares(real.pressure[side], mat), 0)
    real_band = np.nanmean(R.load_profile(real.pressure[side], mat, real.height[side])[:, 2:4].sum(1))
    real_gap = np.nanmedian(head_to_shoulder(real.pressure[side], mat, real.height[side])[:, 2])
    variants = [(None, 0.0)] + list(REPOSED)
    rep, rep_h = repressed(lateral, variants)
    lines += ["", "**2. The same side-lying rests re-posed and pressed again** (no settling; region shares, % of the "
              "load; worst gap: the largest difference from the real shares):", "",
              "| rest | " + " | ".join(R.REGIONS) + " | worst gap (pp) | load 10-20 % below the head end | "
              "head to shoulder peak |",
              "|---|" + "---|" * (len(R.REGIONS) + 3),
              "| real | " + " | ".join(f"{x:.1f}" for x in real_lat) + f" | | {real_band:.1f} | {real_gap:.3f} |"]
    names = {None: "as settled", "shrug": "lower collar raised {:g} deg",
             "tilt": "neck and head bent {:g} deg toward the lower shoulder", "flex": "neck and head flexed {:g} deg",
             "glide": "lower shoulder girdle glided {:g} cm toward the head",
             "flex40_glide": "neck and head flexed 40 deg, girdle glided {:g} cm",
             "widen": "lower shoulder girdle moved {:g} cm outward"}
    for v in variants:
        shares = 100 * np.nanmean(R.region_shares(rep[v], mat), 0)
        band = np.nanmean(R.load_profile(rep[v], mat, rep_h)[:, 2:4].sum(1))
        gap = np.nanmedian(head_to_shoulder(rep[v], mat, rep_h)[:, 2])
        lines.append(f"| {names[v[0]].format(v[1])} | " + " | ".join(f"{x:.1f}" for x in shares)
                     + f" | {np.max(np.abs(shares - real_lat)):.1f} | {band:.1f} | {gap:.3f} |")
    lines.append(f"\n({len(rep_h)} side-lying bodies, each pressed with every rest.)")

    # 3. settled with the neck flexed
    first = np.array([int(s) in subject_range("1-7") for s in real.subject])
    groups = (("all", real), ("1-7", subset(real, first)), ("8-13", subset(real, ~first)))
    lines += ["", "**3. Settled with the neck's springs resting flexed** "
              "(`SettleConfig(lateral_neck_flexion_deg=...)`, "
              "bodies drawn on their side; the same draws as the default's, so the bodies differ only where "
              "an attempt's outcome does). Worst share gap in pp (90 % interval, real images resampled by person) "
              "against PMD-I's people 1-13, 1-7 and 8-13; head imprint rate by the image rule (real 0.96) and "
              "by the head joint (contact within 10 cm of it); attempts and CPU per accepted body:", "",
              "| neck flexion | comparison | shoulders % (real 25.6) | back % (real 12.5) | worst gap, all | "
              "worst gap, 1-7 | worst gap, 8-13 | head imprint, rule / joint | area ratio | attempts per body | "
              "CPU s per body |", "|---|---|---|---|---|---|---|---|---|---|---|"]
    for deg in SETTLED_FLEXION:
        sim = sim_flex[deg]
        acc, att, cpu = _cost(flexed[deg])
        touch = head_touches(flexed[deg])
        for match in (False, True):
            cells, first_h = [], None
            for _, people in groups:
                h = next(x for x in headline(realism_report(people, sim, match=match)) if x["posture"] == "lateral")
                first_h = first_h or h
                lo, hi = h["share_worst_pp_interval"]
                cells.append(f"{h['share_worst_pp']:.1f} ({lo:.1f}-{hi:.1f})")
            cost = f"{att / acc:.2f} | {cpu / acc:.2f}"
            name = f"{deg:g} deg{' (default)' if deg == 0 else ''}"
            lines.append(f"| {name} | {'like postures' if match else 'as drawn'} | "
                         f"{100 * first_h['share_sim']['shoulders']:.1f} | {100 * first_h['share_sim']['back']:.1f} | "
                         + " | ".join(cells)
                         + f" | {first_h['head_sim']:.2f} / {touch:.2f} | {first_h['area_ratio']:.2f} | {cost} |")
    text = "\n".join(lines)
    print(text)
    if not args.no_write:
        write_section("lateral-profile", text)
        side_by_side_figure(real.pressure[real.posture == "lateral"], sim_lat.pressure[sim_lat.posture == "lateral"],
                            mat, FIGURE)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
