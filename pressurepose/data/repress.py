"""Re-press a dataset's resting bodies on another bed: new images, the same rests.

Settling is most of what a sample costs (docs/throughput.md: 80-93 % of the CPU; the press 2-9 %).
A bed that differs from a dataset's own only in constants the settle does not use
(:data:`PRESS_ONLY`: the soft tissue, the sensor law and threshold) rests every drawn body exactly
as the dataset's bed did, so its images can be made again from the labels alone: the mesh at the
labelled pose (where the image was made) is pressed into the new bed with its tissue, and the
press's small rigid correction is folded into the root (:func:`pressurepose.sim.simulate.apply_rigid_motion`).
A randomised sample keeps its draws, re-based on the new bed (:meth:`~pressurepose.sim.randomize.Conditions.rebased`).
This is how a bed fitted by ``pressurepose calibrate`` (tissue, sensor) gets a training set in
minutes instead of hours.

How close it is to ``generate --bed``: that command presses the mesh where the settle left it;
this presses it where the first press left it, a fixed point of the press up to its first-order
tilt solve and float32 labels. Re-pressed on the dataset's own bed, images agree with the stored
ones to a correlation of at least 0.995 and joints to about 2 mm (``tests/data/test_repress.py``).
The bytes differ from ``generate --bed``'s, so the output records where it came from
(``provenance.repressed_from``) and ``generate`` will not resume into it.

Not re-pressable, with the reason given: datasets of other producers (their images are not
pressed), partitions with a wedge (the wedge's contact forces are not stored), and beds that
differ in a settle constant (the bodies would rest elsewhere: generate anew with ``--bed``).
A body the new bed cannot balance is left out and counted (``press_failed``) in its shard's record.

Resuming: shards are made in order and committed atomically, each with its checksum in the output
manifest; a rerun with the same source and bed skips the finished ones.
"""

from __future__ import annotations

import dataclasses
import json
import sys
from pathlib import Path

import numpy as np

from pressurepose.data.dataset import find_datasets
from pressurepose.data.pipeline import check_shards, producer_provenance
from pressurepose.data.schema import GenerationConfig, Sample
from pressurepose.data.store import (
    MANIFEST,
    Manifest,
    ShardRecord,
    commit,
    encode_shard,
    read_shard_arrays,
    samples_from_arrays,
    sha256_bytes,
    shard_name,
    stage_bytes,
    verify_shard,
)
from pressurepose.errors import BadInput
from pressurepose.sim.bed import BedSpec

# BedSpec fields the settle does not read: a bed differing from a dataset's only in these rests the
# same bodies in the same places.
PRESS_ONLY: tuple[str, ...] = ("tissue_modulus_pa", "tissue_bone_fraction", "sensor_c0", "sensor_c1",
                               "sensor_c2", "sensor_threshold_mmhg")


def check_press_only(old: BedSpec, new: BedSpec) -> None:
    """BadInput naming the constants in which ``new`` differs from ``old`` beyond :data:`PRESS_ONLY`."""
    differ = [f.name for f in dataclasses.fields(BedSpec)
              if f.name not in PRESS_ONLY and getattr(old, f.name) != getattr(new, f.name)]
    if differ:
        show = ", ".join(f"{n} {getattr(old, n)!r} -> {getattr(new, n)!r}" if n != "mat" else
                         f"mat {old.mat.name} -> {new.mat.name}" for n in differ)
        raise BadInput(f"the new bed differs from the dataset's in what the settle uses ({show}): the bodies "
                       f"would rest elsewhere, so re-pressing cannot stand in for settling. Only "
                       f"{', '.join(PRESS_ONLY)} may differ; make the data anew with generate --bed")


def repress_config(config: GenerationConfig, bed: BedSpec) -> GenerationConfig:
    """``config`` on ``bed`` (BadInput where re-pressing cannot make its data; module docstring)."""
    from pressurepose.pose.partitions import get_partition

    if config.producer != "physics":
        raise BadInput(f"a dataset of producer {config.producer!r} was not pressed; only physics datasets "
                       f"can be re-pressed")
    if get_partition(config.partition).wedge:
        raise BadInput(f"partition {config.partition} props bodies on a wedge whose contact forces the "
                       f"dataset does not store; make it anew with generate --bed")
    check_press_only(config.bed_spec(), bed)
    return dataclasses.replace(config, bed=bed.to_dict())  # the config keeps its canonical JSON


def repress_sample(body, sample: Sample, old: BedSpec, new: BedSpec) -> Sample | None:
    """``sample`` (made on ``old``) pressed again on ``new``; None if the new bed cannot balance it."""
    from pressurepose.sim.press import PressFailed
    from pressurepose.sim.randomize import Conditions
    from pressurepose.sim.simulate import apply_rigid_motion, press_at

    betas = np.asarray(sample.betas, dtype=np.float64)
    pose = np.asarray(sample.pose, dtype=np.float64)
    transl = np.asarray(sample.transl, dtype=np.float64)
    conditions, bed = None, new
    if sample.conditions is not None:
        conditions = Conditions(*(float(v) for v in sample.conditions)).rebased(old, new)
        bed = conditions.bed(new)
    try:
        image = press_at(body, betas, pose, transl, float(sample.mass), bed)
    except PressFailed:
        return None
    pose, transl = apply_rigid_motion(body, betas, pose, transl, image.transform)
    _, joints = body.forward(betas, pose, transl)
    return dataclasses.replace(sample, pressure=image.pressure, force=image.force, depth=image.depth,
                               contact=image.contact, pose=pose, transl=transl, joints=joints[0],
                               conditions=None if conditions is None else conditions.as_array(),
                               sites=image.label.astype(np.int8))


def _open_output(out: Path, config: GenerationConfig, provenance: dict) -> Manifest:
    out.mkdir(parents=True, exist_ok=True)
    if (out / MANIFEST).exists():
        manifest = Manifest.load(out)
        if manifest.config != config or manifest.provenance != provenance:
            raise BadInput(f"{out} holds another dataset than re-pressing {provenance['repressed_from']['path']} "
                           f"on this bed would make; nothing was changed. Use another --out, or the same "
                           f"source and bed to resume")
        return manifest
    if any(out.iterdir()):
        raise BadInput(f"{out} is not empty and holds no dataset; nothing was written (choose a new directory)")
    manifest = Manifest.new(config, provenance)
    manifest.save(out)
    return manifest


def repress_dataset(src: str | Path, out: str | Path, bed: BedSpec, *, progress=None) -> Manifest:
    """Re-press the one dataset in directory ``src`` on ``bed`` into ``out`` (resumable; see the
    module docstring). ``progress``: called with 1 after each sample re-pressed."""
    from pressurepose.data.physics import setup

    src, out = Path(src), Path(out)
    source = Manifest.load(src)
    if not source.complete:
        raise BadInput(f"dataset {src} is incomplete; finish it (rerun its generate command) before re-pressing")
    config = repress_config(source.config, bed)
    # the rests are the source's: its sampler and settle constants stay on record, the bed is the new one
    provenance = json.loads(json.dumps({
        **(source.provenance or producer_provenance(source.config)), "bed": bed.to_dict(),
        "repressed_from": {"path": str(src.resolve()), "config_digest": source.config.digest,
                           "shards": {shard_name(k): r.sha256 for k, r in sorted(source.shards.items())}}}))
    manifest = _open_output(out, config, provenance)
    body, _ = setup(config)
    old = source.config.bed_spec()
    for k in check_shards(out, manifest):
        record = source.shards.get(k)
        if record is None:
            raise BadInput(f"dataset {src} has no shard {k} in its manifest")
        problem = verify_shard(src, record)
        if problem:
            raise BadInput(problem)
        arrays = read_shard_arrays(src / record.file)
        samples, attempts, failed = [], [], 0
        for s, attempt in zip(samples_from_arrays(arrays), arrays["attempt"]):
            new = repress_sample(body, s, old, bed)
            if progress is not None:
                progress(1)
            if new is None:
                failed += 1
            else:
                samples.append(new)
                attempts.append(int(attempt))
        if not samples:
            raise BadInput(f"no body of {src / record.file} could be pressed on the new bed")
        rejections = dict(record.rejections)
        if failed:
            rejections["press_failed"] = rejections.get("press_failed", 0) + failed
        data = encode_shard(config, k, samples, attempts, rejections)
        tmp = stage_bytes(out / shard_name(k), data)
        manifest.shards[k] = ShardRecord(shard_name(k), sha256_bytes(data), len(samples), record.attempts, rejections)
        manifest.save(out)
        commit(tmp, out / shard_name(k))
    if len(manifest.shards) == config.num_shards and not manifest.complete:
        manifest.complete = True
        manifest.save(out)
    return manifest


def repress(src: str | Path, out: str | Path, bed: BedSpec, *, progress: bool = True,
            skip_wedge: bool = False) -> list[Manifest]:
    """Re-press every dataset under ``src`` (a dataset or a folder of them, e.g. a recipe's
    output) into the same layout under ``out``. Every dataset is checked before any is written;
    ``skip_wedge``: leave out the datasets of wedge partitions instead of refusing them (make those
    anew with ``generate --bed``)."""
    from tqdm import tqdm

    from pressurepose.pose.partitions import get_partition

    src, out = Path(src), Path(out)
    if out.resolve() == src.resolve() or src.resolve() in out.resolve().parents:
        raise BadInput(f"the output {out} lies inside the source {src}; choose a directory outside it")
    sources = {p: Manifest.load(p) for p in find_datasets(src)}
    if not sources:
        raise BadInput(f"{src} holds no pressurepose dataset")
    if skip_wedge:
        sources = {p: m for p, m in sources.items() if not get_partition(m.config.partition).wedge}
        if not sources:
            raise BadInput(f"every dataset under {src} is of a wedge partition; nothing to re-press")
    for p, m in sources.items():
        try:
            repress_config(m.config, bed)
        except BadInput as exc:
            raise BadInput(f"{p}: {exc}" + ("; --skip-wedge leaves such datasets out" if "wedge" in str(exc) else
                                            "")) from None
    parts = list(sources)
    done = sum(Manifest.load(out / p.relative_to(src)).samples_done for p in parts
               if (out / p.relative_to(src) / MANIFEST).exists())
    total = sum(m.samples_done for m in sources.values())
    with tqdm(total=total, initial=done, unit="sample", desc="re-press", disable=not progress,
              dynamic_ncols=True, file=sys.stderr) as bar:
        return [repress_dataset(p, out / p.relative_to(src), bed, progress=bar.update) for p in parts]
