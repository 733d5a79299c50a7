"""Scoring a PressureNet on real pressure images with known posture, height and weight.

For each image (:class:`pressurepose.data.readers.images.RealImages`) made model input
(:meth:`~pressurepose.data.readers.images.RealImages.model_input`, the road ``infer`` takes too): the estimate's posture class against the label
(:mod:`pressurepose.eval.posture`), its stature and mass against the measured height and weight,
and the intersection over union of its reconstructed contact map (PMR) with the input's contact
(taxels above ``contact_mmhg``). Images recorded on an inclined bed are not evaluated; images whose
raw load is a small fraction of their subject's median (a mat that barely recorded) are counted
and left out.

Where no gender is recorded (PMD has none) the default estimates each image with both body
models; every summary then counts each (image, body model) pair once, and ``by_body_model`` splits
them.
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING

import numpy as np

from pressurepose.data.readers.images import RealImages
from pressurepose.data.resample import MMHG_PA
from pressurepose.errors import BadInput, require_bool, require_whole
from pressurepose.eval.posture import (
    body_stature_mass,
    confusion,
    contact_iou,
    posture_correct,
    posture_of,
)
from pressurepose.files import json_ready
from pressurepose.mat import MatSpec
from pressurepose.pose.posture import roll_angle

if TYPE_CHECKING:
    from pressurepose.net.infer import Estimate

GENDER_CHOICES = ("f", "m", "both")
# a body on a wedge (turned 30-60 degrees toward a known side) is read right when its estimate turns at
# least this far toward that side: a turn the posture classes, split at 45 degrees, cannot score
WEDGE_TURN_DEG = 15.0
GRAVITY = 9.80665


@dataclass(frozen=True)
class RealEvalConfig:
    """gender: body model for images without a recorded gender ('f', 'm' or 'both'); force_gender: use
    it even where one is recorded. contact_mmhg: input taxels above it are contact for the IoU; None:
    the model's own contact floor (what its contact channel means), or 2 mmHg for a model without
    one (the paper's, which counts any reading). weak_fraction: images whose
    raw total is below this fraction of their subject's median are left out. batch_size: images
    per forward pass. mirror: average each estimate with the reading of the mirrored image
    (:mod:`pressurepose.net.mirror`). fit: move each estimated body to fit its image's print
    (:mod:`pressurepose.net.fit`)."""

    gender: str = "both"
    force_gender: bool = False
    contact_mmhg: float | None = None
    weak_fraction: float = 0.1
    batch_size: int = 32
    mirror: bool = False
    fit: bool = False

    def __post_init__(self):
        if self.gender not in GENDER_CHOICES:
            raise BadInput(f"gender {self.gender!r} is not known; expected one of {', '.join(GENDER_CHOICES)}")
        number = lambda v: isinstance(v, (int, float, np.integer, np.floating)) and not isinstance(v, bool)  # noqa: E731
        if self.contact_mmhg is not None and not (number(self.contact_mmhg) and 0 <= self.contact_mmhg < float("inf")):
            raise BadInput(f"contact_mmhg (--contact-mmhg) is {self.contact_mmhg!r}; expected a pressure >= 0 (mmHg)")
        if not (number(self.weak_fraction) and 0 <= self.weak_fraction < 1):
            raise BadInput(f"weak_fraction is {self.weak_fraction!r}; expected a share in [0, 1)")
        require_whole("batch_size (--batch-size)", self.batch_size, 1)
        for name in ("force_gender", "mirror"):
            require_bool(name, getattr(self, name))


def weak_images(real: RealImages, fraction: float) -> np.ndarray:
    """(N,) bool: raw total below ``fraction`` of the median total of the same subject's images."""
    total = real.images.reshape(len(real), -1).sum(1).astype(np.float64)
    weak = np.zeros(len(real), bool)
    for s in np.unique(real.subject):
        sel = real.subject == s
        weak[sel] = total[sel] < fraction * np.median(total[sel])
    return weak


def model_inputs(real: RealImages, net, config: RealEvalConfig = RealEvalConfig()):
    """The images of ``real`` that are scored (flat bed, not weak) as ``net``'s input, each once per
    body model it is read with: (the kept RealImages r, x (N, R, C) mmHg on the model's mat, idx (K,)
    into r, genders (K,), {reason: count} of the images left out)."""
    flat = real.posture != "inclined"
    weak = weak_images(real, config.weak_fraction) & flat
    keep = flat & ~weak
    if not keep.any():
        raise BadInput("no real image left to evaluate (all inclined-bed or weak recordings)")
    r = real.select(keep)
    x = r.model_input(net.config.grid)
    idx, genders = [], []
    for i, g in enumerate(r.gender):
        use = [g] if g and not config.force_gender else (["f", "m"] if config.gender == "both" else [config.gender])
        idx += [i] * len(use)
        genders += use
    return r, x, np.array(idx), genders, {"inclined_bed": int((~flat).sum()), "weak_recording": int(weak.sum())}


@dataclass(frozen=True, eq=False)
class RealEvaluation:
    """What :func:`evaluate_real` found: K estimates (an image read with one body model each).

    rows: {name: (K,) array}: image (index into the scored images), subject, posture (label),
    detail, source, frame (index in the source file, -1 for a median of its frames), body_model, predicted (class), scored, correct, roll_deg, stature_m, height_m,
    stature_err_m, mass_kg, weight_kg, mass_err_kg, contact_iou. estimate: the K estimates. input:
    (K, R, C) mmHg the model input. summary: :func:`summarise`. skipped: {reason: count of images
    left out}. n_images: images scored. contact_mmhg: the input's contact threshold for the IoU.
    layout, mat, units, gain: the real images' (:class:`RealImages`).
    """

    rows: dict
    estimate: Estimate
    input: np.ndarray
    summary: dict
    skipped: dict
    n_images: int
    contact_mmhg: float
    layout: str
    mat: MatSpec
    units: str
    gain: float | None

    def metrics(self, **about) -> dict:
        """The metrics.json record: ``about`` (what the caller knows: data, model, options) first, then
        layout, mat, units, gain, contact_mmhg, n_images, skipped and the summary; strict-JSON ready
        (NaN as None)."""
        return json_ready({**about, "layout": self.layout, "mat": self.mat.name, "units": self.units,
                           "gain": self.gain, "contact_mmhg": self.contact_mmhg, "n_images": self.n_images,
                           "skipped": self.skipped, **self.summary})

    def write_metrics(self, path, **about) -> Path:
        """Write :meth:`metrics` to ``path`` as strict JSON (null where a value is not a number)."""
        from pressurepose.files import write_json_atomic

        write_json_atomic(path, self.metrics(**about))
        return Path(path)

    def per_estimate(self) -> list[dict]:
        """One strict-JSON-ready dict per estimate: its rows' values and its betas."""
        betas = self.estimate.betas
        return [json_ready({**{k: v[i] for k, v in self.rows.items()}, "betas": betas[i]})
                for i in range(len(self.rows["image"]))]


def evaluate_real(real: RealImages, model=None, config: RealEvalConfig = RealEvalConfig(),
                  progress: bool = True) -> RealEvaluation:
    """Estimates and per-estimate scores of the images of ``real`` that are scored (see
    :func:`model_inputs`). model: a PressureNet, a model path or None (the shipped model), as
    :func:`pressurepose.net.infer.estimate`'s. progress: a progress bar over the batches on stderr
    (default True, as for every function that runs over a dataset)."""
    from pressurepose.net.infer import estimate, resolve_model

    if not isinstance(real, RealImages):
        raise BadInput(f"real is {type(real).__name__}; expected RealImages, as read_real(folder) or "
                       f"read_recording(...) return")
    if not isinstance(config, RealEvalConfig):
        raise BadInput(f"config is {type(config).__name__}; expected a RealEvalConfig")
    net = resolve_model(model)
    r, x, idx, genders, skipped = model_inputs(real, net, config)
    contact_mmhg = contact_threshold(net, config)
    peak = float(x.max())
    if peak <= contact_mmhg:
        gain = (f"; the gain {r.gain:g} mmHg per raw unit (--gain, or the mat.json's gain) makes every reading "
                f"that small" if r.units == "raw" and r.gain is not None else "")
        raise BadInput(f"every image to score reads at most {peak:.3g} mmHg on the model's mat, not above the contact "
                       f"threshold {contact_mmhg:g} mmHg: the model would see empty mats and the scores would mean "
                       f"nothing{gain}")
    est = estimate(x[idx], genders, model=net, batch_size=config.batch_size, mirror=config.mirror,
                   fit=config.fit, progress=progress)
    pred = posture_of(est.pose)
    h, m = body_stature_mass(net, est.betas, genders)
    rows = {"image": idx, "subject": r.subject[idx], "posture": r.posture[idx], "detail": r.detail[idx],
            "source": r.source[idx], "frame": r.frame[idx], "body_model": np.array(genders), "predicted": pred,
            "scored": np.isin(r.posture[idx], ("supine", "left", "right", "lateral", "prone")),
            "correct": posture_correct(r.posture[idx], pred), "roll_deg": np.degrees(roll_angle(est.pose)),
            "stature_m": h, "height_m": r.height_m[idx],
            "stature_err_m": h - r.height_m[idx], "mass_kg": m, "weight_kg": r.weight_kg[idx],
            "mass_err_kg": m - r.weight_kg[idx],
            "contact_iou": contact_iou(est.contact > 0.5, x[idx] > contact_mmhg),
            "load_kg": x[idx].sum((1, 2)) * MMHG_PA * net.config.grid.taxel_area_m2 / GRAVITY,
            "mat_length_m": np.full(len(idx), real.mat.length_m)}
    return RealEvaluation(rows=rows, estimate=est, input=x[idx], summary=summarise(rows), skipped=skipped,
                          n_images=len(r), contact_mmhg=contact_mmhg, layout=real.layout, mat=real.mat,
                          units=real.units, gain=real.gain)


def contact_threshold(net, config: RealEvalConfig) -> float:
    """The input pressure (mmHg) above which a taxel counts as contact for the IoU (see
    :class:`RealEvalConfig`)."""
    if config.contact_mmhg is not None:
        return float(config.contact_mmhg)
    floor = float(net.config.inputs.contact_floor_mmhg)
    return floor if floor > 0 else 2.0


def _corr(a: np.ndarray, b: np.ndarray) -> float | None:
    """Pearson correlation, None where it is undefined (fewer than 3 values or no spread)."""
    if len(a) < 3 or np.std(a) == 0 or np.std(b) == 0:
        return None
    return float(np.corrcoef(a, b)[0, 1])


def _stats(rows: dict, sel: np.ndarray) -> dict:
    scored = sel & rows["scored"]
    err_h, err_m = rows["stature_err_m"][sel], rows["mass_err_kg"][sel]
    return {"n": int(sel.sum()),
            "posture_accuracy": float(rows["correct"][scored].mean()) if scored.any() else None,
            "abs_roll_median_deg": float(np.median(np.abs(rows["roll_deg"][sel]))) if sel.any() else None,
            "stature_mae_m": float(np.abs(err_h).mean()), "stature_bias_m": float(err_h.mean()),
            "stature_r": _corr(rows["stature_m"][sel], rows["height_m"][sel]),
            "mass_mae_kg": float(np.abs(err_m).mean()), "mass_bias_kg": float(err_m.mean()),
            "contact_iou": float(rows["contact_iou"][sel].mean())}


def turn_toward_label(label, roll_deg) -> np.ndarray:
    """(N,) degrees the estimated body turns toward the side its label names: the roll for 'left'
    (left side down at +90), minus the roll for 'right', its size for 'lateral' (either side); NaN for
    other labels."""
    lab, roll = np.asarray(label, dtype=str), np.asarray(roll_deg, dtype=np.float64)
    return np.where(lab == "left", roll, np.where(lab == "right", -roll,
                                                  np.where(lab == "lateral", np.abs(roll), np.nan)))


def wedge_angle(detail: str) -> str:
    """The wedge's turn named in a source posture ('right 30 deg (wedge)' -> '30'), '' if none."""
    words = str(detail).split()
    return next((w for w, nxt in zip(words, words[1:]) if nxt.startswith("deg") and w.isdigit()), "")


def _wedge_stats(rows: dict, sel: np.ndarray) -> dict | None:
    """Wedge postures among ``sel``: how many turn the right way (:data:`WEDGE_TURN_DEG`) and the
    median turn toward the labelled side by the wedge's angle; None without wedge postures."""
    sel = sel & is_wedge(rows["detail"]) & np.isin(rows["posture"], ("left", "right", "lateral"))
    if not sel.any():
        return None
    turn = turn_toward_label(rows["posture"][sel], rows["roll_deg"][sel])
    angles = np.array([wedge_angle(d) for d in rows["detail"][sel]])
    return {"n": int(sel.sum()), "turned_right_way": float(np.mean(turn >= WEDGE_TURN_DEG)),
            "median_turn_deg": {a or "unknown": float(np.median(turn[angles == a]))
                                for a in sorted(set(angles.tolist()), key=lambda a: (len(a), a))}}


def summarise(rows: dict) -> dict:
    """Overall scores (stature_r: correlation of estimated stature with measured height), per subject,
    per posture label, per source posture name, per body model and the posture confusion matrix
    ({label: {predicted: count}}, scored estimates only).

    As the postures are labelled: ``without_wedge`` scores the postures on a flat bed by class
    (supine, side-lying, prone), ``wedge`` the bodies propped on a wedge by the direction of their
    turn (:func:`_wedge_stats`), both overall and per subject. Stature: ``taller_than_mat`` is the share
    of people taller than the mat is long (their image cannot show the whole body). Mass: the mean
    load the model input carries (``load_kg_mean``) beside the measured weight and the estimate."""
    n = len(rows["image"])
    out = _stats(rows, np.ones(n, bool))
    flat = ~is_wedge(rows["detail"])
    out["wedge"] = _wedge_stats(rows, np.ones(n, bool))
    groups = {"supine": ("supine",), "side-lying": ("left", "right", "lateral"), "prone": ("prone",)}
    out["flat_bed_by_posture"] = {g: float(rows["correct"][sel].mean()) for g, labels in groups.items()
                                  if (sel := flat & rows["scored"] & np.isin(rows["posture"], labels)).any()}
    known = np.isfinite(rows["height_m"])
    mat_length = rows.get("mat_length_m")
    out["mat_length_m"] = float(mat_length[0]) if mat_length is not None and n else None
    out["taller_than_mat"] = (float(np.mean(rows["height_m"][known] > mat_length[known]))
                              if mat_length is not None and known.any() else None)
    out["load_kg_mean"] = float(np.mean(rows["load_kg"])) if "load_kg" in rows and n else None
    out["weight_kg_mean"] = float(np.nanmean(rows["weight_kg"])) if np.isfinite(rows["weight_kg"]).any() else None
    out["n_estimates"] = out.pop("n")
    for key, col in (("per_subject", "subject"), ("per_posture", "posture"), ("per_detail", "detail"),
                     ("by_body_model", "body_model")):
        vals = rows[col]
        order = sorted(set(vals.tolist()), key=lambda v: (len(v), v) if col == "subject" else v)
        out[key] = {str(v): _stats(rows, vals == v) for v in order}
    for v, st in out["per_subject"].items():  # what the subject measured, beside what was estimated
        sel = rows["subject"] == v
        flat_scored = sel & flat & rows["scored"]
        wedge = _wedge_stats(rows, sel)
        st.update(flat_bed_posture_accuracy=float(rows["correct"][flat_scored].mean()) if flat_scored.any() else None,
                  wedge_turned_right_way=None if wedge is None else wedge["turned_right_way"])
        st.update(height_m=float(rows["height_m"][sel].mean()), weight_kg=float(rows["weight_kg"][sel].mean()),
                  stature_mean_m=float(rows["stature_m"][sel].mean()),
                  stature_sd_m=float(rows["stature_m"][sel].std()), mass_mean_kg=float(rows["mass_kg"][sel].mean()))
    out["stature_weight_r"] = _corr(rows["stature_m"], rows["weight_kg"])
    sc = rows["scored"]
    out["confusion"] = confusion(rows["posture"][sc], rows["predicted"][sc])
    wedge = is_wedge(rows["detail"])
    out["without_wedge"] = _stats(rows, ~wedge) if wedge.any() and not wedge.all() else None
    return out


def is_wedge(details) -> np.ndarray:
    """(N,) bool: source postures recorded on a wedge (PMD-I postures 4-7: the body turned 30 or 60
    degrees and propped, labelled left or right by the source; PMD-II E1-E6, turned part-way onto
    either side on a support, labelled 'lateral'; at 30 degrees the project's posture classes, split
    at 45 degrees of roll, call such a body supine)."""
    return detail_has(details, ("wedge",))


def detail_has(details, words) -> np.ndarray:
    """(N,) bool: source posture names (N,) that contain any of ``words`` (case-insensitive)."""
    words = [str(w).lower() for w in words]
    return np.array([any(w in str(d).lower() for w in words) for d in np.atleast_1d(details)], bool)


def format_real_table(summary: dict, key: str = "per_detail") -> str:
    """Markdown table of a summary's groups (default the source's posture names)."""
    def f(v, fmt):
        return "-" if v is None else format(v, fmt)

    lines = ["| posture | n | posture acc. | estimated roll, median abs. (deg) | stature MAE (cm) | stature bias (cm) | "
             "mass MAE (kg) | contact IoU |",
             "|---|---|---|---|---|---|---|---|"]
    groups = list(summary[key].items()) + [("all", {**summary, "n": summary["n_estimates"]})]
    if key == "per_detail" and summary.get("without_wedge"):
        groups.append(("all but the wedge postures", summary["without_wedge"]))
    for name, s in groups:
        lines.append(f"| {name} | {s['n']} | {f(s['posture_accuracy'], '.2f')} | {f(s.get('abs_roll_median_deg'), '.0f')} | "
                     f"{100 * s['stature_mae_m']:.1f} | "
                     f"{100 * s['stature_bias_m']:+.1f} | {s['mass_mae_kg']:.1f} | {s['contact_iou']:.2f} |")
    return "\n".join(lines)


def format_subject_table(summary: dict) -> str:
    """Markdown table per subject: measured height and weight beside the mean estimated stature
    and mass (and the spread of the stature over the subject's images), with the posture accuracy.
    A model that reads size shows estimates that follow the heights down the table."""
    lines = ["| subject | n | height (m) | estimated stature, mean (sd) (m) | weight (kg) | estimated mass, mean (kg) | "
             "posture acc., flat bed | wedge turned the right way |", "|---|---|---|---|---|---|---|---|"]
    f2 = lambda v: "-" if v is None else f"{v:.2f}"  # noqa: E731
    for name, s in summary["per_subject"].items():
        lines.append(f"| {name} | {s['n']} | {s['height_m']:.2f} | {s['stature_mean_m']:.2f} ({s['stature_sd_m']:.2f}) | "
                     f"{s['weight_kg']:.0f} | {s['mass_mean_kg']:.0f} | {f2(s.get('flat_bed_posture_accuracy'))} | "
                     f"{f2(s.get('wedge_turned_right_way'))} |")
    r_h, r_w = summary.get("stature_r"), summary.get("stature_weight_r")
    f = lambda v: "-" if v is None else f"{v:.2f}"  # noqa: E731
    lines.append(f"\nCorrelation of the estimated stature with the measured height {f(r_h)}, with the weight {f(r_w)}.")
    return "\n".join(lines)


def format_confusion(conf: dict) -> str:
    """Markdown confusion matrix: rows the labels, columns the predicted classes."""
    from pressurepose.eval.posture import CLASSES

    lines = ["| label \\ estimate | " + " | ".join(CLASSES) + " |", "|---" * (len(CLASSES) + 1) + "|"]
    lines += [f"| {t} | " + " | ".join(str(c[k]) for k in CLASSES) + " |" for t, c in conf.items()]
    return "\n".join(lines)
