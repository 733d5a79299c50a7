"""CLI verb ``pressurepose evaluate``."""

from __future__ import annotations

import argparse
from pathlib import Path


def add_evaluate_arguments(p: argparse.ArgumentParser) -> None:
    p.description = ("Evaluate a trained PressureNet on a generated dataset: MPJPE (24 joints) and "
                     "vertex-to-vertex error in cm, overall, by partition and by gender, beside the "
                     "paper's mean-pose baseline (mean shape, supine, centred, straight limbs).")
    p.add_argument("--model", required=True, help="trained model (.json with its .safetensors files, .pt, or a run folder)")
    p.add_argument("--data", required=True, help="dataset directory (or a folder of datasets) from `generate`")
    p.add_argument("--out", default=None, help="folder for report.md and report.json (default: print only)")
    p.add_argument("--batch-size", type=int, default=64, help="images per forward pass (default 64)")
    p.add_argument("--limit", type=int, default=None, help="evaluate only the first N samples")
    p.add_argument("--device", default="auto", help="auto (CUDA if available), cpu, cuda ...")
    from pressurepose.net.commands import add_body_arguments

    add_body_arguments(p)


def run_evaluate(args) -> int:
    from pressurepose.errors import BadInput
    from pressurepose.eval.report import evaluate, format_table
    from pressurepose.files import check_output_path, write_json_atomic, write_text_atomic
    from pressurepose.net.data import load_dataset
    from pressurepose.net.commands import body_specs
    from pressurepose.net.infer import resolve_model
    from pressurepose.net.train import resolve_device

    if args.out:
        check_output_path(args.out, "--out", directory=True)
    if args.batch_size < 1:
        raise BadInput(f"--batch-size is {args.batch_size}; expected a whole number >= 1")
    if args.limit is not None and args.limit < 1:
        raise BadInput(f"--limit is {args.limit}; expected a whole number >= 1 (or leave it out for all samples)")
    device = resolve_device(args.device)
    net = resolve_model(args.model, body_specs(args))
    net = net.to(device)
    data = load_dataset(args.data, limit=args.limit)
    if data.grid.shape != net.config.grid.shape:
        raise BadInput(f"the dataset's mat ({data.mat}, {data.grid.rows} x {data.grid.cols}) is not the model's "
                       f"({net.config.grid.rows} x {net.config.grid.cols})")
    result = evaluate(net, data, batch_size=args.batch_size, progress=True)
    table = format_table(result["summary"])
    print(f"{len(data)} samples from {args.data}\n\n{table}")
    if args.out:
        out = Path(args.out)
        out.mkdir(parents=True, exist_ok=True)
        write_text_atomic(out / "report.md", f"# PressureNet evaluation\n\nmodel: {args.model}\ndata: {args.data} "
                                             f"({len(data)} samples)\n\n{table}\n")
        write_json_atomic(out / "report.json", {"model": str(args.model), "data": str(args.data),
                                                "summary": result["summary"]})
        print(f"\nreport written to {out}")
    return 0
