"""CLI verbs ``pressurepose train``, ``pressurepose pack``, ``pressurepose train-sites`` and
``pressurepose infer``."""

from __future__ import annotations

import argparse
import sys

from pressurepose.cli.args import add_progress_argument, add_recording_arguments, seed_arg


def add_train_arguments(p: argparse.ArgumentParser) -> None:
    from pressurepose.net.train_config import CNN_VARIANTS, TrainConfig

    d = TrainConfig()
    p.description = ("Train PressureNet (Mod1 with loss L1, then Mod2 with L2) on a generated dataset. "
                     f"Defaults are the paper's but for the contact floor ({d.contact_floor_mmhg:g} mmHg) and a "
                     f"{100 * d.val_fraction:g} % validation share. Uses a CUDA GPU with mixed precision when there is one. "
                     "Rerunning the same command resumes from the last saved epoch.")
    p.add_argument("--data", required=True,
                   help="dataset directory (or a folder of datasets) from `generate`, or a training pack (.npz) from `pack`")
    p.add_argument("--out", required=True, help="run folder: log.csv, tb/, state.*, model.safetensors + model.json")
    p.add_argument("--epochs-mod1", type=int, default=d.epochs_mod1, help=f"epochs for Mod1 (default {d.epochs_mod1})")
    p.add_argument("--epochs-mod2", type=int, default=d.epochs_mod2, help=f"epochs for Mod2 (default {d.epochs_mod2})")
    p.add_argument("--batch-size", type=int, default=d.batch_size, help=f"images per training step (default {d.batch_size})")
    p.add_argument("--lr", type=float, default=d.lr, help=f"Adam learning rate (default {d.lr})")
    p.add_argument("--lr-mod2", type=float, default=None, help="Mod2's learning rate (default: --lr, as the paper; the shipped recipe trains Mod2 at a fifth of Mod1's "
                        "rate, docs/training.md)")
    p.add_argument("--lr-schedule", choices=("constant", "cosine"), default=d.lr_schedule,
                   help="constant (the paper's, default) or cosine: each stage's rate falls from its --lr to 0 over its "
                        "epochs (the shipped recipe's, with a larger --lr and fewer epochs)")
    p.add_argument("--weight-decay", type=float, default=d.weight_decay, help=f"Adam's L2 weight decay (default {d.weight_decay:g}, the paper's; 0 turns it off)")
    p.add_argument("--no-noise", action="store_true", help="train without the noise model (one of the paper's ablations, table 2)")
    p.add_argument("--no-pmr", action="store_true", help="no PMR maps into Mod2 and L1 for both (the paper's PMR ablation)")
    p.add_argument("--no-edges-contact", action="store_true", help="drop the Sobel and contact channels (the paper's input ablation)")
    p.add_argument("--gender-input", action="store_true", help="also feed the gender flag to the CNN (not in the paper; the shipped "
                                                              "model's: real stature error 9.5 -> 8.3 cm, docs/training.md)")
    p.add_argument("--loss-sigmas", choices=("paper", "data"), default=d.loss_sigmas,
                   help="the loss's normalising constants for joints and shape (sigma_s, sigma_beta): the paper's "
                        "values (paper, default) or the training set's spread (data: for training data whose "
                        "bodies vary unlike the paper's)")
    p.add_argument("--val-fraction", type=float, default=d.val_fraction,
                   help=f"held-out share for per-epoch validation (default {d.val_fraction:g}; 0, the paper's, trains "
                        f"on every sample and validates on none)")
    p.add_argument("--seed", type=seed_arg, default=d.seed, help=f"seed of the split, shuffling, noise, dropout and init (default {d.seed})")
    p.add_argument("--device", default=d.device, help="auto (CUDA if available, default), cpu, cuda, cuda:1 ...")
    p.add_argument("--no-amp", action="store_true", help="float32 throughout on CUDA (default: the CNNs in mixed precision, faster); to rule half "
                        "precision out when a GPU run differs from a CPU one")
    p.add_argument("--cpu-amp", action="store_true", help="bfloat16 autocast for the CNNs on the CPU: 1.5-1.6x faster "
                                                         "on some CPUs with bf16 instructions, 0.7-0.9x on others, "
                                                         "about 10x slower where there are none (look for bf16 in "
                                                         "lscpu); time a short run first (docs/training.md)")
    p.add_argument("--cnn", choices=tuple(CNN_VARIANTS), default=d.cnn,
                   help="CNN widths: paper (default) or half (half as wide, about 3.5x faster to train on a CPU; the "
                        "shipped model's)")
    p.add_argument("--contact-floor", type=float, default=d.contact_floor_mmhg, metavar="MMHG",
                   help="sensor floor: readings at or below it are dropped from the input and the contact channel, "
                        f"in training and in every later use of the model [{d.contact_floor_mmhg:g}: above 99 %% of "
                        "the faint readings a real mat shows away from the body; 0 is the paper's p > 0, which reads "
                        "a real mat's background as body (docs/sim_to_real.md)]")
    p.add_argument("--turn-loss", type=float, default=d.turn_loss, metavar="W",
                   help="weight of a loss on the body's turn about its long axis (the hips' and shoulders' "
                        "left-right axes, apart from the joint distances; not in the paper) [0]")
    p.add_argument("--save-every", type=int, default=d.save_every, help="epochs between resumable states (default 1: an interrupted run repeats at most the epoch it "
                        "was in; each stage's last epoch is always saved)")
    p.add_argument("--limit", type=int, default=None, help="use only the first N samples (default: all)")
    p.add_argument("--female", default="female", help="female body model: 'female' (shipped) or an SMPL-format file")
    p.add_argument("--male", default="male", help="male body model: 'male' (shipped) or an SMPL-format file")
    add_progress_argument(p, also="nor a line per epoch (log.csv in --out has them)")


def run_train(args) -> int:
    from pressurepose.errors import BadInput
    from pressurepose.files import check_output_path
    from pressurepose.net.checkpoint import body_model
    from pressurepose.net.data import load_dataset
    from pressurepose.net.train import train, validation_count
    from pressurepose.net.train_config import TrainConfig

    check_output_path(args.out, "--out", directory=True)
    if args.limit is not None and args.limit < 1:
        raise BadInput(f"--limit is {args.limit}; expected a whole number >= 1 (or leave it out for all samples)")
    if not 0 <= args.turn_loss < float("inf"):
        raise BadInput(f"--turn-loss is {args.turn_loss}; expected a weight >= 0")
    data = load_dataset(args.data, limit=args.limit)
    config = TrainConfig(epochs_mod1=args.epochs_mod1, epochs_mod2=args.epochs_mod2, batch_size=args.batch_size,
                         lr=args.lr, lr_mod2=args.lr_mod2, lr_schedule=args.lr_schedule, weight_decay=args.weight_decay, noise=not args.no_noise,
                         use_pmr=not args.no_pmr, edges_contact=not args.no_edges_contact,
                         gender_input=args.gender_input, loss_sigmas=args.loss_sigmas, val_fraction=args.val_fraction,
                         seed=args.seed, device=args.device, amp=not args.no_amp, save_every=args.save_every,
                         cnn=args.cnn, cpu_amp=args.cpu_amp, contact_floor_mmhg=args.contact_floor,
                         turn_loss=args.turn_loss)
    if args.cpu_amp:
        from pressurepose.net.device import resolve_device
        from pressurepose.net.train import cpu_bf16

        if resolve_device(args.device).type == "cpu" and cpu_bf16() is False:
            print("warning: --cpu-amp on a CPU without bf16 instructions trains about 10x slower than without it "
                  "(docs/training.md); drop --cpu-amp here", file=sys.stderr)
    female = body_model(args.female)
    male = female if args.male == args.female else body_model(args.male)
    held = validation_count(len(data), config.val_fraction)
    print(f"training on {len(data) - held} samples" + (f", validating on {held}" if held else "")
          + f" ({data.mat}, {data.grid.rows} x {data.grid.cols}) into {args.out}")
    result = train(data, args.out, config, bodies=(female, male), progress=not args.no_progress)
    last = result.history[-1] if result.history else {}
    print(f"model: {result.model_path}"
          + (f"  (last epoch: loss {last['train_loss']:.4f}" + (f", val MPJPE {last['val_mpjpe_cm']:.2f} cm"
                                                               if "val_mpjpe_cm" in last else "") + ")" if last else ""))
    return 0


def add_pack_arguments(p: argparse.ArgumentParser) -> None:
    p.description = ("Write the arrays that `train` and `evaluate` read from a dataset (pressure, labels, gender, "
                     "partition; not force, depth or contact) to one compressed .npz file, about a third of the "
                     "dataset's size: make data on CPU machines, copy one file to a GPU machine, and give it to "
                     "`train --data` or `evaluate --data` there (that machine needs no simulator).")
    p.add_argument("data", help="dataset directory (or a folder of datasets of one split) from `generate`")
    p.add_argument("--out", required=True, help="the pack to write (.npz)")


def run_pack(args) -> int:
    from pressurepose.files import check_output_path
    from pressurepose.net.data import load_dataset, save_pack

    out = check_output_path(args.out, "--out", suffixes=(".npz",))
    data = load_dataset(args.data)
    save_pack(data, out)
    print(f"packed {len(data)} samples ({data.mat}, {data.grid.rows} x {data.grid.cols}) into {out} "
          f"({out.stat().st_size / 1e6:.1f} MB)")
    return 0


def add_infer_arguments(p: argparse.ArgumentParser) -> None:
    p.description = ("Estimate 3D body pose and shape from pressure images with a trained PressureNet; write "
                     "betas, pose, joints (JSON and NPZ), meshes and pictures, and the load on each body site "
                     "(sites.json: peak and mean mmHg, contact area, share of the load; sites_000.png; each loaded "
                     "taxel's site read from the estimated body and the image by a site network, docs/monitoring.md). "
                     "Without --mat the images are mmHg "
                     "on the model's own mat. With --mat, FILE is a recording from that mat (any size, raw or "
                     "mmHg): its frames are cleaned, put in mmHg and resampled onto the model's mat as "
                     "evaluate-real does (docs/real-mats.md).")
    p.add_argument("pressure_file", metavar="FILE",
                   help="pressure image(s): .npy ((R, C) or (B, R, C)), .csv (one image); without --mat also .npz (a "
                        "`simulate` output or a training pack) or HDF5 (.h5, a shard of a generated dataset); with "
                        "--mat also a text recording (.txt) of one frame a line, as PMD experiment I's files (every "
                        "frame that carries the body is estimated)")
    add_recording_arguments(p, required=False)
    p.add_argument("--gender", default=None, help="f or m (one for all images, or comma-separated per image); "
                                                 "may be left out for a file that stores it (a dataset shard, a "
                                                 "`simulate` .npz, a training pack)")
    p.add_argument("--model", default=None, help="trained model (.json with its .safetensors files, .pt, or a run folder); "
                                                "default: the shipped model")
    p.add_argument("--out", required=True, help="output folder")
    p.add_argument("--key", default="pressure", help="HDF5 dataset or .npz array holding the images (default pressure)")
    p.add_argument("--mesh-format", choices=("ply", "obj"), default="ply", help="mesh file format (default ply)")
    p.add_argument("--max-figures", type=int, default=16, help="PNG pictures for at most this many images (default 16)")
    add_mirror_argument(p)
    add_fit_argument(p)
    add_site_net_argument(p)
    add_body_arguments(p)
    add_progress_argument(p)


def add_site_net_argument(p: argparse.ArgumentParser) -> None:
    """--site-net for verbs that read body sites (pressurepose.net.sitenet)."""
    p.add_argument("--site-net", default="auto", metavar="FILE",
                   help="site network that gives each loaded taxel its body site from the image and the estimated "
                        "body: a sitenet.json from `train-sites` (for a model of your own), or none (the estimated "
                        "body alone); default auto: the one shipped for the model's mat, if the model reads it")


def site_net_choice(value: str):
    """--site-net's value as estimate()'s site_net: 'auto', None for 'none', else the file."""
    return None if value == "none" else value


def add_train_sites_arguments(p: argparse.ArgumentParser) -> None:
    from pressurepose.net.sitenet_train import VAL_FRACTION, SiteTrainConfig

    d = SiteTrainConfig()
    p.description = ("Train a site network for a PressureNet: it learns to give each loaded taxel the body site "
                     "the simulator recorded under it, from the image and the site map of the body the model "
                     "estimates (docs/monitoring.md). Needed for a model of your own, above all on another mat; "
                     "pass the result to infer and monitor with --site-net, or to estimate(site_net=...). "
                     f"{100 * VAL_FRACTION:g} % of the samples are held out to report how often the most loaded site "
                     "is named right, with and without it. Rerunning the same command resumes from the last epoch.")
    p.add_argument("--data", required=True,
                   help="dataset directory (or a folder of datasets) from `generate` on the model's mat; its samples "
                        "record each taxel's body site")
    p.add_argument("--model", default=None, help="the trained PressureNet it serves (.json, .pt or a run folder); "
                                                "default: the shipped model")
    p.add_argument("--out", required=True, help="folder: sitenet.json and sitenet.safetensors, and the state to resume")
    p.add_argument("--epochs", type=int, default=d.epochs, help=f"passes over the data (default {d.epochs})")
    p.add_argument("--seed", type=seed_arg, default=d.seed, help=f"seed of the split, shuffling, noise and init "
                                                                 f"(default {d.seed})")
    add_body_arguments(p)
    add_progress_argument(p, also="nor the loss per epoch")


def run_train_sites(args) -> int:
    from pressurepose.files import check_output_path
    from pressurepose.net.infer import resolve_model
    from pressurepose.net.sitenet_train import (
        SiteTrainConfig,
        held_out_split,
        load_site_data,
        most_loaded_right,
        train_site_net,
    )

    out = check_output_path(args.out, "--out", directory=True)
    config = SiteTrainConfig(epochs=args.epochs, seed=args.seed)
    net = resolve_model(args.model, body_specs(args))
    data = load_site_data(args.data, model=net, progress=not args.no_progress)
    train, held = held_out_split(data, args.seed)
    g = data.grid
    print(f"training a site network on {len(train)} samples, holding out {len(held)} ({g.rows} x {g.cols} mat) "
          f"into {out}")
    made_for = {"model": "shipped" if args.model is None else str(args.model), "data": str(args.data),
                "held_out": len(held)}
    site_net = train_site_net(train, config, out=out, progress=not args.no_progress, meta=made_for)
    print(f"site network: {out / 'sitenet.json'}")
    if len(held):
        from pressurepose.net.sitenet import resolve_site_net

        net_right, body_right = most_loaded_right(held, site_net), most_loaded_right(held, None)
        shipped = resolve_site_net("auto", g)  # what infer and monitor use by default on this mat
        print(f"most loaded body site named right in the {len(held)} held-out images: {100 * net_right:.1f} % with "
              f"it, {100 * body_right:.1f} % from the estimated body alone"
              + ("" if shipped is None else f", {100 * most_loaded_right(held, shipped):.1f} % with the shipped "
                                            f"site network (the default on this mat)"))
        if net_right < body_right:
            print("warning: the site network names the most loaded site less often than the estimated body alone; "
                  "train it on more data or for more epochs, or do not use it", file=sys.stderr)
    return 0


def most_loaded(est, i: int) -> str:
    """'; most loaded: sacrum (44 %, peak 47 mmHg)' for image i of an estimate with site loads; when
    the rest of the body (no named site) carries the most, the named site loaded most follows."""
    from pressurepose.body.sites import OTHER, SITES, site_label

    if est.sites is None or not est.sites.most_loaded()[i]:
        return ""

    def said(site: str) -> str:
        k = SITES.index(site)
        return (f"{site_label(site)} ({100 * est.sites.share[i, k]:.0f} %, peak "
                f"{est.sites.peak_mmhg[i, k]:.0f} mmHg)")

    top, named = est.sites.most_loaded()[i], est.sites.most_loaded(named=True)[i]
    text = f"; most loaded: {said(top)}"
    return text + (f"; of the named sites: {said(named)}" if top == SITES[OTHER] and named else "")


def add_mirror_argument(p: argparse.ArgumentParser) -> None:
    """--mirror for verbs that run a trained model (pressurepose.net.mirror)."""
    p.add_argument("--mirror", action="store_true",
                   help="also read each image's left-right mirror and average the two bodies (test-time mirror "
                        "averaging; about twice the work)")


def add_fit_argument(p: argparse.ArgumentParser) -> None:
    """--fit for verbs that run a trained model (pressurepose.net.fit)."""
    p.add_argument("--fit", action="store_true",
                   help="after the network, move each body so that it lies where the image shows load "
                        "(about 0.3 s of one CPU core an image; docs/training.md)")


def add_body_arguments(p: argparse.ArgumentParser) -> None:
    """--female/--male for verbs that load a trained model."""
    p.add_argument("--female", default=None, help="female body model the model was trained with, if not where the "
                                                  "model says: 'female' (shipped) or an SMPL-format file")
    p.add_argument("--male", default=None, help="male body model, likewise")


def body_specs(args) -> tuple[str, str] | None:
    """(female, male) specs from --female/--male, or None to use those stored with the model."""
    if args.female is None and args.male is None:
        return None
    if args.female is None or args.male is None:
        from pressurepose.errors import BadInput

        raise BadInput("give both --female and --male (or neither)")
    return args.female, args.male


def frame_ranges(frames) -> str:
    """'2-13, 15' for frame indices [2, 3, ..., 13, 15]."""
    out, start, prev = [], None, None
    for f in [int(x) for x in frames] + [None]:
        if start is not None and (f is None or f != prev + 1):
            out.append(str(start) if start == prev else f"{start}-{prev}")
            start = None
        if f is not None and start is None:
            start = f
        prev = f
    return ", ".join(out)


SHOWN_ESTIMATES = 5  # images whose pelvis and shape infer prints
SHOWN_DOUBTS = 20  # images that do not look like a person lying down, one warning line each


def doubt_lines(est, source: str) -> list[str]:
    """One warning sentence per image of ``est`` that does not look like a person lying on the mat
    (:attr:`~pressurepose.net.infer.Estimate.plausibility`), at most :data:`SHOWN_DOUBTS` and a
    line counting the rest."""
    if est.plausibility is None:
        return []
    doubtful = est.plausibility.doubtful
    lines = [f"{est.image_name(int(i))} of {source} does not look like a person lying on the mat: "
             f"{est.plausibility.reason[i]}; its estimate means nothing (written all the same)"
             for i in doubtful[:SHOWN_DOUBTS]]
    if len(doubtful) > SHOWN_DOUBTS:
        lines.append(f"... and {len(doubtful) - SHOWN_DOUBTS} more images that do not look like a person lying on "
                     f"the mat (\"plausible\": false in estimate.json)")
    return lines


def run_infer(args) -> int:
    import sys
    import warnings

    from pressurepose.errors import BadInput
    from pressurepose.files import check_output_path
    from pressurepose.net.infer import (
        estimate,
        load_genders,
        load_pressure,
        resolve_model,
    )

    out = check_output_path(args.out, "--out", directory=True)
    if args.max_figures < 0:
        raise BadInput(f"--max-figures is {args.max_figures}; expected 0 or more")
    if args.mat is None:
        given = [flag for flag, v in (("--units", args.units), ("--weight-kg", args.weight_kg), ("--gain", args.gain))
                 if v is not None] + (["--head-row"] if args.head_row != "first" else [])
        if given:
            raise BadInput(f"{', '.join(given)} describe a recording on its own mat: give --mat too (a preset or a "
                           f"mat.json); without --mat the images are mmHg on the model's mat")
        if str(args.pressure_file).lower().endswith(".txt"):
            raise BadInput(f"{args.pressure_file}: a text recording is read on its own mat: give --mat (a preset or a "
                           f"mat.json) and --units (raw, with --weight-kg or --gain, or mmHg)")
        source = load_pressure(args.pressure_file, key=args.key)
        recording = {}
    else:
        if args.units is None:
            raise BadInput("--mat needs --units: raw (the mat's own readings, with --weight-kg or --gain) or mmHg")
        source = args.pressure_file
        recording = dict(mat=args.mat, units=args.units, weight_kg=args.weight_kg, gain=args.gain,
                         head_row=args.head_row)
    if args.gender is None:
        gender = load_genders(args.pressure_file)
    else:
        gender = args.gender.split(",") if "," in args.gender else args.gender
    net = resolve_model(args.model, body_specs(args))
    progress = args.mat is None and source.ndim == 3 and len(source) > 64 and not args.no_progress
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        est = estimate(source, gender, model=net, progress=progress, mirror=args.mirror, fit=args.fit,
                       what=str(args.pressure_file), site_net=site_net_choice(args.site_net), **recording)
    for w in caught:
        print(f"warning: {w.message}", file=sys.stderr)
    for line in doubt_lines(est, str(args.pressure_file)):
        print(f"warning: {line}", file=sys.stderr)
    from pressurepose.viz.estimate import save_estimate_figures
    from pressurepose.viz.sites import save_site_figures

    paths = est.save(out, mesh_format=args.mesh_format)
    paths += save_estimate_figures(est, out, max_figures=args.max_figures, progress=not args.no_progress)
    paths += save_site_figures(est, out, max_figures=args.max_figures, progress=not args.no_progress)
    print(f"{len(est)} estimate(s) written to {out} ({len(paths)} files)")
    if est.frame is not None:
        left_out = "" if list(est.frame) == list(range(len(est))) else "; the others blank or start-up frames"
        from pressurepose.data.readers.recording import resolve_mat

        g = net.config.grid
        own = resolve_mat(args.mat)[0]
        same = own.same_grid(g)
        print(f"  {'frame' if len(est.frame) == 1 else 'frames'} {frame_ranges(est.frame)} of {args.pressure_file} "
              f"(counted from 0{left_out}), on the {args.mat} mat, "
              + ("the model's own" if same else f"resampled onto the model's {g.rows} x {g.cols}"))
    import numpy as np

    from pressurepose.eval.posture import body_stature_mass, posture_of
    from pressurepose.pose.posture import roll_angle

    shown = min(len(est), SHOWN_ESTIMATES)
    height, mass = body_stature_mass(net, est.betas[:shown], est.gender[:shown])
    turn = np.degrees(np.atleast_1d(roll_angle(est.pose[:shown])))
    for i, posture in enumerate(posture_of(est.pose[:shown])):
        root = est.joints[i, 0]
        doubt = ("" if est.plausibility is None or est.plausibility.ok[i]
                 else " (not like a person lying on the mat: see the warning)")
        print(f"  {est.image_name(i)}: {posture} (turned {turn[i]:+.0f} deg), stature {height[i]:.2f} m, "
              f"{mass[i]:.0f} kg, pelvis at x {root[0]:.2f}, y {root[1]:.2f} m{most_loaded(est, i)}{doubt}")
    if len(est) > SHOWN_ESTIMATES:
        print(f"  ... and {len(est) - SHOWN_ESTIMATES} more (all in {out / 'estimate.json'})")
    return 0
