"""CLI verbs ``pressurepose generate`` and ``pressurepose info``."""

from __future__ import annotations

import argparse
import json
import sys
from pathlib import Path

from pressurepose.cli.args import MAX_EXAMPLES, add_progress_argument, seed_arg
from pressurepose.errors import BadInput
from pressurepose.pose.partitions import ALIASES, PARTITIONS

_PRODUCER_HELP = (
    "what makes each sample [physics]. 'physics' is the data engine: pose sampler -> settle "
    "(MuJoCo ragdoll on a soft bed) -> press (mesh on the calibrated foundation) -> mat reading. "
    "'synthetic' is a cheap deterministic TEST/DEMO producer that draws Gaussian blobs under a stick "
    "figure: NOT physics, do not train on it. Any importable 'module:function' producer also works")


def _option(text: str) -> tuple[str, object]:
    key, sep, value = text.partition("=")
    if not sep or not key:
        raise argparse.ArgumentTypeError(f"{text!r}: expected KEY=VALUE")
    try:
        parsed = json.loads(value)
    except json.JSONDecodeError:
        parsed = value
    if not isinstance(parsed, (str, int, float, bool)):
        raise argparse.ArgumentTypeError(f"{text!r}: the value must be a string, number or true/false")
    return key, parsed


# The shard size of a new dataset made by `generate` (a dataset already in --out keeps its own). A
# shard is written only once all of it is made, so this is the most work an interruption loses per
# worker: about a minute of one core with physics (0.6-1.6 samples per CPU-second). The paper's
# 206,000 samples make about 3,200 files (90 or so per dataset of the recipe). A shard's fields are
# stored in chunks of 64 samples at any shard size; the files' own metadata adds about 4 % to the
# bytes of 256-sample shards (the synthetic producer's samples). GenerationConfig keeps 256, so that
# configs written in scripts keep their identity.
NEW_SHARD_SIZE = 64
AUTO = "auto"  # --workers: one worker process per core this process may use


def _workers(text: str) -> int | str:
    """--workers: a whole number of at least 1, or 'auto'."""
    if text.strip().lower() == AUTO:
        return AUTO
    try:
        n = int(text)
    except ValueError:
        n = 0
    if n < 1:
        raise argparse.ArgumentTypeError(f"{text!r}: expected a number of worker processes (1 or more) or 'auto'")
    return n


def _shards(text: str) -> list[int]:
    out = []
    try:
        for part in text.split(","):
            lo, sep, hi = part.partition("-")
            if sep and int(hi) < int(lo):
                raise argparse.ArgumentTypeError(f"{text!r}: the range {part} runs backwards; write {hi}-{lo}")
            out.extend(range(int(lo), int(hi) + 1) if sep else [int(lo)])
    except ValueError:
        raise argparse.ArgumentTypeError(f"{text!r}: expected shard numbers like 3 or 0-4,7") from None
    return out


def add_generate_arguments(p: argparse.ArgumentParser) -> None:
    from pressurepose.cli.pose import add_body_arguments
    from pressurepose.cli.sim import add_settle_argument

    p.description = (
        "Generate a labelled synthetic dataset (HDF5 shards + manifest.json) into --out. Each sample "
        "is a pure function of (config, seed, sample index), so rerunning the same command after an "
        "interruption (even kill -9) keeps the finished shards, makes only the missing ones, and "
        "gives the same dataset as an uninterrupted run. Either give one partition (--partition, "
        "--gender, --count) or a whole --recipe.")
    p.epilog = ("examples:\n"
                "  pressurepose generate --partition general --gender f --count 2000 --seed 1 --out data/gen_f\n"
                "  pressurepose generate --recipe paper --out data/paper   # on every core this process may use\n"
                "  pressurepose generate --recipe paper --scale 0.01 --out data/paper_small\n"
                "  pressurepose generate ... --ray auto          # run on the Ray cluster this machine is in")
    p.formatter_class = argparse.RawDescriptionHelpFormatter
    g = p.add_argument_group("what to make")
    g.add_argument("--partition", help=f"one of {', '.join(PARTITIONS)} (the first six are the paper's; "
                                       f"aliases: {', '.join(ALIASES)}); pressurepose.pose.partitions describes them")
    g.add_argument("--gender", help="f or m")
    g.add_argument("--limbs-on-bed", action="store_true",
                   help="start elbows, wrists, knees and ankles over the mattress (the paper's 'plo')")
    add_body_arguments(g)
    add_settle_argument(g)
    g.add_argument("--randomize", action="store_true",
                   help="domain randomisation: draw the mattress and tissue stiffness, sensor gain and "
                        "threshold and the mat's offset and rotation per sample (docs/physics.md); each "
                        "sample's drawn values are stored with it")
    g.add_argument("--count", type=int, help="number of samples")
    g.add_argument("--seed", type=seed_arg, default=0, help="random seed (default 0)")
    g.add_argument("--recipe", help="make a whole mix instead: 'paper' (the paper's 206K samples, appendix "
                                    "A.7) or a recipe JSON file; each entry goes to OUT/<entry name>")
    g.add_argument("--scale", type=float, default=1.0,
                   help="with --recipe: multiply every count by this (default 1; e.g. 0.01 for a quick small mix)")
    g.add_argument("--mat", default=None, help="mat preset: boditrak_bt3510 (64 x 27, default), slp (192 x 84), "
                                               "tip (56 x 40) or fsa_softflex_2048 (64 x 32); or a mat.json of any "
                                               "grid (rows, cols, pitch_m, optional pitch_col_m, max_mmhg, name; "
                                               "docs/data.md), laid on the default mattress")
    g.add_argument("--bed", default=None, metavar="JSON",
                   help="the bed the bodies lie on: a `pressurepose calibrate --out` file or a BedSpec.to_dict "
                        "record, its mat a preset or any grid (kept in the manifest; the same seed draws the same "
                        "bodies on any bed) [the mat's default bed]")
    g.add_argument("--producer", default="physics", help=_PRODUCER_HELP)
    g.add_argument("--option", type=_option, action="append", default=[], metavar="KEY=VALUE",
                   help="producer option, repeatable (synthetic: reject_rate, cost_ms, sleep_ms)")
    g.add_argument("--shard-size", type=int, default=None,
                   help=f"samples per shard file, a shard being written once all of it is made (default: "
                        f"{NEW_SHARD_SIZE} for a new dataset; a dataset already in --out keeps its own). It changes "
                        f"no sample")
    g.add_argument("--max-attempts", type=int, default=200,
                   help="rejected attempts allowed per sample before the run fails (default 200)")
    g.add_argument("--out", required=True, help="output directory (created; reused to resume)")
    r = p.add_argument_group("how to run")
    r.add_argument("--workers", type=_workers, default=AUTO,
                   help="local worker processes: a number (1: this process alone) or 'auto' (default): one per "
                        "core this process may use, one per 8 samples to make at most. Never more than the samples "
                        "to make; the dataset is the same for any number")
    r.add_argument("--ray", metavar="ADDRESS",
                   help="run the work units on Ray instead: 'local' starts a private local instance, "
                        "'auto' joins this machine's cluster, or ray://host:port (needs the [ray] extra)")
    r.add_argument("--retries", type=int, default=2, help="extra tries for a failing shard (default 2)")
    r.add_argument("--repair", action="store_true",
                   help="set corrupt shards aside (renamed *.corrupt-<time>) and make them again")
    r.add_argument("--shards", type=_shards, help="make only these shards, e.g. 3 or 0-4,7 (one config)")
    add_progress_argument(r)


def run_generate(args: argparse.Namespace) -> int:
    from pressurepose.cli.pose import body_settings
    from pressurepose.data.dataset import SPLITS
    from pressurepose.data.generate import generate
    from pressurepose.data.pipeline import GenerationError
    from pressurepose.data.producers import check_options
    from pressurepose.data.recipes import load_recipe
    from pressurepose.data.schema import GenerationConfig
    from pressurepose.data.store import MANIFEST
    from pressurepose.files import check_output_path
    from pressurepose.cli.args import bed_of
    from pressurepose.mat import MATS

    check_output_path(args.out, "--out", directory=True)
    bed = bed_of(args.mat, args.bed)
    default_bed = args.bed is None and bed.mat.name in MATS  # a preset's default bed is implied by its name
    common = dict(mat=bed.mat.name, bed="" if default_bed else bed.to_dict(), shard_size=NEW_SHARD_SIZE,
                  producer=args.producer, max_attempts=args.max_attempts, options=dict(args.option),
                  randomize=bool(args.randomize), settle=args.settle, **body_settings(args))
    out = Path(args.out)
    if args.recipe:
        if args.partition or args.gender or args.count is not None or args.limbs_on_bed:
            raise BadInput("--recipe sets partitions, genders, limbs-on-bed and counts itself; "
                           "drop --partition/--gender/--count/--limbs-on-bed")
        if args.shards is not None:
            raise BadInput("--shards works with one config, not with --recipe")
        jobs = [(out / e.name, e.config) for e in load_recipe(args.recipe, scale=args.scale, **common)]
        if (out / MANIFEST).exists():
            raise BadInput(f"{out} holds a single dataset; a recipe's datasets would be mixed into it. "
                           f"Use another --out for the recipe")
    else:
        missing = [f"--{n}" for n in ("partition", "gender", "count") if getattr(args, n) is None]
        if missing:
            raise BadInput(f"give {', '.join(missing)} (or --recipe)")
        jobs = [(out, GenerationConfig(partition=args.partition, gender=args.gender,
                                       limbs_on_bed=args.limbs_on_bed, count=args.count, seed=args.seed,
                                       **common))]
        inner = sorted(p.parent for p in out.glob(f"*/**/{MANIFEST}")) if out.is_dir() else []
        if inner or (out.is_dir() and any((out / s).is_dir() for s in SPLITS)):
            raise BadInput(f"{out} holds datasets in its sub-folders (a recipe's output?); a single dataset "
                           f"there would be counted with them. Use another --out")
    jobs = [(path, _laid_out(path, config, args.shard_size)) for path, config in jobs]
    for _, config in jobs:
        check_options(config)
    if args.producer == "synthetic":
        print("note: producer 'synthetic' makes TEST/DEMO data (not physics)", file=sys.stderr)
    for i, (path, config) in enumerate(jobs):
        if args.repair:
            _set_aside_unreadable_manifest(path)
        try:
            report = generate(config, path, workers=args.workers, ray_address=args.ray, retries=args.retries,
                              progress=not args.no_progress, repair=args.repair, only_shards=args.shards)
        except GenerationError as exc:  # attempts exhausted, or a unit that kept failing: say which, no traceback
            print(f"error: {path}: {exc}\nfinished shards are kept; rerunning the same command resumes",
                  file=sys.stderr)
            return 1
        except KeyboardInterrupt:
            print("\n" + interrupted_line(path, config, done=i, of=len(jobs)), file=sys.stderr)
            return 130
        m = report.manifest
        attempts = m.attempts
        rate = 100.0 * sum(m.rejections.values()) / attempts if attempts else 0.0
        print(f"[{i + 1}/{len(jobs)}] {path}: {m.samples_done}/{config.count} samples, made {report.made} "
              f"shard(s), kept {report.skipped}, {report.retries} retried, rejected {rate:.1f}% "
              f"in {report.seconds:.1f} s ({_ran_on(report.workers)})")
    return 0


def _ran_on(workers: int) -> str:
    """Where a run's samples were made, in words (``workers``: :attr:`RunReport.workers`)."""
    if workers == 0:
        return "on Ray"
    return "this process" if workers == 1 else f"{workers} worker processes"


def _stored_shard_size(path: Path) -> int | None:
    """Samples per shard of the dataset in ``path``; None where there is none, or its manifest cannot
    be read (the run then says why, or ``--repair`` sets it aside)."""
    from pressurepose.data.store import MANIFEST, Manifest

    if not (path / MANIFEST).is_file():
        return None
    try:
        return Manifest.load(path).config.shard_size
    except (BadInput, OSError):
        return None


def _laid_out(path: Path, config, given: int | None):
    """``config`` with the shard size of the dataset at ``path``: ``given`` (--shard-size), else that of
    the dataset already there (so it resumes), else :data:`NEW_SHARD_SIZE`. BadInput when ``given``
    differs from the dataset's own: shard size is part of a dataset's config."""
    import dataclasses

    stored = _stored_shard_size(path)
    if given is not None and stored is not None and given != stored:
        raise BadInput(f"{path} holds a dataset of {stored}-sample shards; --shard-size {given} would lay its "
                       f"samples out anew. Leave --shard-size out (or give {stored}) to resume it, or use another "
                       f"--out")
    size = next(s for s in (given, stored, NEW_SHARD_SIZE) if s is not None)
    return config if size == config.shard_size else dataclasses.replace(config, shard_size=size)


def interrupted_line(path: Path, config, done: int = 0, of: int = 1) -> str:
    """What an interrupted ``generate`` keeps, in words: the samples of ``path``'s finished shards
    (a shard is written only when all of it is made) and, for a recipe, the datasets already made."""
    from pressurepose.data.store import MANIFEST, Manifest

    try:
        kept = Manifest.load(path).samples_done if (path / MANIFEST).is_file() else 0
    except (BadInput, OSError, ValueError):  # an unreadable manifest keeps nothing; the rerun says why
        kept = 0
    recipe = f"{done} of the recipe's {of} datasets are complete; " if of > 1 else ""
    shard = min(config.shard_size, config.count)
    return (f"interrupted: {recipe}{kept} of the {config.count} samples of {path} are in finished shards and are "
            f"kept; rerunning the same command makes the rest. A shard ({shard} samples here; --shard-size) is "
            f"written only once all of it is made, so the samples of an unfinished shard are made again")


def _set_aside_unreadable_manifest(out: Path) -> None:
    """With --repair: a manifest that cannot be read is renamed ``*.corrupt-<time>``, with the shards it
    vouched for (their checksums are lost), so the dataset is made again."""
    import os
    import time

    from pressurepose.data.store import FORMAT, MANIFEST, set_aside_path

    if not (out / MANIFEST).is_file():
        return
    try:
        raw = json.loads((out / MANIFEST).read_text())
        if isinstance(raw, dict) and raw.get("format") == FORMAT:
            return  # readable: any other problem with it is reported, not repaired
    except (json.JSONDecodeError, UnicodeDecodeError):
        pass
    stamp = time.strftime("%Y%m%d-%H%M%S")
    for p in [out / MANIFEST, *sorted(out.glob("shard-*.h5"))]:
        os.replace(p, set_aside_path(p, stamp))
    print(f"note: {out / MANIFEST} was unreadable; set it and its shards aside (*.corrupt-{stamp})",
          file=sys.stderr)


def add_info_arguments(p: argparse.ArgumentParser) -> None:
    p.description = ("Summarise a dataset directory (or a folder of datasets, e.g. a recipe's output): "
                     "counts by partition and gender, rejection rates, pressure statistics; writes a PNG "
                     "of sample images and histograms.")
    p.add_argument("dir", help="dataset directory")
    p.add_argument("--png", help="picture to write (default DIR/info.png); a folder of splits (a recipe's output: "
                                 "train/, test/) gets one picture per split, its name after the split's: "
                                 "info_train.png, info_test.png")
    p.add_argument("--examples", type=int, default=6, help="sample images in the picture (default 6)")
    p.add_argument("--no-verify", action="store_true",
                   help="skip the shard checksum check (default: every shard is read and checked; skip it for a "
                        "quick look at a large dataset already checked)")


def run_info(args: argparse.Namespace) -> int:
    """One summary per split (train, test...) when DIR holds several: they are never counted together."""
    from pressurepose.data.dataset import find_datasets, split_folders
    from pressurepose.data.info import format_summary, summarize
    from pressurepose.files import FIGURE_SUFFIXES, check_output_path
    from pressurepose.viz.dataset import draw_summary

    root = Path(args.dir)
    find_datasets(root)  # a file, a missing folder or no dataset: said before anything is written
    png = Path(args.png) if args.png else root / "info.png"
    check_output_path(png, "--png", suffixes=FIGURE_SUFFIXES)
    if not 0 <= args.examples <= MAX_EXAMPLES:
        raise BadInput(f"--examples is {args.examples}; expected 0 to {MAX_EXAMPLES} images")
    splits = split_folders(root)
    parts = splits if len(splits) > 1 else {"": root}
    for split, folder in parts.items():
        summary = summarize(folder, verify=not args.no_verify, examples=args.examples)
        print(format_summary(summary) + "\n")
        path = draw_summary(summary, png.with_name(f"{png.stem}_{split}{png.suffix}") if split else png)
        print(f"picture: {path}\n")
    return 0


def add_convert_arguments(p: argparse.ArgumentParser) -> None:
    p.description = (
        "Convert the official PressurePose release to pressurepose datasets, or back. SRC may be a "
        "synthetic .p file or a folder of them (each becomes OUT/<file stem>, a dataset), or a real-data "
        "participant folder with participant_info_red.p (becomes OUT/<participant>.h5: pressure images, "
        "body facts, point clouds). With --to-pressurepose, SRC is a pressurepose dataset (BodiTrak 64 x 27) "
        "and OUT a .p file in the release format. Pickles are read with an unpickler that only builds "
        "arrays. Images are mirrored and coordinates rotated into pressurepose's bed frame (z up, y toward the feet; "
        "docs/data.md).")
    p.add_argument("src", help="release file or folder, or (with --to-pressurepose) a dataset directory")
    p.add_argument("--out", required=True, help="output directory (or .p file with --to-pressurepose)")
    p.add_argument("--to-pressurepose", action="store_true", help="export a pressurepose dataset to the release format")
    p.add_argument("--partition", help="override the partition read from the file name")
    p.add_argument("--gender", help="override the gender read from the file name (f or m)")
    p.add_argument("--limbs-on-bed", choices=("yes", "no"), help="override the 'plo' flag read from the file name")
    p.add_argument("--body", help="body model (f, m, or an SMPL-format file) used to express the root "
                                  "position as transl; default: the shipped model of the sample's gender")


def run_convert(args: argparse.Namespace) -> int:
    from pressurepose.body import BodyModel
    from pressurepose.data.dataset import DatasetReader
    from pressurepose.data.readers import pressurepose_pickle as pp
    from pressurepose.files import check_output_path

    src, out = Path(args.src), Path(args.out)
    if not src.exists():
        raise BadInput(f"{src} does not exist; expected a PressurePose .p file, a folder of them, a participant "
                       f"folder or (with --to-pressurepose) a dataset")
    if args.to_pressurepose:
        check_output_path(out, "--out", suffixes=(".p",))
        samples = list(DatasetReader(src))
        pp.export_synthetic(samples, out)
        print(f"wrote {len(samples)} samples to {out}")
        return 0
    check_output_path(out, "--out", directory=True)
    if src.is_dir() and (src / "participant_info_red.p").exists():
        out.mkdir(parents=True, exist_ok=True)
        part = pp.read_real_participant(src)
        path = pp.save_real_hdf5(part, out / f"{part.name}.h5")
        print(f"{src}: {', '.join(f'{k} {len(r.pressure)}' for k, r in part.recordings.items())} images -> {path}")
        return 0
    files = sorted(src.glob("*.p")) if src.is_dir() else [src]
    if not files:
        raise BadInput(f"{src} holds no .p files and is not a participant folder")
    body = BodyModel(args.body) if args.body else None
    plo = None if args.limbs_on_bed is None else args.limbs_on_bed == "yes"
    for f in files:
        m = pp.convert_synthetic(f, out / f.stem if len(files) > 1 or src.is_dir() else out, body=body,
                                 partition=args.partition, gender=args.gender, limbs_on_bed=plo)
        c = m.config
        print(f"{f}: {c.count} samples ({c.partition}, {c.gender}{', limbs on bed' if c.limbs_on_bed else ''})")
    return 0


def add_repress_arguments(p: argparse.ArgumentParser) -> None:
    p.description = (
        "Press a dataset's resting bodies again on another bed: new images, the same rests, in minutes "
        "instead of the hours settling takes. The bed (a `pressurepose calibrate --out` file or a bare "
        "BedSpec record) may differ from the dataset's own only in the soft tissue and the sensor law "
        "and threshold (what the settle does not use); randomised samples keep their draws. SRC may be "
        "one dataset or a folder of them (a recipe's output); OUT gets the same layout. Resumable: rerun "
        "the same command to finish. Wedge partitions cannot be re-pressed (the wedge's forces are not stored): "
        "--skip-wedge leaves them out, to be made with generate --bed.")
    p.add_argument("src", help="dataset directory, or a folder of datasets")
    p.add_argument("--bed", required=True, help="JSON file of the bed to press on")
    p.add_argument("--out", required=True, help="output directory (new or empty, or the same run to resume)")
    p.add_argument("--skip-wedge", action="store_true",
                   help="leave out datasets of wedge partitions (propped_lateral) instead of refusing")
    add_progress_argument(p)


def run_repress(args: argparse.Namespace) -> int:
    from pressurepose.data.repress import repress
    from pressurepose.files import check_output_path
    from pressurepose.sim.bed import load_bed

    src, out = Path(args.src), Path(args.out)
    check_output_path(out, "--out", directory=True)
    manifests = repress(src, out, load_bed(args.bed), progress=not args.no_progress, skip_wedge=args.skip_wedge)
    made = sum(m.samples_done for m in manifests)
    failed = sum(m.rejections.get("press_failed", 0) for m in manifests)
    print(f"re-pressed {made} samples of {len(manifests)} dataset(s) into {out}"
          + (f"; {failed} bodies the new bed could not balance were left out" if failed else ""))
    return 0
