"""The accuracy table (paper Table 2): a trained PressureNet and the mean-pose baseline on a dataset,
MPJPE and v2v in cm, overall, by partition and by gender; and, for comparison with real images
(:mod:`pressurepose.eval.real`), Mod2's posture accuracy and the stature error of its body
(estimated body's standing height minus the true body's, :mod:`pressurepose.eval.posture`), and its
roll error: how far the body's turn about its long axis is misread, and whether turned bodies are
read flatter than they lie (:func:`roll_errors`)."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import torch

from pressurepose.errors import BadInput, require_bool, require_whole
from pressurepose.eval.metrics import baseline_body, mpjpe, v2v
from pressurepose.eval.posture import body_stature_mass, posture_of
from pressurepose.net.data import LoadedData, check_loaded, load_dataset
from pressurepose.net.fit import FitConfig, fit_config
from pressurepose.net.model import PressureNet
from pressurepose.net.outputs import BodyParams
from pressurepose.pose.posture import roll_angle

GENDER_NAMES = ("f", "m")
ROWS = (("mod2", "PressureNet (Mod1 + Mod2)"), ("mod1", "Mod1 alone"), ("baseline", "mean-pose baseline (BL)"))


def _params(betas, pose, transl) -> BodyParams:
    b = betas.shape[0]
    return BodyParams(unconstrained=betas.new_zeros(b, 88), betas=betas, transl=transl,
                      root_euler=betas.new_zeros(b, 3), global_orient=pose[:, :3], body_pose=pose[:, 3:])


def _layer_forward(net: PressureNet, gender: int):
    def forward(betas, pose, transl):
        t = lambda a: torch.as_tensor(np.asarray(a), dtype=torch.float32, device=device)  # noqa: E731
        g = torch.full((np.shape(betas)[0],), gender, dtype=torch.long, device=device)
        verts, joints = net.body(_params(t(betas), t(pose), t(transl)), g)
        return verts.cpu().numpy(), joints.cpu().numpy()

    device = next(net.parameters()).device
    return forward


def grid_text(grid) -> str:
    """'64 x 27 taxels at 28.6 x 28.6 mm' for a MatSpec: rows x cols, and the taxel pitch along the bed
    x across it."""
    return f"{grid.rows} x {grid.cols} taxels at {1000 * grid.pitch_row_m:.3g} x {1000 * grid.pitch_col_m:.3g} mm"


@torch.no_grad()
def evaluate(data: LoadedData | str | Path, model: PressureNet | str | Path | None = None, batch_size: int = 64,
              progress: bool = True, mirror: bool = False, fit: bool | FitConfig = False) -> dict:
    """Per-sample errors (metres) of Mod2, Mod1 and the baseline on ``data``, plus the summary
    (:func:`summarise`): ``{"errors": {name: (N,) array}, "summary": {...}}``.

    data: a :class:`pressurepose.net.data.LoadedData` or what
    :func:`~pressurepose.net.data.load_dataset` reads (a dataset, a folder of datasets of one split,
    a training pack), on the model's mat (its rows, cols and taxel pitches; BadInput naming both mats
    otherwise); a LoadedData built by hand is checked as a training pack
    is (:func:`~pressurepose.net.data.check_loaded`: BadInput naming a missing, misshapen, non-finite
    or out-of-range field). model: a PressureNet, a model path or None (the shipped
    model), as :func:`pressurepose.net.infer.estimate`'s.
    Vertex errors compare with the true bodies posed by the network's own body layer (same
    topology); joint errors compare with the dataset's joints. progress: a progress bar over batches on
    stderr (default True, as for every function that runs over a dataset).
    mirror: average each estimate with the network's reading of the mirrored image
    (:mod:`pressurepose.net.mirror`). fit: True or a FitConfig: then move Mod2's body to fit each
    image's print (:mod:`pressurepose.net.fit`).
    """
    from tqdm import tqdm

    from pressurepose.net.infer import read_batch, resolve_model

    require_whole("batch size", batch_size, 1)
    if isinstance(data, PressureNet):
        raise BadInput("evaluate(data, model): the data come first, then the model")
    net = resolve_model(model)
    data = check_loaded(data) if isinstance(data, LoadedData) else load_dataset(data)
    if len(data) == 0:
        raise BadInput("no samples to evaluate")
    if not data.grid.same_grid(net.config.grid):
        raise BadInput(f"the dataset's mat ({data.mat}, {grid_text(data.grid)}) is not the model's "
                       f"({net.config.grid.name}, {grid_text(net.config.grid)}): evaluate a model on images of "
                       f"its own mat")
    fitting = fit_config(fit)
    require_bool("mirror", mirror)
    net.eval()
    device = next(net.parameters()).device
    t = data.tensors
    n = len(data)
    base = {g: baseline_body(_layer_forward(net, g), net.config.grid) for g in (0, 1)}
    base_out = {g: _layer_forward(net, g)(*(a[None] for a in base[g])) for g in (0, 1)}
    errs = {f"{row}_{m}": np.zeros(n) for row, _ in ROWS for m in ("mpjpe", "v2v")}
    errs.update(posture_correct=np.zeros(n, bool), stature_err=np.zeros(n), roll_err=np.zeros(n), turn_err=np.zeros(n))
    for s in tqdm(range(0, n, batch_size), desc="evaluate", unit="batch", disable=not progress):
        sl = slice(s, min(s + batch_size, n))
        gender = t["gender"][sl].to(device)
        pressure = t["pressure"][sl].to(device)
        out1, out2 = read_batch(net, pressure, gender, mirror, fitting)
        true_verts, _ = net.body(_params(t["betas"][sl].to(device), t["pose"][sl].to(device),
                                         t["transl"][sl].to(device)), gender)
        tv = true_verts.cpu().numpy()
        tj = t["joints"][sl].numpy()
        for row, out in (("mod2", out2), ("mod1", out1)):
            errs[f"{row}_mpjpe"][sl] = mpjpe(out.joints.cpu().numpy(), tj)
            errs[f"{row}_v2v"][sl] = v2v(out.vertices.cpu().numpy(), tv)
        g = gender.cpu().numpy()
        names = [GENDER_NAMES[int(x)] for x in g]
        est_pose, true_pose = out2.params.pose.cpu().numpy(), t["pose"][sl].numpy()
        errs["posture_correct"][sl] = posture_of(est_pose) == posture_of(true_pose)
        errs["roll_err"][sl], errs["turn_err"][sl] = roll_errors(est_pose, true_pose)
        h_est, _ = body_stature_mass(net, out2.params.betas.cpu().numpy(), names)
        h_true, _ = body_stature_mass(net, t["betas"][sl].numpy(), names)
        errs["stature_err"][sl] = h_est - h_true
        bv = np.stack([base_out[int(x)][0][0] for x in g])
        bj = np.stack([base_out[int(x)][1][0] for x in g])
        errs["baseline_mpjpe"][sl] = mpjpe(bj, tj)
        errs["baseline_v2v"][sl] = v2v(bv, tv)
    return {"errors": errs, "summary": summarise(errs, t["gender"].numpy(), t["partition"].numpy(),
                                                 data.partition_names)}


def roll_errors(est_pose, true_pose) -> tuple[np.ndarray, np.ndarray]:
    """Degrees (B,) each, for SMPL poses (B, 72): the roll error (the estimated roll less the true
    one, wrapped to [-180, 180)) and the turn error (|estimated roll| less |true roll|: negative
    where a turned body is read flatter, toward supine, than it lies)."""
    est, true = np.degrees(roll_angle(est_pose)), np.degrees(roll_angle(true_pose))
    return (est - true + 180.0) % 360.0 - 180.0, np.abs(est) - np.abs(true)


def summarise(errs: dict, gender: np.ndarray, partition: np.ndarray, partition_names) -> dict:
    """{group: {row: {"mpjpe_cm", "v2v_cm"}, "count", "posture_accuracy", "stature_mae_cm",
    "stature_bias_cm", "roll_mae_deg", "turn_bias_deg"}} for "all", each partition and each gender
    (posture, stature and roll: Mod2). turn_bias_deg: the mean turn error (:func:`roll_errors`)."""
    groups = {"all": np.ones(len(gender), bool)}
    for p in np.unique(partition):
        groups[f"partition:{partition_names[int(p)]}"] = partition == p
    for g in np.unique(gender):
        groups[f"gender:{GENDER_NAMES[int(g)]}"] = gender == g
    out = {}
    for name, sel in groups.items():
        out[name] = {"count": int(sel.sum())}
        if "posture_correct" in errs:
            err = errs["stature_err"][sel]
            out[name].update(posture_accuracy=float(np.mean(errs["posture_correct"][sel])),
                             stature_mae_cm=100 * float(np.mean(np.abs(err))),
                             stature_bias_cm=100 * float(np.mean(err)))
        if "roll_err" in errs:
            out[name].update(roll_mae_deg=float(np.mean(np.abs(errs["roll_err"][sel]))),
                             turn_bias_deg=float(np.mean(errs["turn_err"][sel])))
        for row, _ in ROWS:
            out[name][row] = {m + "_cm": 100 * float(np.mean(errs[f"{row}_{m}"][sel])) for m in ("mpjpe", "v2v")}
    return out


def format_table(summary: dict) -> str:
    """Markdown tables like the paper's Table 2 (overall), then by partition and gender."""
    lines = ["| network | MPJPE (cm) | v2v (cm) |", "|---|---|---|"]
    for row, label in ROWS:
        r = summary["all"][row]
        lines.append(f"| {label} | {r['mpjpe_cm']:.2f} | {r['v2v_cm']:.2f} |")
    lines += ["", "| group | n | MPJPE (cm) | v2v (cm) | BL MPJPE (cm) | BL v2v (cm) | posture acc. | "
              "stature MAE (cm) | stature bias (cm) | roll MAE (deg) | turn bias (deg) |",
              "|---|---|---|---|---|---|---|---|---|---|---|"]
    for name, s in summary.items():
        label = "all" if name == "all" else name.split(":", 1)[1]
        extra = (f" {s['posture_accuracy']:.2f} | {s['stature_mae_cm']:.1f} | {s['stature_bias_cm']:+.1f} |"
                 if "posture_accuracy" in s else " - | - | - |")
        extra += (f" {s['roll_mae_deg']:.1f} | {s['turn_bias_deg']:+.1f} |" if "roll_mae_deg" in s else " - | - |")
        lines.append(f"| {label} | {s['count']} | {s['mod2']['mpjpe_cm']:.2f} | {s['mod2']['v2v_cm']:.2f} | "
                     f"{s['baseline']['mpjpe_cm']:.2f} | {s['baseline']['v2v_cm']:.2f} |{extra}")
    return "\n".join(lines)
