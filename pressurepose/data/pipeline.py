"""Dataset generation: plan work units, skip finished shards, run the rest, commit them atomically.

A work unit is (config, shard, sample range): some or all of the samples ``config.shard_range(shard)``.
Sample ``i`` is made by calling the config's producer with
:func:`~pressurepose.data.producers.attempt_rng` for attempts 0, 1, 2, ... until it returns a Sample;
so a unit's result depends only on (config, its sample range) and any shard can be regenerated
anywhere, in any order, by any number of workers.

With one worker a unit is a whole shard. With several, a shard is split into parts small enough
that every worker has work (:func:`plan_units`: about four units per worker), so ``--workers 2`` on
a single 64-sample shard keeps both cores busy. Workers return their samples; the coordinating
process puts a shard's parts together in index order (the same bytes whatever the split), encodes
it and commits it. Only the coordinator touches the output directory, so the same code runs on local
processes and on Ray nodes without a shared file system. A run killed mid-shard loses that shard's
finished parts (the shard is the unit of resuming), never a committed shard.
"""

from __future__ import annotations

import dataclasses
import os
import time
import traceback
from dataclasses import dataclass
from pathlib import Path
from typing import Callable

from pressurepose import __version__
from pressurepose.data.producers import attempt_rng, resolve_producer
from pressurepose.data.schema import GenerationConfig, Sample
from pressurepose.data.store import (
    MANIFEST,
    Manifest,
    ShardRecord,
    commit,
    encode_shard,
    is_set_aside_name,
    is_temp_name,
    set_aside_path,
    sha256_bytes,
    shard_name,
    stage_bytes,
    verify_shard,
)
from pressurepose.errors import BadInput, record_difference
from pressurepose.sim.simulate import Rejected


class GenerationError(RuntimeError):
    """A work unit kept failing after its retries (the message names the unit and the cause)."""


class AttemptsExhausted(GenerationError):
    """A sample index was rejected ``max_attempts`` times in a row (deterministic: not retried)."""


@dataclass(frozen=True)
class WorkUnit:
    """Samples ``start`` .. ``stop - 1`` of shard ``shard`` (default: the whole shard)."""

    config: GenerationConfig
    shard: int
    start: int | None = None
    stop: int | None = None

    @property
    def indices(self) -> range:
        whole = self.config.shard_range(self.shard)
        return range(whole.start if self.start is None else self.start,
                     whole.stop if self.stop is None else self.stop)

    def __str__(self) -> str:
        return f"shard {self.shard} (samples {self.indices.start}..{self.indices.stop - 1})"


@dataclass(frozen=True, eq=False)
class PartResult:
    """What a worker returns for one unit: its samples in index order, the accepted attempt number of
    each, rejections by cause, and the wall and CPU seconds of the process that made them."""

    unit: WorkUnit
    samples: list
    attempts: list
    rejections: dict
    seconds: float
    cpu_seconds: float


@dataclass(frozen=True)
class UnitResult:
    """A finished shard: its encoded bytes and statistics (CPU summed over its parts)."""

    shard: int
    data: bytes
    count: int
    attempts: int
    rejections: dict
    seconds: float
    cpu_seconds: float  # CPU time of the processes that made its samples


# progress callback: (shard, accepted, rejected) increments, called after every attempt
Progress = Callable[[int, int, int], None]


UNITS_PER_WORKER = 4


def plan_units(config: GenerationConfig, shards: list[int] | None = None, workers: int = 1) -> list[WorkUnit]:
    """The work units that make ``shards`` (default all), in index order. One worker: one unit per
    shard. More: shards are split into parts of near-equal size, about ``UNITS_PER_WORKER`` units
    per worker over all the shards, so that no worker idles while another makes a whole shard."""
    shards = list(range(config.num_shards)) if shards is None else list(shards)
    if workers <= 1 or not shards:
        return [WorkUnit(config, k) for k in shards]
    total = sum(len(config.shard_range(k)) for k in shards)
    part = max(1, -(-total // (UNITS_PER_WORKER * workers)))
    units = []
    for k in shards:
        r = config.shard_range(k)
        n = -(-len(r) // part)
        edges = [r.start + (len(r) * i) // n for i in range(n + 1)]
        units += [WorkUnit(config, k, a, b) for a, b in zip(edges, edges[1:])]
    return units


def make_sample(config: GenerationConfig, index: int, producer=None,
                progress: Progress | None = None, shard: int = -1) -> tuple[Sample, int, dict[str, int]]:
    """Sample ``index`` of a dataset: (sample, accepted attempt number, rejections by cause)."""
    producer = producer or resolve_producer(config.producer)
    shape = config.grid.shape
    rejections: dict[str, int] = {}
    for attempt in range(config.max_attempts):
        out = producer(config, attempt_rng(config, index, attempt))
        if isinstance(out, Rejected):
            rejections[out.cause] = rejections.get(out.cause, 0) + 1
            if progress:
                progress(shard, 0, 1)
            continue
        if not isinstance(out, Sample):
            raise GenerationError(f"producer {config.producer!r} returned {type(out).__name__}; "
                                  f"expected Sample or Rejected")
        if out.gender != config.gender or out.partition != config.partition:
            raise GenerationError(f"producer {config.producer!r} returned a {out.gender}/{out.partition} "
                                  f"sample for a {config.gender}/{config.partition} config")
        sample = dataclasses.replace(out, index=index).validate(shape, what=f"sample {index}")
        if progress:
            progress(shard, 1, 0)
        return sample, attempt, rejections
    raise AttemptsExhausted(f"sample {index} was rejected {config.max_attempts} times in a row "
                            f"({rejections}); raise max_attempts or fix the producer")


def run_unit(unit: WorkUnit, progress: Progress | None = None) -> PartResult:
    """Produce one unit's samples (pure: touches no files)."""
    t0, cpu0 = time.perf_counter(), time.process_time()
    producer = resolve_producer(unit.config.producer)
    samples, attempts, rejections = [], [], {}
    for i in unit.indices:
        s, a, rej = make_sample(unit.config, i, producer, progress, unit.shard)
        samples.append(s)
        attempts.append(a)
        for cause, n in rej.items():
            rejections[cause] = rejections.get(cause, 0) + n
    return PartResult(unit, samples, attempts, rejections, time.perf_counter() - t0, time.process_time() - cpu0)


class ShardAssembler:
    """Collects the parts of each shard; when a shard's last part arrives, encodes the shard (parts in
    index order, so the bytes do not depend on how the shard was split or which part came first)
    and hands its :class:`UnitResult` to ``on_shard``."""

    def __init__(self, on_shard: Callable[[UnitResult], None]):
        self.on_shard = on_shard
        self.parts: dict[int, list[PartResult]] = {}

    def __call__(self, part: PartResult) -> None:
        unit = part.unit
        parts = self.parts.setdefault(unit.shard, [])
        parts.append(part)
        whole = unit.config.shard_range(unit.shard)
        if sum(len(p.unit.indices) for p in parts) < len(whole):
            return
        del self.parts[unit.shard]
        parts.sort(key=lambda p: p.unit.indices.start)
        samples = [s for p in parts for s in p.samples]
        if [s.index for s in samples] != list(whole):
            raise GenerationError(f"shard {unit.shard}: parts cover samples {[s.index for s in samples]}, "
                                  f"expected {whole.start}..{whole.stop - 1}")
        attempts = [a for p in parts for a in p.attempts]
        rejections: dict[str, int] = {}
        for p in parts:
            for cause, n in p.rejections.items():
                rejections[cause] = rejections.get(cause, 0) + n
        data = encode_shard(unit.config, unit.shard, samples, attempts, rejections)
        self.on_shard(UnitResult(unit.shard, data, len(samples), len(samples) + sum(rejections.values()),
                                 rejections, sum(p.seconds for p in parts), sum(p.cpu_seconds for p in parts)))


# --------------------------------------------------------------------------- resuming


def _config_difference(a: GenerationConfig, b: GenerationConfig) -> str:
    da, db = a.to_dict(), b.to_dict()

    def show(config, d, k):
        if k == "bed":
            return "a given bed" if k in d else "the mat's default bed"
        if k == "poses" and k not in d:
            return "no pose file"
        return repr(d[k] if k in d else getattr(config, k))  # a setting the record leaves out: its default

    return ", ".join(f"{k}: {show(a, da, k)} on disk vs {show(b, db, k)} now" for k in dict.fromkeys([*da, *db])
                     if da.get(k) != db.get(k))


def open_output(out: Path, config: GenerationConfig) -> Manifest:
    """Load or create the manifest of ``out`` for ``config``. Refuses (BadInput) a directory that
    holds another config's dataset, another package version's, or files that are not a dataset's."""
    out.mkdir(parents=True, exist_ok=True)
    if (out / MANIFEST).exists():
        manifest = Manifest.load(out)
        if manifest.config != config:
            raise BadInput(f"{out} holds a dataset made with a different config "
                           f"({_config_difference(manifest.config, config)}); nothing was changed. "
                           f"Use another --out, or the same options to resume")
        if manifest.package_version != __version__:
            raise BadInput(f"{out} was made by pressurepose {manifest.package_version}, this is "
                           f"{__version__}; shards from two versions may differ, so nothing was changed. "
                           f"Use another --out")
        now = producer_provenance(config)
        if manifest.provenance and now and manifest.provenance != now:
            raise BadInput(f"{out} was begun with other physics or sampler constants "
                           f"({record_difference(manifest.provenance, now)}); its shards and new ones "
                           f"would differ, so nothing was changed. Use another --out")
        return manifest
    strays = sorted(p.name for p in out.glob("shard-*.h5"))
    if strays:
        raise BadInput(f"{out} has shard files ({', '.join(strays[:3])}...) but no {MANIFEST}; "
                       f"refusing to mix datasets. Use an empty --out")
    others = sorted(p.name for p in out.iterdir() if not (is_temp_name(p.name) or is_set_aside_name(p.name)))
    if others:
        raise BadInput(f"{out} is not empty and holds no dataset ({', '.join(others[:3])}"
                       f"{', ...' if len(others) > 3 else ''}); a dataset is written into a folder of its own. "
                       f"Use an empty or new --out")
    manifest = Manifest.new(config, producer_provenance(config))
    manifest.save(out)
    return manifest


def producer_provenance(config: GenerationConfig) -> dict:
    """The constants of the built-in physics producer (``pressurepose.data.physics.provenance``);
    {} for other producers."""
    if config.producer != "physics":
        return {}
    from pressurepose.data.physics import provenance

    return provenance(config)


def check_shards(out: Path, manifest: Manifest, repair: bool = False) -> list[int]:
    """Shards still to make. Finished shards are verified by checksum; a corrupt one raises BadInput
    naming it (with ``repair``, it is renamed ``*.corrupt-<time>`` and made again)."""
    for p in out.iterdir():
        if is_temp_name(p.name):
            p.unlink(missing_ok=True)  # a partial write from an interrupted run
    todo, corrupt = [], []
    for k in range(manifest.config.num_shards):
        record = manifest.shards.get(k)
        path = out / shard_name(k)
        if record is None:
            if path.exists():
                corrupt.append(f"{path} is not recorded in the manifest")
            todo.append(k)
        elif not path.exists():
            todo.append(k)  # recorded, then interrupted before the rename: make it again
        else:
            problem = verify_shard(out, record)
            if problem:
                corrupt.append(problem)
                todo.append(k)
    if corrupt and not repair:
        raise BadInput("; ".join(corrupt) + ". Nothing was overwritten: rerun with --repair to set "
                       "bad shards aside (renamed *.corrupt-<time>) and make them again")
    if corrupt:
        stamp = time.strftime("%Y%m%d-%H%M%S")
        for k in todo:
            path = out / shard_name(k)
            if path.exists():
                os.replace(path, set_aside_path(path, stamp))
                manifest.shards.pop(k, None)
    return todo


def commit_result(out: Path, manifest: Manifest, result: UnitResult) -> None:
    name = shard_name(result.shard)
    digest = sha256_bytes(result.data)
    previous = manifest.shards.get(result.shard)
    if previous is not None and previous.sha256 != digest:
        raise GenerationError(f"{name} came out different from the first time it was made (sha256 "
                              f"{digest[:16]}... vs {previous.sha256[:16]}...): the producer is not "
                              f"deterministic. Nothing was overwritten")
    tmp = stage_bytes(out / name, result.data)
    manifest.shards[result.shard] = ShardRecord(name, digest, result.count, result.attempts, result.rejections)
    try:
        manifest.save(out)
    except BaseException:
        tmp.unlink(missing_ok=True)
        raise
    commit(tmp, out / name)


def format_failure(unit: WorkUnit, exc: BaseException) -> str:
    """One line naming the unit and the error, plus the worker's traceback tail when there is one."""
    tb = "".join(traceback.format_exception(type(exc), exc, exc.__traceback__)).strip().splitlines()
    return f"{unit}: {type(exc).__name__}: {exc}\n    " + "\n    ".join(tb[-6:])
