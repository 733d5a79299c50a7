"""Producers and configs for the data tests (importable by worker processes as tests.data.helpers)."""

import os
from pathlib import Path

from pressurepose.data.schema import GenerationConfig
from pressurepose.data.synthetic import synthetic_producer


def small_config(**kw) -> GenerationConfig:
    base = dict(partition="general", gender="f", count=20, shard_size=6, seed=7, producer="synthetic")
    base.update(kw)
    return GenerationConfig(**base)


def first_claim(config, name: str) -> bool:
    """Whether this call is the first across all processes to claim ``name``: it creates the marker
    file ``name`` in the config's ``marker_dir`` option, and only one creator can succeed."""
    try:
        fd = os.open(Path(config.option("marker_dir")) / name, os.O_CREAT | os.O_EXCL | os.O_WRONLY)
    except FileExistsError:
        return False
    os.close(fd)
    return True


def flaky_producer(config, rng):
    """Raises on the very first call across all processes (claimed by creating a marker file), then
    behaves like the synthetic producer: exactly one work unit fails once."""
    if not first_claim(config, "failed_once"):
        return synthetic_producer(config, rng)
    raise RuntimeError("injected worker failure")


def broken_producer(config, rng):
    raise RuntimeError("this producer always fails")


def crashing_producer(config, rng):
    """Kills its worker process outright on the first call (marker file), like a segfault would."""
    if not first_claim(config, "crashed_once"):
        return synthetic_producer(config, rng)
    os._exit(1)


def pid_recording_producer(config, rng):
    """The synthetic producer, leaving a file named after the process that made each attempt."""
    (Path(config.option("marker_dir")) / f"pid-{os.getpid()}").touch()
    return synthetic_producer(config, rng)
