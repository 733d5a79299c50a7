"""Make (or finish) a dataset: plan the work units of the shards still to make, run them on local
processes or Ray (:mod:`.executors`), and commit each finished shard (:mod:`.pipeline`)."""

from __future__ import annotations

import time
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from pressurepose.data.executors import check_executor, resolve_workers, run_units
from pressurepose.data.pipeline import (
    ShardAssembler,
    check_shards,
    commit_result,
    open_output,
    plan_units,
)
from pressurepose.data.producers import check_options, resolve_producer
from pressurepose.data.schema import GenerationConfig
from pressurepose.data.store import Manifest
from pressurepose.errors import BadInput
from pressurepose.files import check_output_path


@dataclass
class RunReport:
    out: Path
    manifest: Manifest
    made: int          # shards made by this run
    skipped: int       # shards already finished
    seconds: float
    retries: int
    unit_cpu_seconds: float  # CPU time spent making this run's shards, summed over workers
    workers: int = 1   # local worker processes used (1: this process; 0: the units ran on Ray)


def generate(config: GenerationConfig, out: str | Path, *, workers: int | str = 1, ray_address: str | None = None,
             retries: int = 2, progress: bool = True, repair: bool = False,
             only_shards: list[int] | None = None) -> RunReport:
    """Make (or finish) the dataset of ``config`` in ``out``; rerunning continues where it stopped.

    workers: local processes (1 = in this process), or ``"auto"``: one per core this process may use;
    either is capped at the samples still to make, and the dataset is the same for any number. From a
    script, more than one needs the script's work under ``if __name__ == "__main__":`` (each worker
    process imports the script first, as multiprocessing does). ray_address: run on Ray
    instead (``"local"`` starts a local instance); retries: extra tries for a failing unit before
    GenerationError; repair: set corrupt shards aside and remake them; only_shards: make just these
    shards (the rest may stay missing); progress: a progress bar on stderr (default True, as for every
    function that runs over a dataset). Returns a :class:`RunReport`.
    """
    from pressurepose.data.progress import ProgressBar

    t0 = time.perf_counter()
    if not isinstance(config, GenerationConfig):
        raise BadInput(f"config is {type(config).__name__}; expected a GenerationConfig")
    out = check_output_path(out, "out", directory=True)
    resolve_producer(config.producer)
    check_options(config)
    if config.poses and config.producer == "physics":
        from pressurepose.data.physics import check_poses

        check_poses(config)
    check_executor(workers, ray_address, retries)
    if only_shards is not None:  # before anything is written
        if isinstance(only_shards, (str, bytes, dict)) or not hasattr(only_shards, "__iter__"):
            raise BadInput(f"only_shards is {only_shards!r:.80}; expected a list of shard numbers")
        only_shards = list(only_shards)
        for k in only_shards:
            if isinstance(k, bool) or not isinstance(k, (int, np.integer)):
                raise BadInput(f"only_shards holds {k!r:.40}; expected shard numbers (whole numbers)")
        bad = [k for k in only_shards if not 0 <= k < config.num_shards]
        if bad:
            raise BadInput(f"shards {bad} do not exist; this dataset has shards 0..{config.num_shards - 1}")
    manifest = open_output(out, config)
    todo = check_shards(out, manifest, repair)
    if only_shards is not None:
        todo = [k for k in todo if k in set(only_shards)]
    skipped = config.num_shards - len(todo)
    unit_cpu = []
    bar = ProgressBar(total=config.count, initial=manifest.samples_done, enabled=progress,
                      desc=f"{config.partition}/{config.gender}{'/plo' if config.limbs_on_bed else ''}")
    assemble = ShardAssembler(lambda r: (commit_result(out, manifest, r), bar.unit_done(r),
                                         unit_cpu.append(r.cpu_seconds)))
    to_make = sum(len(config.shard_range(k)) for k in todo)
    used = 0 if ray_address else resolve_workers(workers, to_make)  # Ray: one unit per shard
    try:
        retried = run_units(plan_units(config, todo, used), workers=max(used, 1), ray_address=ray_address,
                            retries=retries, on_result=assemble, on_progress=bar.attempt,
                            on_failure=bar.unit_failed)
    finally:
        bar.close()
    if len(manifest.shards) == config.num_shards and not manifest.complete:
        manifest.complete = True
        manifest.save(out)
    return RunReport(out, manifest, len(todo), skipped, time.perf_counter() - t0, retried, sum(unit_cpu), used)
