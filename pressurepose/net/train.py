"""Training PressureNet: Mod1 with L1, then Mod2 (Mod1 frozen) with L2 (paper sections 4-5, B.3).

Data is an in-memory mapping of tensors (or numpy arrays), N samples on one mat:

=========== ============ ==============================================
key         shape        meaning
=========== ============ ==============================================
pressure    (N, R, C)    pressure images, mmHg
gender      (N,)         0 / 1, or 'f' / 'm'
betas       (N, 10)      body shape
pose        (N, 72)      SMPL axis-angle, root first
transl      (N, 3)       the body model's translation, m (bed frame)
joints      (N, 24, 3)   joint positions, m (bed frame)
=========== ============ ==============================================

(:func:`pressurepose.net.data.load_dataset` reads a generated dataset into this layout.) The ground
truth PMR maps are PMR of the true bodies ("setting Psi^ = Psi", paper eq. 3), computed once.

Runs are seeded (the shuffling, the noise and dropout of epoch e depend only on (seed, stage, e)),
use a CUDA GPU with mixed precision when there is one, and write into ``out_dir``: ``log.csv``
(always), TensorBoard events in ``tb/`` (when the ``tensorboard`` package is importable), the
resumable state ``state.safetensors`` + ``state.json`` after every epoch, and the final
``model.safetensors`` + ``model.json``. Running again with the same config and data resumes from
the last saved epoch (the epoch counts may be raised to train on; the device may change).
"""

from __future__ import annotations

import csv
import dataclasses
import hashlib
import io
import json
import math
import sys
import time
from dataclasses import dataclass
from pathlib import Path
from typing import Mapping

import numpy as np
import torch

from pressurepose.body.model import BodyModel
from pressurepose.errors import BadInput, record_difference
from pressurepose.files import atomic_write, write_json_atomic, write_text_atomic
from pressurepose.mat import MatSpec
from pressurepose.net.checkpoint import bodies_meta, gendered_body, save_model
from pressurepose.net.data import LoadedData, as_numpy, check_arrays
from pressurepose.net.device import resolve_device
from pressurepose.net.losses import dataset_scales, joint_error, loss_l1, loss_l2
from pressurepose.net.model import GENDER_CODES, NetConfig, PressureNet
from pressurepose.net.noise import add_noise
from pressurepose.net.outputs import BodyParams, OutputConfig
from pressurepose.net.pmr import PMRConfig, pmr
from pressurepose.net.train_config import CNN_VARIANTS, PAPER_TRAINING, TrainConfig
from pressurepose.net.transforms import InputConfig, apply_floor

DATA_KEYS = ("pressure", "gender", "betas", "pose", "transl", "joints")  # what training reads (module docstring)


@dataclass
class TrainResult:
    """Where the trained model is and the per-epoch log rows."""

    model_path: Path
    history: list[dict]


# ---------------------------------------------------------------------------------------- data
def as_training_data(data: Mapping, grid: MatSpec) -> dict[str, torch.Tensor]:
    """The arrays of :data:`DATA_KEYS` in ``data`` (a mapping, the module docstring) as tensors, float32
    (gender int64, 'f' / 'm' read as 0 / 1), checked as a dataset is on loading
    (:func:`pressurepose.net.data.check_arrays`: shapes, finite numbers, pressure >= 0, gender 0 or 1);
    BadInput naming the field otherwise. pressure: (N, rows, cols) mmHg on ``grid``."""
    missing = [k for k in DATA_KEYS if k not in data]
    if missing:
        raise BadInput(f"training data lacks {', '.join(missing)}; expected keys {', '.join(DATA_KEYS)}")
    arrays = {k: as_numpy(data[k]) for k in DATA_KEYS}
    if arrays["gender"].dtype.kind in "USO":
        try:
            arrays["gender"] = np.array([GENDER_CODES[str(x).lower()] for x in arrays["gender"].reshape(-1)])
        except KeyError as exc:
            raise BadInput(f"training data gender {exc.args[0]!r}: expected 'f' or 'm'") from None
    if np.shape(arrays["pressure"])[1:] != grid.shape:
        raise BadInput(f"training data pressure has shape {np.shape(arrays['pressure'])}; expected images of "
                       f"{grid.rows} x {grid.cols} on the {grid.name} mat; for images of another mat give train() "
                       f"that mat (grid=) or the LoadedData of load_dataset, which carries it")
    check_arrays(arrays, grid.shape, None, "training data")
    if not len(arrays["pressure"]):
        raise BadInput("training data is empty")
    out = {k: torch.as_tensor(np.ascontiguousarray(a), dtype=torch.float32) for k, a in arrays.items() if k != "gender"}
    return {"gender": torch.as_tensor(arrays["gender"]).long(), **out}


def _fingerprint(data: dict[str, torch.Tensor]) -> str:
    h = hashlib.sha256()
    n = data["pressure"].shape[0]
    idx = torch.arange(0, n, max(1, n // 64))
    for k in sorted(data):
        h.update(k.encode())
        h.update(data[k][idx].numpy().tobytes())
        h.update(str(float(data[k].double().sum())).encode())
    return f"{n}:{h.hexdigest()[:16]}"


def _truth_params(data: dict[str, torch.Tensor], idx: torch.Tensor, device) -> BodyParams:
    pose = data["pose"][idx].to(device)
    return BodyParams(unconstrained=pose.new_zeros(pose.shape[0], 88), betas=data["betas"][idx].to(device),
                      transl=data["transl"][idx].to(device), root_euler=pose.new_zeros(pose.shape[0], 3),
                      global_orient=pose[:, :3], body_pose=pose[:, 3:])


@torch.no_grad()
def truth_maps(net: PressureNet, data: dict[str, torch.Tensor], device, chunk: int = 256,
               ) -> tuple[torch.Tensor, torch.Tensor]:
    """Ground-truth PMR maps of the true bodies, on the CPU: Q (N, R, C) float16 (mm of sink; half
    the memory of float32 at no loss that matters) and contact (N, R, C) uint8."""
    qs, cs = [], []
    for s in range(0, data["pressure"].shape[0], chunk):
        idx = torch.arange(s, min(s + chunk, data["pressure"].shape[0]))
        verts, _ = net.body(_truth_params(data, idx, device), data["gender"][idx].to(device))
        m = pmr(verts, net.config.grid, net.config.pmr)
        qs.append(m.q.half().cpu())
        cs.append(m.contact.to(torch.uint8).cpu())
    return torch.cat(qs), torch.cat(cs)


# ---------------------------------------------------------------------------------------- helpers
def cpu_bf16() -> bool | None:
    """Whether this CPU runs bfloat16 arithmetic natively (AVX512-BF16 or AMX), as PyTorch's oneDNN
    reports it; None where PyTorch does not say. Without it ``cpu_amp`` trains about 10x slower
    than float32 (docs/training.md)."""
    probe = getattr(getattr(torch.ops, "mkldnn", None), "_is_mkldnn_bf16_supported", None)
    if probe is None:
        return None
    try:
        return bool(probe())
    except RuntimeError:
        return None


def _epoch_seed(seed: int, stage: int, epoch: int) -> int:
    return (seed * 1_000_003 + stage * 10_007 + epoch) % (2 ** 62)


def net_config_for(config: TrainConfig, grid: MatSpec, transl: torch.Tensor) -> NetConfig:
    """The network config a training run builds: output home translation = the data's mean, its
    scale = the data's range (at least 5 cm per axis)."""
    t = transl.double()
    rng = (t.max(0).values - t.min(0).values).clamp_min(0.05)
    outputs = OutputConfig.default(t.mean(0).tolist(), rng.tolist(), gain=config.gain)
    return NetConfig(grid=grid, outputs=outputs,
                     inputs=InputConfig(upsample=config.upsample, blur_sigma=config.blur_sigma,
                                        edges_contact=config.edges_contact,
                                        contact_floor_mmhg=config.contact_floor_mmhg),
                     pmr=PMRConfig(), use_pmr=config.use_pmr, gender_input=config.gender_input,
                     dropout=config.dropout, cnn_channels=CNN_VARIANTS[config.cnn])


class _Logger:
    FIELDS = ["stage", "epoch", "lr", "train_loss", "train_joints_cm", "val_loss", "val_mpjpe_cm", "seconds",
              "images_per_s"]

    def __init__(self, out_dir: Path, history: list[dict]):
        """Starts log.csv afresh with the rows of ``history`` (those of the saved state)."""
        self.path = out_dir / "log.csv"
        self.rows = [{k: row.get(k, "") for k in self.FIELDS} for row in history]
        self._save()
        self.tb = None
        try:
            from torch.utils.tensorboard import SummaryWriter

            self.tb = SummaryWriter(str(out_dir / "tb"))
        except ImportError:  # tensorboard is optional
            pass

    def _save(self) -> None:
        text = io.StringIO()
        w = csv.DictWriter(text, fieldnames=self.FIELDS)
        w.writeheader()
        w.writerows(self.rows)
        write_text_atomic(self.path, text.getvalue())

    def write(self, row: dict) -> None:
        self.rows.append({k: row.get(k, "") for k in self.FIELDS})
        self._save()
        if self.tb is not None:
            for k in self.FIELDS[2:]:
                if isinstance(row.get(k), float) and math.isfinite(row[k]):
                    self.tb.add_scalar(f"mod{row['stage']}/{k}", row[k], row["epoch"])
            self.tb.flush()

    def close(self) -> None:
        if self.tb is not None:
            self.tb.close()


def _save_state(out_dir: Path, net: PressureNet, opt: torch.optim.Optimizer, record: dict) -> None:
    from safetensors.torch import save_file

    tensors = {f"net.{k}": v.detach().cpu().contiguous() for k, v in net.state_dict().items()}
    st = opt.state_dict()
    for i, s in st["state"].items():
        for k, v in s.items():
            tensors[f"opt.{i}.{k}"] = torch.as_tensor(v).detach().cpu().contiguous()
    record = {**record, "param_groups": st["param_groups"]}
    atomic_write(out_dir / "state.safetensors", lambda p: save_file(tensors, str(p)))
    write_json_atomic(out_dir / "state.json", record)


def _load_state(out_dir: Path, net: PressureNet, opt: torch.optim.Optimizer, record: dict) -> None:
    from safetensors.torch import load_file

    tensors = load_file(str(out_dir / "state.safetensors"))
    net.load_state_dict({k[4:]: v for k, v in tensors.items() if k.startswith("net.")})
    state: dict = {}
    for k, v in tensors.items():
        if k.startswith("opt."):
            _, i, name = k.split(".", 2)
            state.setdefault(int(i), {})[name] = v
    opt.load_state_dict({"state": state, "param_groups": record["param_groups"]})


# ---------------------------------------------------------------------------------------- training
def _optimizer(module: torch.nn.Module, config: TrainConfig, stage: int) -> torch.optim.Optimizer:
    return torch.optim.Adam(module.parameters(), lr=stage_lr(config, stage), weight_decay=config.weight_decay)


def stage_lr(config: TrainConfig, stage: int, epoch: int = 0, epochs: int = 1) -> float:
    """The learning rate of ``epoch`` (0-based) of ``epochs`` in ``stage`` (1 or 2)."""
    lr = config.lr_mod2 if stage == 2 and config.lr_mod2 is not None else config.lr
    if config.lr_schedule == "cosine":
        lr *= 0.5 * (1.0 + math.cos(math.pi * epoch / max(epochs, 1)))
    return lr


def _fits_on_gpu(device: torch.device, *tensors, share: float = 0.25) -> bool:
    """Whether the tensors (others ignored) take at most ``share`` of the GPU's free memory (the
    paper's 184,000 samples with their maps take about 2.3 GB; the training itself needs the rest)."""
    need = sum(t.numel() * t.element_size() for t in tensors if torch.is_tensor(t))
    free, _ = torch.cuda.mem_get_info(device)
    return need <= share * free


def _forward(net: PressureNet, stage: int, pressure, gender, noise_gen, config: TrainConfig, maps: bool):
    if noise_gen is not None:
        clean = apply_floor(pressure, net.config.inputs.contact_floor_mmhg)
        noisy, mask, sigma = add_noise(clean, noise_gen, config.noise_config)
        x1 = net.inputs(noisy, contact=mask, blur_sigma=sigma)
    else:
        x1 = net.inputs(pressure)
    # the mesh only where PMR needs it: the L1 terms (joints, betas) need the skeleton alone
    if stage == 1:
        return net.run_mod1(x1, gender, maps=maps, vertices=False)
    with torch.no_grad():
        out1 = net.run_mod1(x1, gender, maps=config.use_pmr, vertices=False)
    return net.run_mod2(x1, gender, out1, maps=maps, vertices=False)


def resumable_options(config: TrainConfig) -> dict:
    """The options a run resumes only with (a JSON-ready dict): all but the epoch counts, the
    device and ``cpu_amp``."""
    return json.loads(json.dumps({k: v for k, v in config.to_dict().items()
                                  if k not in ("epochs_mod1", "epochs_mod2", "device", "cpu_amp")}))


def as_trained(stored):
    """A stored run's identity (``state.json``'s ``identity``) as the run was trained: an option its
    ``train`` record does not name at the paper's value (:data:`PAPER_TRAINING`, else TrainConfig's
    default), its ``net`` record as :meth:`NetConfig.from_dict` reads it (a missing input setting at
    its default: ``inputs.contact_floor_mmhg`` 0). Anything else is returned as given."""
    if not isinstance(stored, dict) or not isinstance(stored.get("train"), dict):
        return stored
    out = {**stored, "train": {**resumable_options(TrainConfig(**PAPER_TRAINING)), **stored["train"]}}
    try:
        out["net"] = json.loads(json.dumps(NetConfig.from_dict(stored["net"]).to_dict()))
    except (BadInput, KeyError, TypeError, ValueError):
        pass  # compared as stored: the refusal names the difference
    return out


def validation_count(n: int, val_fraction: float) -> int:
    """How many of ``n`` samples a run holds out for validation (the rest train)."""
    return int(round(val_fraction * n))


def resume_line(out_dir: Path, history: list, config: TrainConfig) -> str:
    """'resuming the run in OUT: Mod1 3 of 6 epochs done, Mod2 0 of 3' from a saved state's history."""
    done = [sum(1 for r in history if isinstance(r, dict) and r.get("stage") == stage) for stage in (1, 2)]
    return (f"resuming the run in {out_dir}: Mod1 {done[0]} of {config.epochs_mod1} epochs done, Mod2 {done[1]} of "
            f"{config.epochs_mod2} (log.csv has each epoch's loss)")


def epoch_line(row: dict, epochs: int) -> str:
    """'mod1 epoch 3/48: loss 0.412, joints 14.2 cm (validation MPJPE 15.1 cm), 35 s' from a log row."""
    val = f" (validation MPJPE {row['val_mpjpe_cm']:.1f} cm)" if "val_mpjpe_cm" in row else ""
    return (f"mod{row['stage']} epoch {row['epoch'] + 1}/{epochs}: loss {row['train_loss']:.4g}, joints "
            f"{row['train_joints_cm']:.1f} cm{val}, {row['seconds']:.0f} s")


def train(data: LoadedData | Mapping, out_dir: str | Path, config: TrainConfig = TrainConfig(),
          bodies: tuple[BodyModel, BodyModel] | None = None, grid: MatSpec | None = None,
          progress: bool = True) -> TrainResult:
    """Train Mod1 then Mod2 on ``data``; write logs, resumable state and the model into ``out_dir``.

    data: a :class:`~pressurepose.net.data.LoadedData` (:func:`~pressurepose.net.data.load_dataset`:
    a dataset or a training pack, on its own mat) or a mapping of arrays (the module docstring).
    bodies: (female, male) BodyModels (default the shipped ones). grid: the mat the images are on
    (default: a LoadedData's own, else the BodiTrak BT-3510). progress: a progress bar per epoch, a
    line on stderr after each (:func:`epoch_line`), and one saying how far a run it resumes had gone
    (default True, as for every function that runs over a dataset; False: nothing on stderr).
    """
    from pressurepose.files import check_output_path

    if not isinstance(data, (LoadedData, Mapping)):
        raise BadInput(f"data is {type(data).__name__}; expected a LoadedData (load_dataset(path)) or a mapping of "
                       f"arrays")
    if not isinstance(config, TrainConfig):
        raise BadInput(f"config is {type(config).__name__}; expected a TrainConfig")
    if bodies is not None and not (isinstance(bodies, (tuple, list)) and len(bodies) == 2
                                   and all(isinstance(b, BodyModel) for b in bodies)):
        raise BadInput(f"bodies is {bodies!r:.80}; expected (female, male) BodyModels, or None for the shipped ones")
    if grid is not None and not isinstance(grid, MatSpec):
        raise BadInput(f"grid is {type(grid).__name__}; expected a MatSpec (get_mat(name)) or None")
    out_dir = check_output_path(out_dir, "out_dir", directory=True)
    if isinstance(data, LoadedData):
        if grid is not None and grid.shape != data.grid.shape:
            raise BadInput(f"grid is {grid.rows} x {grid.cols} but the data's mat ({data.mat}) is "
                           f"{data.grid.rows} x {data.grid.cols}; leave grid out to train on the data's mat")
        grid = data.grid if grid is None else grid
        data = data.tensors
    if grid is None:
        from pressurepose.mat import get_mat

        grid = get_mat("boditrak_bt3510")
    if bodies is None:
        bodies = (BodyModel("female"), BodyModel("male"))
    data = as_training_data(data, grid)
    device = resolve_device(config.device)
    n = data["pressure"].shape[0]
    n_val = validation_count(n, config.val_fraction)
    if n_val >= n:
        raise BadInput(f"val_fraction {config.val_fraction} of {n} sample(s) holds out {n_val}, which leaves none to "
                       f"train on; use a smaller fraction or more samples")
    perm = torch.randperm(n, generator=torch.Generator().manual_seed(config.seed))
    val_idx, train_idx = perm[:n_val].sort().values, perm[n_val:].sort().values

    net_config = net_config_for(config, grid, data["transl"][train_idx])
    torch.manual_seed(config.seed)  # the initial weights
    net = PressureNet(net_config, gendered_body(*bodies)).to(device)
    identity = {"train": resumable_options(config), "net": net_config.to_dict(), "bodies": bodies_meta(*bodies),
                "data": _fingerprint(data)}
    identity = json.loads(json.dumps(identity))  # tuples -> lists, as stored

    state_path = out_dir / "state.json"
    try:
        record = json.loads(state_path.read_text()) if state_path.exists() else None
    except (json.JSONDecodeError, UnicodeDecodeError) as exc:
        raise BadInput(f"{state_path} is corrupt ({exc}); nothing was overwritten. Delete {out_dir}'s "
                       f"state.json and state.safetensors to start the run afresh, or use another --out") from None
    if record is not None and not isinstance(record, dict):
        raise BadInput(f"{state_path} is not a training state; use another --out")
    if record is not None and as_trained(record.get("identity")) != identity:
        old = record.get("identity")
        what = record_difference(as_trained(old), identity) if isinstance(old, dict) else "an unreadable record"
        raise BadInput(f"{out_dir} holds a training run with a different config, body model or data ({what}); "
                       f"use another output folder (nothing was overwritten)")
    if record is not None and record.get("stage") == 2:
        ran = sum(1 for r in record.get("history", []) if isinstance(r, dict) and r.get("stage") == 1)
        if config.epochs_mod1 != ran:
            raise BadInput(f"{out_dir}: Mod1 finished after {ran} epoch(s) and Mod2 has trained on it, so Mod1 cannot "
                           f"be changed to {config.epochs_mod1} epochs; resume with --epochs-mod1 {ran} (more "
                           f"--epochs-mod2 may be added) or start a new run in another folder")

    q_true = c_true = None
    if config.use_pmr:
        q_true, c_true = truth_maps(net, data, device)
    t_idx = train_idx
    scales = dataset_scales(data["joints"][t_idx], data["betas"][t_idx],
                            q_true[t_idx] if q_true is not None else None,
                            c_true[t_idx] if c_true is not None else None,
                            paper_joints_betas=config.loss_sigmas == "paper")

    if device.type == "cuda" and _fits_on_gpu(device, *data.values(), q_true, c_true):
        # the whole set on the GPU once: a step then copies nothing from the host, and a blocking copy
        # would hold the host until the GPU had finished its queue, every step
        data = {k: v.to(device) if torch.is_tensor(v) else v for k, v in data.items()}
        q_true, c_true = (None if x is None else x.to(device) for x in (q_true, c_true))
        train_idx, val_idx = train_idx.to(device), val_idx.to(device)
    use_amp = (config.amp and device.type == "cuda") or (config.cpu_amp and device.type == "cpu")
    amp_dtype = (torch.bfloat16 if device.type == "cpu" or (use_amp and torch.cuda.is_bf16_supported())
                 else torch.float16)
    history = list(record["history"]) if record else []
    if record and progress:
        print(resume_line(out_dir, history, config), file=sys.stderr)
    out_dir.mkdir(parents=True, exist_ok=True)  # only now: a refusal above writes nothing
    logger = _Logger(out_dir, history)
    resume_stage, resume_epoch = (record["stage"], record["epoch"] + 1) if record else (1, 0)

    try:
        for stage in (1, 2):
            if stage < resume_stage:
                continue
            epochs = config.epochs_mod1 if stage == 1 else config.epochs_mod2
            module = net.mod1 if stage == 1 else net.mod2
            for p in net.mod1.parameters():
                p.requires_grad_(stage == 1)
            opt = _optimizer(module, config, stage)
            first = 0
            if record and stage == resume_stage:
                _load_state(out_dir, net, opt, record)
                first = resume_epoch
            scaler = torch.amp.GradScaler("cuda", enabled=use_amp and amp_dtype == torch.float16)
            l2 = stage == 2 and config.use_pmr
            for epoch in range(first, epochs):
                for group in opt.param_groups:
                    group["lr"] = stage_lr(config, stage, epoch, epochs)
                seed = _epoch_seed(config.seed, stage, epoch)
                torch.manual_seed(seed)
                gen = torch.Generator().manual_seed(seed)
                noise_gen = torch.Generator().manual_seed(seed + 1) if config.noise else None
                order = train_idx[torch.randperm(len(train_idx), generator=gen).to(train_idx.device)]
                net.train()
                net.mod1.train(stage == 1)
                # summed on the device and read once an epoch: a float() per step would wait for the GPU every step
                t0, count = time.perf_counter(), 0
                sums = {k: torch.zeros((), dtype=torch.float64, device=device) for k in ("loss", "joints")}
                batches = range(0, len(order), config.batch_size)
                if progress:
                    from tqdm import tqdm

                    batches = tqdm(batches, desc=f"mod{stage} epoch {epoch + 1}/{epochs}", leave=False)
                for s in batches:
                    idx = order[s:s + config.batch_size]
                    pressure = data["pressure"][idx].to(device, non_blocking=True)
                    gender = data["gender"][idx].to(device)
                    joints, betas = data["joints"][idx].to(device), data["betas"][idx].to(device)
                    q_b, c_b = (q_true[idx].to(device), c_true[idx].to(device)) if l2 else (None, None)
                    with torch.autocast(device.type, dtype=amp_dtype, enabled=use_amp):
                        out = _forward(net, stage, pressure, gender, noise_gen, config, maps=l2)
                        if l2:
                            loss, parts = loss_l2(out, joints, betas, q_b, c_b, scales, config.turn_loss)
                        else:
                            loss, parts = loss_l1(out, joints, betas, scales, config.turn_loss)
                    opt.zero_grad(set_to_none=True)
                    scaler.scale(loss).backward()
                    scaler.step(opt)
                    scaler.update()
                    sums["loss"] += loss.detach().double() * len(idx)
                    sums["joints"] += parts["joints"].detach().double() * len(idx)
                    count += len(idx)
                seconds = time.perf_counter() - t0
                row = {"stage": stage, "epoch": epoch, "lr": opt.param_groups[0]["lr"],
                       "train_loss": float(sums["loss"]) / max(count, 1),
                       "train_joints_cm": 100 * float(sums["joints"]) * scales.joints_m / max(count, 1),
                       "seconds": seconds,
                       "images_per_s": count / max(seconds, 1e-9)}
                if n_val:
                    row.update(_validate(net, stage, data, val_idx, q_true, c_true, scales, config, device))
                logger.write(row)
                history.append(row)
                if progress:
                    print(epoch_line(row, epochs), file=sys.stderr)
                if (epoch + 1) % config.save_every == 0 or epoch == epochs - 1:
                    _save_state(out_dir, net, opt, {"identity": identity, "stage": stage, "epoch": epoch,
                                                    "history": history})
    finally:
        logger.close()
    meta = {"loss_scales": dataclasses.asdict(scales), "train": config.to_dict(),
            "data": identity["data"], "history": history}
    model_path = save_model(out_dir / "model.safetensors", net, bodies, meta)
    return TrainResult(model_path, history)


@torch.no_grad()
def _validate(net, stage, data, val_idx, q_true, c_true, scales, config, device) -> dict:
    net.eval()
    tot_loss = tot_err = 0.0
    l2 = stage == 2 and config.use_pmr
    for s in range(0, len(val_idx), config.batch_size):
        idx = val_idx[s:s + config.batch_size]
        out = _forward(net, stage, data["pressure"][idx].to(device), data["gender"][idx].to(device), None,
                       config, maps=l2)
        joints, betas = data["joints"][idx].to(device), data["betas"][idx].to(device)
        if l2:
            loss, _ = loss_l2(out, joints, betas, q_true[idx].to(device), c_true[idx].to(device), scales,
                              config.turn_loss)
        else:
            loss, _ = loss_l1(out, joints, betas, scales, config.turn_loss)
        tot_loss += float(loss) * len(idx)
        tot_err += float(joint_error(out.joints, joints).sum())
    return {"val_loss": tot_loss / len(val_idx), "val_mpjpe_cm": 100 * tot_err / len(val_idx)}
