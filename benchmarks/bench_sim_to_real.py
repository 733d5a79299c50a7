"""Why the shipped PressureNet misreads real pressure images: controlled sim-to-real experiments.

    .venv/bin/python -m benchmarks.bench_sim_to_real [--data ../shared/data/pmd-experiment-i]
        [--sim DATASET | --count 24] [--out runs/sim_to_real] [--no-write]

Feeds the shipped model (trained on simulated ``general_supine`` only) simulated images with known
bodies and real PhysioNet PMD experiment I images, each as they are and after one perturbation at a
time, and reports what moves the first shape coefficient (beta0) and the estimated stature:

1. the real-data path on simulated images: BodiTrak -> the FSA 64 x 32 grid (0.028 m) -> the
   evaluate-real preprocessing (:func:`pressurepose.data.realprep.prepare`: baseline, taxel repair,
   weight normalisation, resampling back), against the same images untouched;
2. image statistics as the network sees them (:func:`pressurepose.net.transforms.input_channels`):
   contact area, extent along and across the bed, intensity spread, row profile, and perturbations
   of simulated images toward real statistics (contact halo, blur, shift, stretch) and of real
   images away from them (diagnostic only: no fix is tuned on real data);
3. where bodies lie along the mat (first and last contact row, pelvis row) in simulated and real
   images, and where the estimate puts its root and its reconstructed pressure map (PMR).

Simulated set: ``--sim`` (a dataset folder) or, by default, ``--count`` general_supine bodies per
gender generated with seeds 931 / 932 (never used for training). Writes OUT/sim_to_real.json, the
figures docs/sim_to_real_inputs.png and docs/sim_to_real_stats.png, and replaces the
``bench:sim_to_real`` section of docs/RESULTS.md. Rerun it after simulator changes (issue 12) to see
whether the gap closes. Nothing here trains or tunes anything on real data.
"""

from __future__ import annotations

import argparse
import datetime
import os
import platform
from pathlib import Path

import numpy as np
from scipy import ndimage

from benchmarks.results import write_section

DOCS = Path(__file__).resolve().parents[1] / "docs"
DEFAULT_DATA = Path(__file__).resolve().parents[1].parent / "shared" / "data" / "pmd-experiment-i"
SUPINE_STRAIGHT = ("supine", "supine star", "supine hands crossed")  # PMD-I postures 1, 8, 9
G = 9.80665
MMHG_PA = 133.322


# ------------------------------------------------------------------------------------------ data
def load_real(data: Path, dst) -> dict:
    """PMD-I flat-bed images as model input (N, 64, 27) mmHg with height_m, weight_kg, detail."""
    from pressurepose.data.readers.real import read_real
    from pressurepose.data.realprep import prepare

    real = read_real(data)
    r = real.select(real.posture != "inclined")
    x = prepare(r.images, r.mat, r.units, dst, weight_kg=r.weight_kg, gain=r.gain)
    return {"x": x, "height": r.height_m.astype(np.float64), "weight": r.weight_kg.astype(np.float64),
            "detail": r.detail, "posture": r.posture, "supine": np.isin(r.detail, SUPINE_STRAIGHT)}


def real_contact_areas(data: Path, dst) -> dict:
    """Median area (m^2) of the real supine images' non-zero taxels at each step of the real-data path:
    as recorded (FSA grid), after baseline removal and taxel repair, and as model input (``dst``)."""
    from pressurepose.data.readers.real import read_real
    from pressurepose.data.realprep import prepare, remove_baseline, repair_taxels

    real = read_real(data)
    r = real.select(np.isin(real.detail, SUPINE_STRAIGHT))
    raw = r.images.astype(np.float64)
    area = lambda x, mat: float(np.median((x > 0).sum((1, 2)))) * mat.taxel_area_m2  # noqa: E731
    x = prepare(r.images, r.mat, r.units, dst, weight_kg=r.weight_kg, gain=r.gain)
    return {"recorded": area(raw, r.mat), "baseline_repaired": area(repair_taxels(remove_baseline(raw)), r.mat),
            "model_input": area(x, dst), "fsa_mat": r.mat.rows * r.mat.cols * r.mat.taxel_area_m2,
            "model_mat": dst.rows * dst.cols * dst.taxel_area_m2}


def make_sim(out: Path, count: int) -> Path:
    """general_supine, ``count`` per gender (seeds 931 / 932) under out; returns the root."""
    from pressurepose.cli import main as cli

    for gender, seed in (("f", 931), ("m", 932)):
        where = out / f"general_supine_{gender}"  # generate resumes: finished shards are kept
        assert cli(["generate", "--partition", "general_supine", "--gender", gender, "--count", str(count),
                    "--seed", str(seed), "--workers", "1", "--no-progress",
                    "--out", str(where)]) == 0
    return out


def load_sim(root: Path, net) -> dict:
    """Simulated images (N, R, C) mmHg with genders, true stature (m), mass, joints and transl."""
    from pressurepose.data.dataset import DatasetReader
    from pressurepose.data.schema import GENDERS

    d = DatasetReader(root).load_arrays(("pressure", "betas", "height", "mass", "joints", "transl"),
                                        image_dtype=np.float32)
    return {"x": d["pressure"], "gender": [GENDERS[k] for k in d["gender"]], "height": d["height"].astype(np.float64),
            "weight": d["mass"].astype(np.float64), "betas": d["betas"], "joints": d["joints"]}


# ------------------------------------------------------------------------------------ statistics
def weight_scaled(x: np.ndarray, weight_kg: np.ndarray, pitch: tuple[float, float]) -> np.ndarray:
    """Images (N, R, C) scaled so each carries its body's weight (as weight normalisation does)."""
    total = x.reshape(len(x), -1).sum(1).astype(np.float64) * pitch[0] * pitch[1] * MMHG_PA
    return x * (weight_kg * G / np.maximum(total, 1e-12))[:, None, None]


def image_stats(x: np.ndarray, weight_kg: np.ndarray, height_m: np.ndarray, pitch: tuple[float, float]) -> dict:
    """Per-image statistics (each (N,)) of model inputs x (N, R, C) mmHg.

    contact_any: taxels > 0 (the network's contact channel C_I); contact_5: taxels above 5 mmHg
    once the image carries the body's weight; first_row / last_row: the contact extent along the
    bed (rows with >= 2 taxels above 5 % of the image's 99th percentile, as
    :func:`pressurepose.data.realprep.contact_extent_rows`); width_cols: columns with such taxels;
    centroid_row: the load's centre along the bed; peak_to_mean: 99th percentile over the mean of
    the taxels above 5 mmHg; bottom_share: load share of the last 4 rows; at_clip: taxels at the
    sensor's 100 mmHg ceiling; height_minus_extent_cm: standing height minus the imprint's length
    along the bed ((last - first + 1) rows x pitch).
    """
    from pressurepose.data.realprep import contact_extent_rows

    w = weight_scaled(x, weight_kg, pitch)
    rows = np.arange(x.shape[1])
    out = {k: [] for k in ("contact_any", "contact_5", "first_row", "last_row", "width_cols", "centroid_row",
                           "peak_to_mean", "bottom_share", "at_clip")}
    for a, b in zip(x, w):
        first, last = contact_extent_rows(a)
        nz = a[a > 0]
        strong = a > 0.05 * np.percentile(nz, 99) if nz.size else np.zeros_like(a, bool)
        cols = np.nonzero(strong.sum(0) >= 2)[0]
        out["contact_any"].append(int((a > 0).sum()))
        out["contact_5"].append(int((b > 5).sum()))
        out["first_row"].append(first)
        out["last_row"].append(last)
        out["width_cols"].append(int(cols[-1] - cols[0] + 1) if cols.size else 0)
        out["centroid_row"].append(float((a.sum(1) * rows).sum() / max(a.sum(), 1e-12)))
        out["peak_to_mean"].append(float(np.percentile(b[b > 5], 99) / b[b > 5].mean()) if (b > 5).any() else 0.0)
        out["bottom_share"].append(float(a[-4:].sum() / max(a.sum(), 1e-12)))
        out["at_clip"].append(int((a >= 99.9).sum()))
    out = {k: np.asarray(v, dtype=np.float64) for k, v in out.items()}
    out["height_minus_extent_cm"] = 100 * (height_m - (out["last_row"] - out["first_row"] + 1) * pitch[0])
    return out


def row_profile(x: np.ndarray) -> np.ndarray:
    """(R,) mean over images of each row's share of the image's load."""
    s = x.sum(2)
    return (s / np.maximum(s.sum(1, keepdims=True), 1e-12)).mean(0)


def contact_row_profile(x: np.ndarray) -> np.ndarray:
    """(R,) mean over images of each row's share of columns in the contact channel (p > 0)."""
    return (x > 0).mean((0, 2))


# ------------------------------------------------------------------------------------ the model
def run_model(net, x: np.ndarray, genders, height: np.ndarray) -> dict:
    """The shipped model's estimate of images x (N, R, C): beta0, stature (m) and its error against
    height (m), rows of the pelvis, head and lower ankle joints, the ankles' and wrists' distance
    across the bed (m; how far the limbs are spread), and where the reconstructed map Q lies (its
    centroid row and the share in the last 4 rows). All (N,) arrays."""
    from pressurepose.body.joints import JOINT_NAMES
    from pressurepose.eval.posture import body_stature_mass
    from pressurepose.net.infer import estimate

    est = estimate(np.ascontiguousarray(x, dtype=np.float32), list(genders), model=net, batch_size=32)
    h, _ = body_stature_mass(net, est.betas, list(genders))
    pitch = net.config.grid.pitch_row_m
    j = est.joints[..., 1] / pitch - 0.5  # row coordinate of each joint (taxel centres at integers)
    jx = lambda n: est.joints[:, JOINT_NAMES.index(n), 0]  # noqa: E731
    q = np.clip(est.q, 0, None)
    rows = np.arange(q.shape[1])
    qs = q.sum((1, 2))
    return {"beta0": est.betas[:, 0].astype(np.float64), "stature": h, "stature_err": h - height,
            "pelvis_row": j[:, JOINT_NAMES.index("pelvis")], "head_row": j[:, JOINT_NAMES.index("head")],
            "ankle_row": j[:, [JOINT_NAMES.index("left_ankle"), JOINT_NAMES.index("right_ankle")]].max(1),
            "ankle_sep": np.abs(jx("left_ankle") - jx("right_ankle")),
            "wrist_sep": np.abs(jx("left_wrist") - jx("right_wrist")),
            "q_centroid_row": (q.sum(2) * rows).sum(1) / np.maximum(qs, 1e-12),
            "q_bottom_share": q[:, -4:].sum((1, 2)) / np.maximum(qs, 1e-12)}


def summary(res: dict, height: np.ndarray) -> dict:
    r = np.corrcoef(res["stature"], height)[0, 1] if np.std(res["stature"]) > 0 else float("nan")
    return {"beta0": float(res["beta0"].mean()), "beta0_sd": float(res["beta0"].std()),
            "stature_bias_cm": 100 * float(res["stature_err"].mean()),
            "stature_mae_cm": 100 * float(np.abs(res["stature_err"]).mean()), "stature_r": float(r),
            "pelvis_row": float(res["pelvis_row"].mean()), "ankle_row": float(res["ankle_row"].mean()),
            "ankle_sep_cm": 100 * float(res["ankle_sep"].mean()), "wrist_sep_cm": 100 * float(res["wrist_sep"].mean()),
            "q_bottom_share": float(res["q_bottom_share"].mean())}


def head_ankle_lengths(net, betas: np.ndarray, genders, joints: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """(lying, standing), (N,) each, metres: the head-to-lower-ankle distance along the bed of lying
    bodies (joints (N, 24, 3), bed frame) and the same joints' distance in the same bodies standing
    straight (zero pose). lying / standing is 1 for a body lying straight along the bed, less when
    its legs are spread or bent or it lies askew."""
    import torch

    from pressurepose.body.joints import JOINT_NAMES
    from pressurepose.net.model import GENDER_CODES

    h, la, ra = (JOINT_NAMES.index(n) for n in ("head", "left_ankle", "right_ankle"))
    lying = joints[:, [la, ra], 1].max(1) - joints[:, h, 1]
    standing = np.zeros(len(betas))
    codes = np.array([GENDER_CODES[g] for g in genders])
    for c in np.unique(codes):
        sel = codes == c
        layer = net.body.layers[min(int(c), len(net.body.layers) - 1)]
        buf = next(layer.buffers())
        with torch.no_grad():
            j = layer(betas=torch.as_tensor(betas[sel], dtype=buf.dtype, device=buf.device)).joints.cpu().numpy()
        standing[sel] = j[:, h, 2] - j[:, [la, ra], 2].min(1)
    return lying, standing


# ---------------------------------------------------------------------------------- perturbations
def round_trip(x: np.ndarray, weight_kg: np.ndarray, model_mat, full: bool = True) -> np.ndarray:
    """Simulated images on the model's mat -> the FSA 64 x 32 mat (force kept, centred) -> back.
    full: through the whole evaluate-real path (:func:`pressurepose.data.realprep.prepare`: baseline,
    repair, weight normalisation, resampling, clipping), else resampling only."""
    from pressurepose.data.realprep import prepare, to_model_mat
    from pressurepose.mat import get_mat

    fsa = get_mat("fsa_softflex_2048")
    on_fsa = to_model_mat(x, model_mat, fsa)
    if full:
        return prepare(on_fsa, fsa, "raw", model_mat, weight_kg=weight_kg)
    return to_model_mat(on_fsa, fsa, model_mat).astype(np.float32)


def halo(x: np.ndarray, taxels: int, level: float = 0.01) -> np.ndarray:
    """A faint rim: taxels within ``taxels`` steps (4-neighbour) of the contact that read 0 now read ``level`` mmHg
    (the contact channel grows; the pressure is unchanged to 1e-4 of its total)."""
    out = x.copy()
    for a in out:
        grown = ndimage.binary_dilation(a > 0, iterations=taxels) if taxels > 0 else np.ones_like(a, bool)
        a[grown & (a == 0)] = level
    return out


def blur(x: np.ndarray, sigma: float, keep_contact: bool) -> np.ndarray:
    """Gaussian blur (taxels, force kept); keep_contact: then zero outside the original contact
    (rescaled to the same total), so only the intensity spreads, not the contact channel."""
    out = np.stack([ndimage.gaussian_filter(a.astype(np.float64), sigma, mode="constant") for a in x])
    out[out < 1e-6 * out.max()] = 0
    if keep_contact:
        out = np.where(x > 0, out, 0)
        out *= (x.sum((1, 2)) / np.maximum(out.sum((1, 2)), 1e-12))[:, None, None]
    return out.astype(np.float32)


def shift_rows(x: np.ndarray, rows: int) -> np.ndarray:
    """Move the image ``rows`` toward the foot (negative: toward the head), zero fill; what leaves
    the mat is lost."""
    out = np.zeros_like(x)
    if rows >= 0:
        out[:, rows:] = x[:, :x.shape[1] - rows]
    else:
        out[:, :rows] = x[:, -rows:]
    return out


def stretch_rows(x: np.ndarray, factor: float) -> np.ndarray:
    """Stretch along the bed by ``factor`` about the load's centroid row (linear interpolation,
    total kept; what leaves the mat is lost)."""
    rows = np.arange(x.shape[1], dtype=np.float64)
    out = np.empty_like(x)
    for k, a in enumerate(x):
        c = (a.sum(1) * rows).sum() / max(a.sum(), 1e-12)
        src = c + (rows - c) / factor
        out[k] = np.clip(ndimage.map_coordinates(a, [np.repeat(src, a.shape[1]),
                                                     np.tile(np.arange(a.shape[1]), a.shape[0])],
                                                 order=1, mode="constant").reshape(a.shape), 0, None) / factor
    return out


def gamma(x: np.ndarray, power: float) -> np.ndarray:
    """Intensities raised to ``power`` within the contact, total kept (> 1: peakier, < 1: flatter)."""
    out = np.power(x.astype(np.float64), power)
    return (out * (x.sum((1, 2)) / np.maximum(out.sum((1, 2)), 1e-12))[:, None, None]).astype(np.float32)


def threshold(x: np.ndarray, mmhg: float) -> np.ndarray:
    """Taxels at or below ``mmhg`` set to 0 (the contact channel shrinks to the firm contact)."""
    return np.where(x > mmhg, x, 0).astype(np.float32)


def sim_perturbations(sim: dict, model_mat) -> list[tuple[str, np.ndarray]]:
    x, w = sim["x"], sim["weight"]
    return [
        ("none", x),
        ("x 0.5 (total pressure halved)", x * 0.5),
        ("round trip: resampling only", round_trip(x, w, model_mat, full=False)),
        ("round trip: full real-data path", round_trip(x, w, model_mat, full=True)),
        ("round trip, then contact > 0.5 mmHg", threshold(round_trip(x, w, model_mat), 0.5)),
        ("halo 1 taxel (0.01 mmHg)", halo(x, 1)),
        ("halo 2 taxels", halo(x, 2)),
        ("halo 4 taxels", halo(x, 4)),
        ("0.01 mmHg on every empty taxel", halo(x, 0)),
        ("blur sigma 1, contact kept", blur(x, 1.0, True)),
        ("blur sigma 2, contact kept", blur(x, 2.0, True)),
        ("blur sigma 1 (contact grows)", blur(x, 1.0, False)),
        ("intensity ^ 1.5 (peakier), contact kept", gamma(x, 1.5)),
        ("shift 4 rows toward the foot", shift_rows(x, 4)),
        ("shift 4 rows toward the head", shift_rows(x, -4)),
        ("stretch rows x 1.1", stretch_rows(x, 1.1)),
        ("stretch rows x 0.9", stretch_rows(x, 0.9)),
    ]


def real_perturbations(x: np.ndarray) -> list[tuple[str, np.ndarray]]:
    return [
        ("none (evaluate-real input)", x),
        ("contact > 0.5 mmHg", threshold(x, 0.5)),
        ("contact > 2 mmHg", threshold(x, 2.0)),
        ("contact > 5 mmHg", threshold(x, 5.0)),
        ("contact > 10 mmHg", threshold(x, 10.0)),
        ("contact > 5 mmHg, shift 4 rows toward the head", shift_rows(threshold(x, 5.0), -4)),
        ("contact > 5 mmHg, stretch rows x 0.9", threshold(stretch_rows(x, 0.9), 5.0)),
    ]


# --------------------------------------------------------------------------------------- figures
def inputs_figure(net, examples: list[tuple[str, np.ndarray, str]]):
    """One row per example (title, image (R, C) mmHg, note): the pressure and the three network
    channels (blurred pressure P, Sobel edges E, contact C_I), each as the network sees it
    (upsampled, normalised to mean 1 over the 128 x 54 input)."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    import torch

    from pressurepose.net.transforms import input_channels

    imgs = np.stack([e[1] for e in examples]).astype(np.float32)
    with torch.no_grad():
        ch = input_channels(torch.from_numpy(imgs), net.config.inputs).numpy()
    vmax = [max(float(np.percentile(ch[:, k], 99.5)), 1e-6) for k in range(3)]
    fig, axes = plt.subplots(len(examples), 4, figsize=(8.2, 3.3 * len(examples)), squeeze=False)
    for i, (title, img, note) in enumerate(examples):
        ax = axes[i]
        ax[0].imshow(img, cmap="magma", interpolation="nearest", vmin=0, vmax=max(float(img.max()), 1e-6))
        ax[0].set_title(f"{title}\nmmHg (max {img.max():.0f})", fontsize=8)
        for k, name in enumerate(("P (blurred)", "E (Sobel)", "C_I = (p > 0)")):
            ax[k + 1].imshow(ch[i, k], cmap="magma", interpolation="nearest", vmin=0, vmax=vmax[k])
            ax[k + 1].set_title(f"{name}\n{note if k == 2 else ''}", fontsize=8)
        for a in ax:
            a.set_xticks([])
            a.set_yticks([])
    fig.suptitle("Network input channels (same colour scale per column; row 0 = head end at the top)", fontsize=9)
    fig.tight_layout()
    return fig


def stats_figure(real_stats, sim_stats, real_prof, sim_prof, real_cprof, sim_cprof, table):
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig = plt.figure(figsize=(15, 9))
    gs = fig.add_gridspec(2, 3)
    axes = np.array([[fig.add_subplot(gs[0, k]) for k in range(3)], [fig.add_subplot(gs[1, 0]), None, None]],
                    dtype=object)
    axes[1, 1] = fig.add_subplot(gs[1, 1:])
    ax = axes[0, 0]
    bins = np.linspace(0, 1728, 37)
    ax.hist(sim_stats["contact_any"], bins, alpha=0.6, label="simulated: taxels > 0 (= C_I)")
    ax.hist(real_stats["contact_any"], bins, alpha=0.6, label="real: taxels > 0 (= C_I)")
    ax.hist(sim_stats["contact_5"], bins, histtype="step", lw=2, color="C0", label="simulated: > 5 mmHg")
    ax.hist(real_stats["contact_5"], bins, histtype="step", lw=2, color="C1", label="real: > 5 mmHg")
    ax.set_xlabel("taxels (of 64 x 27 = 1728)")
    ax.set_ylabel("images")
    ax.set_title("contact area (real: supine postures 1, 8, 9)", fontsize=9)
    ax.legend(fontsize=7)
    ax = axes[0, 1]
    ax.plot(sim_prof, label="simulated general_supine")
    ax.plot(real_prof, label="real supine (PMD-I 1, 8, 9)")
    ax.set_xlabel("row (0 = head end)")
    ax.set_ylabel("mean share of the image's load")
    ax.set_title("where the load lies along the bed", fontsize=9)
    ax.legend(fontsize=7)
    ax = axes[0, 2]
    ax.plot(sim_cprof, label="simulated general_supine")
    ax.plot(real_cprof, label="real supine (PMD-I 1, 8, 9)")
    ax.set_xlabel("row (0 = head end)")
    ax.set_ylabel("share of the row's taxels with p > 0")
    ax.set_title("the contact channel C_I along the bed", fontsize=9)
    ax.legend(fontsize=7)
    ax = axes[1, 0]
    b = np.arange(-0.5, 64.5, 2)
    ax.hist(sim_stats["first_row"], b, alpha=0.6, color="C0", label="simulated first row")
    ax.hist(real_stats["first_row"], b, alpha=0.6, color="C1", label="real first row")
    ax.hist(sim_stats["last_row"], b, histtype="step", lw=2, color="C0", label="simulated last row")
    ax.hist(real_stats["last_row"], b, histtype="step", lw=2, color="C1", label="real last row")
    ax.set_xlabel("row")
    ax.set_title("contact extent along the bed", fontsize=9)
    ax.legend(fontsize=7)
    ax = axes[1, 1]
    names = [f"{d}: {n}" for d, n, _ in table]
    y = np.arange(len(table))
    ax.barh(y, [s["beta0"] for _, _, s in table], color=["C0" if d == "sim" else "C1" for d, _, _ in table])
    ax.set_yticks(y)
    ax.set_yticklabels(names, fontsize=6)
    ax.invert_yaxis()
    for k, (_, _, st) in enumerate(table):
        ax.text(3.1, k, f"{st['stature_bias_cm']:+.1f} cm", va="center", fontsize=6)
    ax.axvline(3, color="0.5", ls="--")
    ax.set_xlim(min(-1.0, min(st["beta0"] for _, _, st in table) - 0.2), 3.7)
    ax.set_xlabel("mean beta0 of the estimate (limit +3); right: stature bias")
    ax.set_title("perturbations (blue: simulated, orange: real supine)", fontsize=9)
    fig.tight_layout()
    return fig


# ------------------------------------------------------------------------------------------- main
def _fmt_table(table: list[tuple[str, str, dict]]) -> str:
    lines = ["| data | perturbation | C_I taxels (median) | beta0 (mean, sd) | stature bias (cm) | stature MAE (cm) "
             "| r (stature, height) | pelvis row | ankles apart (cm) | wrists apart (cm) | Q in last 4 rows |",
             "|---|---|---|---|---|---|---|---|---|---|---|"]
    for d, name, s in table:
        lines.append(f"| {d} | {name} | {s['contact_any']:.0f} | {s['beta0']:+.2f} ({s['beta0_sd']:.2f}) | "
                     f"{s['stature_bias_cm']:+.1f} | {s['stature_mae_cm']:.1f} | {s['stature_r']:.2f} | "
                     f"{s['pelvis_row']:.1f} | {s['ankle_sep_cm']:.0f} | {s['wrist_sep_cm']:.0f} | "
                     f"{100 * s['q_bottom_share']:.0f} % |")
    return "\n".join(lines)


def _stats_table(groups: dict[str, dict]) -> str:
    keys = (("contact_any", "C_I taxels (> 0)", ".0f"), ("contact_5", "taxels > 5 mmHg (weight-scaled)", ".0f"),
            ("first_row", "first contact row", ".1f"), ("last_row", "last contact row", ".1f"),
            ("width_cols", "contact width (columns)", ".1f"), ("centroid_row", "load centroid row", ".1f"),
            ("peak_to_mean", "p99 / mean over > 5 mmHg", ".2f"), ("bottom_share", "load in last 4 rows", ".3f"),
            ("at_clip", "taxels at 100 mmHg", ".1f"),
            ("height_minus_extent_cm", "standing height - imprint length (cm)", ".1f"))
    names = list(groups)
    lines = ["| statistic (median) | " + " | ".join(names) + " |", "|---" * (len(names) + 1) + "|"]
    for k, label, fmt in keys:
        lines.append(f"| {label} | " + " | ".join(format(float(np.median(groups[n][k])), fmt) for n in names) + " |")
    return "\n".join(lines)


def _commit() -> str:
    """The checkout's short commit (the simulator that made a freshly generated set), or 'unknown'."""
    import subprocess

    try:
        return subprocess.run(["git", "rev-parse", "--short", "HEAD"], capture_output=True, text=True, check=True,
                              cwd=Path(__file__).resolve().parents[1]).stdout.strip() or "unknown"
    except (OSError, subprocess.CalledProcessError):
        return "unknown"


def main(argv=None) -> int:
    import torch

    from pressurepose.files import save_figure_atomic, write_json_atomic
    from pressurepose.mat import MatSpec
    from pressurepose.net.infer import resolve_model

    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--data", default=str(DEFAULT_DATA))
    ap.add_argument("--sim", default=None, help="simulated dataset folder (default: generate --count per gender)")
    ap.add_argument("--count", type=int, default=24, help="general_supine bodies per gender to generate")
    ap.add_argument("--out", default="runs/sim_to_real")
    ap.add_argument("--no-write", action="store_true")
    args = ap.parse_args(argv)
    torch.set_num_threads(1)
    out = Path(args.out)
    net = resolve_model(None)
    g = net.config.grid
    model_mat = MatSpec("model", g.rows, g.cols, g.pitch_row_m, g.pitch_col_m)
    pitch = (g.pitch_row_m, g.pitch_col_m)

    sim = load_sim(Path(args.sim) if args.sim else make_sim(out / "sim", args.count), net)
    real = load_real(Path(args.data), model_mat)
    sup = real["supine"]
    rx, rh, rw = real["x"][sup], real["height"][sup], real["weight"][sup]
    # no sex is recorded: each real image is estimated with both body models, each estimate counts
    r2 = lambda a: np.concatenate([a, a])  # noqa: E731
    rg = ["f"] * len(rx) + ["m"] * len(rx)

    table, details = [], {}
    for name, x in sim_perturbations(sim, model_mat):
        res = run_model(net, x, sim["gender"], sim["height"])
        s = summary(res, sim["height"]) | {"contact_any": float(np.median((x > 0).sum((1, 2))))}
        table.append(("sim", name, s))
        details[f"sim: {name}"] = res
        print(f"sim  {name:45s} {s}", flush=True)
    for name, x in real_perturbations(rx):
        res = run_model(net, r2(x), rg, r2(rh))
        s = summary(res, r2(rh)) | {"contact_any": float(np.median((x > 0).sum((1, 2))))}
        table.append(("real", name, s))
        details[f"real: {name}"] = res
        print(f"real {name:45s} {s}", flush=True)
    # every flat real posture, as evaluate-real sees it, for reference
    allx = real["x"]
    res_all = run_model(net, r2(allx), ["f"] * len(allx) + ["m"] * len(allx), r2(real["height"]))
    s_all = summary(res_all, r2(real["height"])) | {"contact_any": float(np.median((allx > 0).sum((1, 2))))}
    table.append(("real", "all flat postures, as evaluate-real", s_all))

    sim_stats = image_stats(sim["x"], sim["weight"], sim["height"], pitch)
    real_stats = image_stats(rx, rw, rh, pitch)
    rt = round_trip(sim["x"], sim["weight"], model_mat)
    groups = {"simulated": sim_stats, "simulated, round trip": image_stats(rt, sim["weight"], sim["height"], pitch),
              "real supine": real_stats,
              "real supine, > 5 mmHg": image_stats(threshold(rx, 5.0), rw, rh, pitch),
              "real, all flat": image_stats(allx, real["weight"], real["height"], pitch)}
    extent = lambda st: st["last_row"] - st["first_row"] + 1  # noqa: E731
    # placement: the true pelvis joint of the simulated bodies against the estimate's
    from pressurepose.body.joints import JOINT_NAMES

    true_pelvis = sim["joints"][:, JOINT_NAMES.index("pelvis"), 1] / pitch[0] - 0.5
    true_ankle = sim["joints"][:, [JOINT_NAMES.index("left_ankle"), JOINT_NAMES.index("right_ankle")], 1].max(1)
    true_ankle = true_ankle / pitch[0] - 0.5
    jx = lambda n: sim["joints"][:, JOINT_NAMES.index(n), 0]  # noqa: E731
    lying, standing = head_ankle_lengths(net, sim["betas"], sim["gender"], sim["joints"])
    true_ankle_sep = np.abs(jx("left_ankle") - jx("right_ankle"))
    true_wrist_sep = np.abs(jx("left_wrist") - jx("right_wrist"))
    est0 = details["sim: none"]
    est_real = details["real: none (evaluate-real input)"]
    placement = {
        "sim_true_pelvis_row": [float(np.median(true_pelvis)), float(true_pelvis.min()), float(true_pelvis.max())],
        "sim_est_pelvis_row_err": float(np.mean(est0["pelvis_row"] - true_pelvis)),
        "sim_true_ankle_row": [float(np.median(true_ankle)), float(true_ankle.min()), float(true_ankle.max())],
        "sim_est_ankle_row_err": float(np.mean(est0["ankle_row"] - true_ankle)),
        "sim_true_ankle_sep_cm": 100 * float(true_ankle_sep.mean()),
        "sim_true_wrist_sep_cm": 100 * float(true_wrist_sep.mean()),
        "sim_extent_height_r": float(np.corrcoef(extent(sim_stats), sim["height"])[0, 1]),
        "real_extent_height_r": float(np.corrcoef(extent(real_stats), rh)[0, 1]),
        "sim_true_head_row": float(np.median(sim["joints"][:, JOINT_NAMES.index("head"), 1] / pitch[0] - 0.5)),
        "sim_true_head_row_minus_first_contact": float(np.median(
            sim["joints"][:, JOINT_NAMES.index("head"), 1] / pitch[0] - 0.5 - sim_stats["first_row"])),
        "sim_head_ankle_ratio": float(np.median(lying / standing)),
        "sim_pose_shortening_cm": 100 * float(np.median(standing - lying)),
        "sim_height_minus_extent_cm": float(np.median(sim_stats["height_minus_extent_cm"])),
        "real_height_minus_extent_cm": float(np.median(real_stats["height_minus_extent_cm"])),
        "sim_last_contact_minus_ankle_row": float(np.median(sim_stats["last_row"] - true_ankle)),
        "sim_last_row_63_share": float(np.mean(sim_stats["last_row"] >= 63)),
        "real_last_row_63_share": float(np.mean(real_stats["last_row"] >= 63)),
        "sim_first_row_0_share": float(np.mean(sim_stats["first_row"] <= 0)),
        "real_first_row_0_share": float(np.mean(real_stats["first_row"] <= 0)),
        "real_est_pelvis_row": float(np.median(est_real["pelvis_row"])),
        "real_est_ankle_row": float(np.median(est_real["ankle_row"])),
        "real_est_head_row": float(np.median(est_real["head_row"])),
        "real_est_ankle_beyond_mat": float(np.mean(est_real["ankle_row"] > g.rows - 0.5)),
        "real_last_contact_row": float(np.median(real_stats["last_row"])),
        "real_first_contact_row": float(np.median(real_stats["first_row"])),
        "sim_est_head_row_minus_first_contact": float(np.median(est0["head_row"] - sim_stats["first_row"])),
        "real_est_head_row_minus_first_contact": float(np.median(est_real["head_row"] - r2(real_stats["first_row"]))),
        "sim_est_ankle_row_minus_last_contact": float(np.median(est0["ankle_row"] - sim_stats["last_row"])),
        "real_est_ankle_row_minus_last_contact": float(np.median(est_real["ankle_row"] - r2(real_stats["last_row"]))),
    }
    areas = real_contact_areas(Path(args.data), model_mat)
    a_taxel = model_mat.taxel_area_m2
    areas["simulated"] = float(np.median(sim_stats["contact_any"])) * a_taxel
    areas["simulated_round_trip"] = float(np.median(groups["simulated, round trip"]["contact_any"])) * a_taxel
    print(placement, areas)
    p = placement
    out.mkdir(parents=True, exist_ok=True)
    write_json_atomic(out / "sim_to_real.json", {
        "table": [{"data": d, "perturbation": n, **s} for d, n, s in table],
        "image_stats_median": {k: {s: float(np.median(v)) for s, v in st.items()} for k, st in groups.items()},
        "placement": placement, "contact_area_m2": areas, "n_sim": len(sim["x"]), "n_real_supine": int(sup.sum())})

    # figures: two real supine images (tallest and shortest subject) above the simulated bodies
    # closest to them in height
    ir = [int(np.argmax(rh)), int(np.argmin(rh))]
    js = [int(np.argmin(np.abs(sim["height"] - rh[i]))) for i in ir]
    b_real = est_real["beta0"][:len(rx)]
    examples = [(f"real, {rh[i]:.2f} m, {rw[i]:.0f} kg", rx[i], f"{(rx[i] > 0).sum()} taxels; beta0 {b_real[i]:+.2f}")
                for i in ir]
    examples += [(f"simulated ({sim['gender'][j]}), {sim['height'][j]:.2f} m, {sim['weight'][j]:.0f} kg", sim["x"][j],
                  f"{(sim['x'][j] > 0).sum()} taxels; beta0 {est0['beta0'][j]:+.2f}") for j in js]
    j = js[0]
    x_halo = halo(sim["x"][j:j + 1], 0)[0]
    examples.append(("the same simulated body,\n0.01 mmHg on every empty taxel", x_halo,
                     f"{(x_halo > 0).sum()} taxels; beta0 "
                     f"{details['sim: 0.01 mmHg on every empty taxel']['beta0'][j]:+.2f}"))
    fig_dir = DOCS if not args.no_write else out
    save_figure_atomic(inputs_figure(net, examples), fig_dir / "sim_to_real_inputs.png", dpi=90)
    save_figure_atomic(stats_figure(real_stats, sim_stats, row_profile(rx), row_profile(sim["x"]),
                                    contact_row_profile(rx), contact_row_profile(sim["x"]),
                                    [t for t in table if t[1] != "all flat postures, as evaluate-real"]),
                       fig_dir / "sim_to_real_stats.png", dpi=90)

    made = f"from {args.sim}" if args.sim else f"seeds 931/932, made (or reused) by the checkout at commit {_commit()}"
    text = "\n".join([
        "## Sim-to-real gap of the shipped PressureNet (`benchmarks/bench_sim_to_real.py`)",
        "",
        f"{datetime.date.today().isoformat()}, {platform.platform()}, {os.cpu_count()} CPUs. Shipped model; "
        f"{len(sim['x'])} simulated `general_supine` bodies (both genders, {made}) and the {int(sup.sum())} real "
        f"PMD-I images of straight-legged "
        f"supine postures (1, 8, 9), each estimated with both body models. Reproduce: "
        f"`python -m benchmarks.bench_sim_to_real`. Analysis: docs/sim_to_real.md.",
        "",
        "Perturbations, one at a time (C_I: the network's contact channel, taxels > 0; r: correlation of "
        "estimated stature with the true height; pelvis row: the estimate's):",
        "",
        _fmt_table(table),
        "",
        "Image statistics (medians; model input on the 64 x 27 grid):",
        "",
        _stats_table(groups),
        "",
        f"Where the real contact channel comes from (median area of non-zero taxels, real supine): as recorded on the "
        f"FSA mat {areas['recorded']:.2f} m^2 (of {areas['fsa_mat']:.2f}), after baseline removal and taxel repair "
        f"{areas['baseline_repaired']:.2f} m^2, as model input {areas['model_input']:.2f} m^2 (of "
        f"{areas['model_mat']:.2f}); simulated {areas['simulated']:.2f} m^2, after the round trip "
        f"{areas['simulated_round_trip']:.2f} m^2.",
        "",
        "Placement and length along the bed (rows; 0 = head end, 63 = last):",
        "",
        f"- simulated: true pelvis row median {p['sim_true_pelvis_row'][0]:.1f} (range "
        f"{p['sim_true_pelvis_row'][1]:.1f}-{p['sim_true_pelvis_row'][2]:.1f}), the estimate's pelvis off by "
        f"{p['sim_est_pelvis_row_err']:+.1f} rows; lower ankle median {p['sim_true_ankle_row'][0]:.1f}; the head joint "
        f"{p['sim_true_head_row_minus_first_contact']:+.1f} rows below the first contact row, the last contact row "
        f"{p['sim_last_contact_minus_ankle_row']:+.1f} rows from the lower ankle (medians);",
        f"- contact reaching row 63: {100 * p['sim_last_row_63_share']:.0f} % of simulated, "
        f"{100 * p['real_last_row_63_share']:.0f} % of real supine images; reaching row 0: "
        f"{100 * p['sim_first_row_0_share']:.0f} % / {100 * p['real_first_row_0_share']:.0f} %;",
        f"- real supine estimates: pelvis row {p['real_est_pelvis_row']:.1f}, head {p['real_est_head_row']:.1f}, lower "
        f"ankle {p['real_est_ankle_row']:.1f} ({100 * p['real_est_ankle_beyond_mat']:.0f} % beyond the last row); "
        f"estimated ankle minus last contact row: simulated {p['sim_est_ankle_row_minus_last_contact']:+.1f}, real "
        f"{p['real_est_ankle_row_minus_last_contact']:+.1f};",
        f"- limb spread of the simulated bodies themselves: ankles {p['sim_true_ankle_sep_cm']:.0f} cm apart, wrists "
        f"{p['sim_true_wrist_sep_cm']:.0f} cm (mean);",
        f"- standing height minus imprint length: simulated {p['sim_height_minus_extent_cm']:.0f} cm, real "
        f"{p['real_height_minus_extent_cm']:.0f} cm (medians); the simulated bodies' head-to-ankle distance along the "
        f"bed is {p['sim_head_ankle_ratio']:.2f} of the same body's standing ({p['sim_pose_shortening_cm']:.0f} cm "
        f"shorter; 1 = lying straight); correlation of imprint length with height: simulated "
        f"{p['sim_extent_height_r']:.2f}, real {p['real_extent_height_r']:.2f}.",
        "",
        "Figures: docs/sim_to_real_inputs.png (network input channels, real beside simulated), "
        "docs/sim_to_real_stats.png (contact area, row profile, extent, beta0 per perturbation).",
    ])
    print(text)
    if not args.no_write:
        write_section("sim_to_real", text)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
