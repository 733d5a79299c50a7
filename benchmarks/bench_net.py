"""PressureNet speed (and, given a model and a test set, accuracy).

    .venv/bin/python -m benchmarks.bench_net [--frames 40] [--train-batch 32] [--no-write]
    .venv/bin/python -m benchmarks.bench_net --model RUN/model.safetensors --data TEST_DIR   # + accuracy

Measures, on the BodiTrak 64 x 27 mat (network input 128 x 54) with the shipped bodies (the toy body
when they are missing):

* inference frames/s at batch 1 on one CPU core, Mod1 + Mod2 end to end (input transform, both
  CNNs, both body layers, both PMRs), with a breakdown;
* training images/s on the CPU (one optimiser step of Mod1 with L1, and of Mod2 with L2 with Mod1
  run frozen), and on a CUDA GPU with mixed precision when there is one;
* with --model and --data: the accuracy table (MPJPE, v2v; PressureNet, Mod1, mean-pose baseline)
  via :func:`accuracy_section`.

Prints the figures and replaces the ``bench:net`` section of docs/RESULTS.md.
"""

from __future__ import annotations

import argparse
import datetime
import os
import platform
import statistics
import time

import torch

from pressurepose.body.model import BodyModel, asset_path
from pressurepose.body.toy import toy_body_arrays
from pressurepose.net.checkpoint import gendered_body
from pressurepose.net.cnn import flattened_size
from pressurepose.net.losses import LossScales, loss_l1, loss_l2
from pressurepose.net.model import NetConfig, PressureNet
from pressurepose.net.outputs import OutputConfig
from pressurepose.net.pmr import MatGrid, pmr
from benchmarks.results import write_section

GRID = MatGrid(64, 27, 0.0286, 0.0286)


def bodies() -> tuple[BodyModel, BodyModel, str]:
    if asset_path("female.npz").is_file() and asset_path("male.npz").is_file():
        return BodyModel("female"), BodyModel("male"), "shipped female and male bodies"
    toy = BodyModel(toy_body_arrays())
    return toy, toy, "toy body (shipped bodies missing)"


def make_net(female, male, device="cpu") -> PressureNet:
    torch.manual_seed(0)
    w, length = GRID.size_m
    cfg = NetConfig(grid=GRID, outputs=OutputConfig.default((w / 2, length / 2, 0.25), (0.4, 0.4, 0.1)))
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
    """Median wall time and median CPU time of this thread (s) of ``n`` calls after two warm-ups.

    On a shared machine the wall time includes waiting for a core; with one torch thread the
    thread's CPU time is what the work costs on a free core."""
    fn()
    fn()
    wall, cpu = [], []
    for _ in range(n):
        t0, c0 = time.perf_counter(), time.thread_time()
        fn()
        wall.append(time.perf_counter() - t0)
        cpu.append(time.thread_time() - c0)
    return statistics.median(wall), statistics.median(cpu)


@torch.no_grad()
def bench_inference(net: PressureNet, frames: int) -> dict[str, tuple[float, float]]:
    net.eval()
    p = fake_pressure(1)
    g = torch.zeros(1, dtype=torch.long)
    x1 = net.inputs(p)
    out1 = net.run_mod1(x1, g)
    x2 = net.mod2_input(x1, out1)
    res = {
        "end to end (Mod1 + Mod2)": timed(lambda: net(p, g), frames),
        "input transform": timed(lambda: net.inputs(p), frames),
        "Mod1 CNN": timed(lambda: net.mod1.cnn(x1, g), frames),
        "Mod2 CNN": timed(lambda: net.mod2.cnn(x2, g), frames),
        "body layer": timed(lambda: net.body(out1.params, g), frames),
        "PMR": timed(lambda: pmr(out1.vertices, GRID), frames),
    }
    return res


def bench_training(net: PressureNet, batch: int, steps: int, device: str = "cpu", amp: bool = False) -> dict[str, float]:
    p = fake_pressure(batch).to(device)
    g = (torch.arange(batch) % 2).to(device)
    joints = torch.zeros(batch, 24, 3, device=device)
    betas = torch.zeros(batch, 10, device=device)
    maps = torch.zeros(batch, *GRID.shape, device=device)
    scales = LossScales(q=10.0, contact=0.4)
    dtype = torch.bfloat16 if device == "cuda" and torch.cuda.is_bf16_supported() else torch.float16
    out = {}
    for stage in (1, 2):
        module = net.mod1 if stage == 1 else net.mod2
        opt = torch.optim.Adam(module.parameters(), lr=2e-5, weight_decay=5e-4)
        net.train()
        net.mod1.train(stage == 1)

        def step():
            with torch.autocast(device, dtype=dtype, enabled=amp):
                x1 = net.inputs(p)
                if stage == 1:
                    loss, _ = loss_l1(net.run_mod1(x1, g, maps=False), joints, betas, scales)
                else:
                    with torch.no_grad():
                        o1 = net.run_mod1(x1, g)
                    loss, _ = loss_l2(net.run_mod2(x1, g, o1), joints, betas, maps, maps, scales)
            opt.zero_grad()
            loss.backward()
            opt.step()
            if device == "cuda":
                torch.cuda.synchronize()

        out[f"Mod{stage} ({'L1' if stage == 1 else 'L2'})"] = batch / timed(step, steps)[0]
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
    result = evaluate(net, test, batch_size=batch_size)
    tr = meta.get("train", {})
    n_train = str(meta.get("data", "?")).split(":")[0]
    return (f"### Accuracy on {data} ({len(test)} test samples)\n\n"
            f"Model {model}: trained on {n_train} samples, {tr.get('epochs_mod1', '?')} + "
            f"{tr.get('epochs_mod2', '?')} epochs (Mod1 + Mod2), noise {tr.get('noise')}, PMR {tr.get('use_pmr')}.\n\n"
            + format_table(result["summary"]) + "\n")




def main(argv=None) -> int:
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    p.add_argument("--frames", type=int, default=40, help="timed inference frames (median reported; default 40)")
    p.add_argument("--train-batch", type=int, default=32, help="CPU training batch (default 32)")
    p.add_argument("--train-steps", type=int, default=3, help="timed training steps per module (default 3)")
    p.add_argument("--train-threads", type=int, default=os.cpu_count(), help="CPU threads for training")
    p.add_argument("--model", default=None, help="trained model for the accuracy table")
    p.add_argument("--data", default=None, help="test dataset for the accuracy table")
    p.add_argument("--limit", type=int, default=None, help="test samples to use (default all)")
    p.add_argument("--no-write", action="store_true", help="print only; leave docs/RESULTS.md alone")
    args = p.parse_args(argv)

    female, male, body_label = bodies()
    load_before = os.getloadavg()[0]
    torch.set_num_threads(1)
    net = make_net(female, male)
    inf = bench_inference(net, args.frames)
    torch.set_num_threads(args.train_threads)
    train_cpu = bench_training(net, args.train_batch, args.train_steps)
    train_gpu = None
    if torch.cuda.is_available():
        gnet = make_net(female, male, "cuda")
        train_gpu = bench_training(gnet, 128, 10, device="cuda", amp=True)
    load_after = os.getloadavg()[0]

    wall, cpu = inf["end to end (Mod1 + Mod2)"]
    lines = [
        "## PressureNet (`benchmarks/bench_net.py`)",
        "",
        f"Machine: {platform.platform()}, {os.cpu_count()} CPUs (load average {load_before:.1f} before, "
        f"{load_after:.1f} after: the machine is shared); torch {torch.__version__}; "
        f"{datetime.date.today().isoformat()}. Bodies: {body_label} ({female.num_vertices} vertices). "
        f"Mat 64 x 27, network input 128 x 54 (flattened CNN features {flattened_size(128, 54):,}).",
        "",
        f"Inference, batch 1, one CPU thread, Mod1 + Mod2 end to end (goal >= 30 frames/s): "
        f"**{1 / cpu:.1f} frames/s by CPU time** (the cost on a free core), {1 / wall:.1f} frames/s by wall "
        f"time on this shared machine; medians of {args.frames} frames. Breakdown (ms, median):",
        "",
        "| part | CPU ms | wall ms |",
        "|---|---|---|",
        *[f"| {k} | {1000 * c:.2f} | {1000 * w:.2f} |" for k, (w, c) in inf.items()],
        "",
        f"Training, CPU ({args.train_threads} threads), batch {args.train_batch}, Adam step, wall time (median of "
        f"{args.train_steps}; shared machine, so a lower bound):",
        "",
        "| module | images/s |",
        "|---|---|",
        *[f"| {k} | {v:.1f} |" for k, v in train_cpu.items()],
    ]
    if train_gpu:
        lines += ["", f"Training, GPU ({torch.cuda.get_device_name()}), batch 128, mixed precision:", "",
                  "| module | images/s |", "|---|---|", *[f"| {k} | {v:.1f} |" for k, v in train_gpu.items()]]
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
