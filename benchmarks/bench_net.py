"""PressureNet speed (and, given a model and a test set, accuracy).

    python -m benchmarks.bench_net [--frames 40] [--train-batch 32] [--no-write]
    python -m benchmarks.bench_net --model RUN/model.safetensors --data TEST_DIR   # + accuracy

Measures, on the BodiTrak 64 x 27 mat (network input 128 x 54), all on one CPU thread and by CPU
time (``time.process_time``: on a machine shared with other jobs the wall time measures their load,
the CPU time what the work costs on a free core):

* inference as a user calls it: ``estimate(image, "f")`` on one image, repeatedly (the shipped
  model, loaded once and cached; a random network with the shipped bodies when there is none),
  the same on batches, and a breakdown of one call into its parts;
* training images per CPU-second with the training loop's own steps (noise, input transform,
  forward, loss, backward, Adam) for Mod1 (L1) and Mod2 (L2, Mod1 frozen), for each speed option:
  the paper's CNN and the lighter variants, float32 and bfloat16 autocast (``cpu_amp``); and on a
  CUDA GPU with mixed precision when there is one;
* with --model and --data: the accuracy table (MPJPE, v2v; PressureNet, Mod1, mean-pose baseline)
  via :func:`accuracy_section`.

Prints the figures and replaces the ``bench:net`` section of docs/RESULTS.md.
"""

from __future__ import annotations

import argparse
import datetime
import os
import statistics
import tempfile
import time

import torch

from benchmarks.common import machine
from benchmarks.results import write_section
from pressurepose.body.model import BodyModel, asset_path
from pressurepose.body.toy import toy_body_arrays
from pressurepose.mat import custom_mat
from pressurepose.net.checkpoint import gendered_body, save_model
from pressurepose.net.cnn import flattened_size
from pressurepose.net.infer import DEFAULT_MODEL, estimate, resolve_model
from pressurepose.net.losses import LossScales, loss_l1, loss_l2
from pressurepose.net.model import NetConfig, PressureNet
from pressurepose.net.outputs import OutputConfig
from pressurepose.net.pmr import pmr
from pressurepose.net.train_config import CNN_VARIANTS

GRID = custom_mat(64, 27, 0.0286, 0.0286)
# (label, cnn variant, bf16 autocast) of the training options measured
TRAIN_OPTIONS = (("paper CNN, float32 (default)", "paper", False), ("paper CNN, bf16 autocast", "paper", True),
                 ("half CNN, float32", "half", False), ("half CNN, bf16 autocast", "half", True))


def bodies() -> tuple[BodyModel, BodyModel, str]:
    if asset_path("female.npz").is_file() and asset_path("male.npz").is_file():
        return BodyModel("female"), BodyModel("male"), "shipped female and male bodies"
    toy = BodyModel(toy_body_arrays())
    return toy, toy, "toy body (shipped bodies missing)"


def make_net(female, male, device="cpu", cnn: str = "paper") -> PressureNet:
    torch.manual_seed(0)
    w, length = GRID.size_m
    cfg = NetConfig(grid=GRID, outputs=OutputConfig.default((w / 2, length / 2, 0.25), (0.4, 0.4, 0.1)),
                    cnn_channels=CNN_VARIANTS[cnn])
    net = PressureNet(cfg, gendered_body(female, male)).to(device)
    torch.nn.init.normal_(net.mod2.cnn.fc.weight, std=1e-4)  # a trained-like Mod2, not the zero init
    return net


def fake_pressure(batch: int, seed: int = 0) -> torch.Tensor:
    """Body-sized blobs of pressure (the timing does not depend on the values)."""
    g = torch.Generator().manual_seed(seed)
    p = 40 * torch.rand(batch, *GRID.shape, generator=g)
    p[:, :, :6] = 0
    p[:, :, -6:] = 0
    return p


def timed(fn, n: int) -> tuple[float, float]:
    """Median CPU time of this process and median wall time (s) of ``n`` calls after two
    warm-ups (with one torch thread the process's CPU time is the cost on a free core)."""
    fn()
    fn()
    wall, cpu = [], []
    for _ in range(n):
        t0, c0 = time.perf_counter(), time.process_time()
        fn()
        wall.append(time.perf_counter() - t0)
        cpu.append(time.process_time() - c0)
    return statistics.median(cpu), statistics.median(wall)


def user_model(female, male, tmp: str):
    """What ``estimate(image, "f")`` uses: the shipped model (None), or a saved random network."""
    if DEFAULT_MODEL.is_file():
        return None, "the shipped model"
    path = save_model(os.path.join(tmp, "model.safetensors"), make_net(female, male), (female, male))
    return str(path), "a random network (no shipped model)"


def bench_estimate(model, frames: int, batches=(8, 64)) -> dict[str, tuple[float, float, int]]:
    """{label: (CPU s, wall s, images)} per call of ``estimate`` as a user calls it."""
    image = fake_pressure(1)[0].numpy()
    res = {"one image, estimate(image, 'f')": (*timed(lambda: estimate(image, "f", model=model), frames), 1),
           "one image, mirror-averaged, estimate(image, 'f', mirror=True)":
               (*timed(lambda: estimate(image, "f", model=model, mirror=True), frames), 1)}
    for b in batches:
        imgs = fake_pressure(b, seed=1).numpy()
        genders = ["f", "m"] * (b // 2) + ["f"] * (b % 2)
        res[f"batch of {b} (both genders)"] = (*timed(lambda: estimate(imgs, genders, model=model),
                                                       max(3, frames // b)), b)
    return res


@torch.inference_mode()
def bench_parts(net: PressureNet, frames: int) -> dict[str, tuple[float, float]]:
    """CPU and wall time of the parts of one call at batch 1 (each part repeated on its own, so
    with warm caches: their sum is below the whole call's)."""
    net.eval()
    p = fake_pressure(1)
    g = torch.zeros(1, dtype=torch.long)
    x1 = net.inputs(p)
    out1 = net.run_mod1(x1, g)
    x2 = net.mod2_input(x1, out1)
    raw = net.mod1.cnn(x1, g)
    return {
        "input transform": timed(lambda: net.inputs(p), frames),
        "Mod1 CNN": timed(lambda: net.mod1.cnn(x1, g), frames),
        "Mod2 CNN": timed(lambda: net.mod2.cnn(x2, g), frames),
        "output layer (one module)": timed(lambda: net.mod1.outputs(raw), frames),
        "body layer (one module)": timed(lambda: net.body(out1.params, g), frames),
        "PMR (one module)": timed(lambda: pmr(out1.vertices, GRID), frames),
    }


def dispatched_ops(fn) -> int:
    """How many tensor operations one call of ``fn`` dispatches to kernels (forward, backward and
    optimizer; counted below autograd, so views and in-place updates count too). A GPU training
    step of this size is bound by their number rather than by arithmetic, so fewer is faster there."""
    from torch.utils._python_dispatch import TorchDispatchMode

    class Count(TorchDispatchMode):
        n = 0

        def __torch_dispatch__(self, func, types, args=(), kwargs=None):
            Count.n += 1
            return func(*args, **(kwargs or {}))

    with Count():
        fn()
    return Count.n


def host_waits(fn) -> int:
    """How many times one call of ``fn`` makes the host wait for the GPU (reads of GPU values, blocking
    copies), counted by PyTorch's sync debug mode; 0 off a GPU."""
    if not torch.cuda.is_available():
        return 0
    import warnings

    torch.cuda.synchronize()
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        torch.cuda.set_sync_debug_mode("warn")
        try:
            fn()
        finally:
            torch.cuda.set_sync_debug_mode("default")
    return sum("synchroniz" in str(w.message) for w in caught)


def bench_training(net: PressureNet, batch: int, steps: int, device: str = "cpu", amp: bool = False,
                   compile_cnns: bool = False) -> dict[str, tuple[float, float, int]]:
    """{module: (images per CPU-second, images per wall-second, count)} of training steps as
    :func:`pressurepose.net.train.train` runs them (noise on, Mod1 frozen for Mod2); count: operations
    dispatched per step on the CPU (:func:`dispatched_ops`), the host's waits per step on a GPU
    (:func:`host_waits`; the step itself synchronises once at its end to be timed).
    compile_cnns: the CNNs through ``torch.compile`` (measured only; training does not use it)."""
    from pressurepose.net.train import _forward
    from pressurepose.net.train_config import TrainConfig

    if compile_cnns:
        for m in (net.mod1, net.mod2):
            m.cnn = torch.compile(m.cnn)

    p = fake_pressure(batch).to(device)
    g = (torch.arange(batch) % 2).to(device)
    joints = torch.zeros(batch, 24, 3, device=device)
    betas = torch.zeros(batch, 10, device=device)
    maps = torch.zeros(batch, *GRID.shape, device=device)
    scales = LossScales(q=10.0, contact=0.4)
    config = TrainConfig()
    dtype = torch.bfloat16 if device == "cpu" or torch.cuda.is_bf16_supported() else torch.float16
    out = {}
    for stage in (1, 2):
        module = net.mod1 if stage == 1 else net.mod2
        for q in net.mod1.parameters():
            q.requires_grad_(stage == 1)
        opt = torch.optim.Adam(module.parameters(), lr=2e-5, weight_decay=5e-4)
        net.train()
        net.mod1.train(stage == 1)
        gen = torch.Generator().manual_seed(0)  # on the CPU, as train() draws its noise

        def step():
            with torch.autocast(device, dtype=dtype, enabled=amp):
                o = _forward(net, stage, p, g, gen, config, maps=stage == 2)
                loss = (loss_l1(o, joints, betas, scales) if stage == 1
                        else loss_l2(o, joints, betas, maps, maps, scales))[0]
            opt.zero_grad(set_to_none=True)
            loss.backward()
            opt.step()
            if device == "cuda":
                torch.cuda.synchronize()

        cpu, wall = timed(step, steps)
        count = host_waits(step) if device == "cuda" else dispatched_ops(step)
        out[f"Mod{stage} ({'L1' if stage == 1 else 'L2'})"] = (batch / cpu, batch / wall, count)
    for q in net.mod1.parameters():
        q.requires_grad_(True)
    return out


def accuracy_section(model: str, data: str, batch_size: int = 64, limit: int | None = None) -> str:
    """Markdown: the accuracy table of ``model`` on the dataset ``data`` (with how it was trained)."""
    from pressurepose.eval.report import evaluate, format_table
    from pressurepose.net.checkpoint import read_model_files
    from pressurepose.net.data import load_dataset
    from pressurepose.net.infer import resolve_model

    meta, _ = read_model_files(model)
    net = resolve_model(model)
    if torch.cuda.is_available():
        net = net.to("cuda")
    test = load_dataset(data, limit=limit)
    result = evaluate(test, net, batch_size=batch_size, progress=False)
    tr = meta.get("train", {})
    n_train = str(meta.get("data", "?")).split(":")[0]
    return (f"### Accuracy on {data} ({len(test)} test samples)\n\n"
            f"Model {model}: trained on {n_train} samples, {tr.get('epochs_mod1', '?')} + "
            f"{tr.get('epochs_mod2', '?')} epochs (Mod1 + Mod2), noise {tr.get('noise')}, PMR {tr.get('use_pmr')}.\n\n"
            + format_table(result["summary"]) + "\n")




def main(argv=None) -> int:
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    p.add_argument("--frames", type=int, default=40, help="timed calls of estimate() on one image (median; default 40)")
    p.add_argument("--train-batch", type=int, default=32, help="CPU training batch (default 32)")
    p.add_argument("--train-steps", type=int, default=3, help="timed training steps per module and option (default 3)")
    p.add_argument("--model", default=None, help="trained model for the accuracy table")
    p.add_argument("--data", default=None, help="test dataset for the accuracy table")
    p.add_argument("--limit", type=int, default=None, help="test samples to use (default all)")
    p.add_argument("--compile", action="store_true", help="also time training with the CNNs under torch.compile "
                                                         "(compiles for a minute or more)")
    p.add_argument("--no-write", action="store_true", help="print only; leave docs/RESULTS.md alone")
    args = p.parse_args(argv)

    female, male, body_label = bodies()
    load_before = os.getloadavg()[0]
    torch.set_num_threads(1)
    with tempfile.TemporaryDirectory() as tmp:
        model, model_label = user_model(female, male, tmp)
        est = bench_estimate(model, args.frames)
        parts = bench_parts(resolve_model(model), args.frames)
    train_cpu = {label: bench_training(make_net(female, male, cnn=cnn), args.train_batch, args.train_steps, amp=amp)
                 for label, cnn, amp in TRAIN_OPTIONS}
    if args.compile:
        train_cpu["paper CNN, float32, torch.compile"] = bench_training(
            make_net(female, male), args.train_batch, args.train_steps, compile_cnns=True)
    train_gpu = None
    if torch.cuda.is_available():
        train_gpu = bench_training(make_net(female, male, "cuda"), 128, 10, device="cuda", amp=True)
    load_after = os.getloadavg()[0]

    cpu1, wall1, _ = est["one image, estimate(image, 'f')"]
    base = train_cpu[TRAIN_OPTIONS[0][0]]
    lines = [
        "## PressureNet (`benchmarks/bench_net.py`)",
        "",
        f"`python -m benchmarks.bench_net`; machine: {machine()}, {os.cpu_count()} CPUs (load average {load_before:.1f} before, "
        f"{load_after:.1f} after: the machine is shared with other jobs); torch {torch.__version__}, one thread; "
        f"{datetime.date.today().isoformat()}. Bodies: {body_label} ({female.num_vertices} vertices). "
        f"Mat 64 x 27, network input 128 x 54 (flattened CNN features {flattened_size(128, 54):,}). "
        "Figures are CPU time (`time.process_time`, one torch thread): the cost on a free core; the wall "
        "time on this shared machine is given beside it.",
        "",
        f"Inference as a user calls it, `estimate(image, \"f\")` on one 64 x 27 image, repeated, with "
        f"{model_label} loaded once and cached (goal >= 30 frames/s on one core): "
        f"**{1 / cpu1:.1f} frames/s by CPU time** ({1000 * cpu1:.1f} ms per call; {1 / wall1:.1f} frames/s by "
        f"wall time); medians of {args.frames} calls. Batches (both modules, meshes and maps for every image):",
        "",
        "| call | CPU ms per call | images per CPU-second | images per wall-second |",
        "|---|---|---|---|",
        *[f"| {k} | {1000 * c:.1f} | {n / c:.1f} | {n / w:.1f} |" for k, (c, w, n) in est.items()],
        "",
        "Parts of one call (batch 1, each repeated on its own with warm caches, so they add up to less "
        "than the call; the two CNNs and two body layers and PMRs run once per module):",
        "",
        "| part | CPU ms | wall ms |",
        "|---|---|---|",
        *[f"| {k} | {1000 * c:.2f} | {1000 * w:.2f} |" for k, (c, w) in parts.items()],
        "",
        f"Training on the CPU, one thread, batch {args.train_batch}, the training loop's steps (noise, input "
        f"transform, forward, loss, backward, Adam); median of {args.train_steps} steps. The paper's CNN in "
        "float32 is the default of `pressurepose train`; the others are options (`train --cnn half`, "
        "`--cpu-amp`). The shipped model is the half CNN trained with bf16 autocast (section shipped model), "
        "which also makes its inference faster than the paper CNN's.",
        "",
        "| option | Mod1 (L1) images per CPU-s | x default | Mod2 (L2) images per CPU-s | x default | "
        "Mod1 images per wall-s | operations per step, Mod1 / Mod2 |",
        "|---|---|---|---|---|---|---|",
        *[f"| {k} | {v['Mod1 (L1)'][0]:.1f} | {v['Mod1 (L1)'][0] / base['Mod1 (L1)'][0]:.1f} | "
          f"{v['Mod2 (L2)'][0]:.1f} | {v['Mod2 (L2)'][0] / base['Mod2 (L2)'][0]:.1f} | {v['Mod1 (L1)'][1]:.1f} | "
          f"{v['Mod1 (L1)'][2]:,} / {v['Mod2 (L2)'][2]:,} |"
          for k, v in train_cpu.items()],
        "",
        "Operations per step: tensor operations one training step dispatches (forward, backward and Adam, "
        "counted below autograd, views included). On a GPU a step this small is bound by their number "
        "rather than by arithmetic, so they are the figure to cut for GPU training.",
    ]
    if args.compile:
        lines += ["", "torch.compile row: both CNNs compiled by inductor (C++ made by the local gcc, offline); "
                      "the timed steps follow two warm-up steps, so compiling is not in the figures."]
    if train_gpu:
        lines += ["", f"Training, GPU ({torch.cuda.get_device_name()}), batch 128, mixed precision; host waits: "
                      "the times one step makes the host wait for the GPU (PyTorch's sync debug mode), counting "
                      "the synchronisation the benchmark adds to time each step:", "",
                  "| module | images/s (wall) | host waits per step |", "|---|---|---|",
                  *[f"| {k} | {w:.1f} | {c} |" for k, (_, w, c) in train_gpu.items()]]
    else:
        lines += ["", "No CUDA GPU on this machine: GPU training speed not measured."]
    if args.model and args.data:
        lines += ["", accuracy_section(args.model, args.data, limit=args.limit)]
    else:
        lines += ["", "Accuracy: not measured in this run (needs a trained model and a generated test set: "
                      "`python -m benchmarks.bench_net --model RUN/model.safetensors --data TEST_DIR`)."]
    text = "\n".join(lines)
    print(text)
    if not args.no_write:
        write_section("net", text)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
