"""The per-sample producer interface, the producer registry, and per-sample random streams.

A producer is a plain function

    producer(config: GenerationConfig, rng: numpy.random.Generator) -> Sample | Rejected

that makes ONE attempt at a labelled sample using only ``rng`` for randomness. It returns a
:class:`~pressurepose.data.schema.Sample` (its ``index`` is filled in by the pipeline) or
:class:`~pressurepose.sim.simulate.Rejected` with a short cause (``"self_collision"``,
``"unstable"``...). The pipeline calls it
for attempt 0, 1, 2, ... of sample ``i`` with :func:`attempt_rng` until one is accepted, so
rejections are as deterministic as the samples. Expensive set-up (body models, the bed model) belongs
in a cache inside the producer's module keyed by the (hashable, frozen) config.

Producers are named in :data:`PRODUCERS` (name -> ``"module:function"``); a config may also name
any importable ``"module:function"`` directly. Names resolve by import, so the same config works in
worker processes and on Ray nodes.
"""

from __future__ import annotations

import importlib
from typing import Callable, Protocol, Union

import numpy as np

from pressurepose.data.schema import GenerationConfig, Sample
from pressurepose.errors import BadInput
from pressurepose.sim.simulate import Rejected


class Producer(Protocol):
    def __call__(self, config: GenerationConfig, rng: np.random.Generator) -> Union[Sample, Rejected]:
        ...


# name -> "module:function". "physics" is the real data engine (sample, settle, press);
# "synthetic" is a cheap test/demo producer (no physics).
PRODUCERS: dict[str, str] = {
    "physics": "pressurepose.data.physics:physics_producer",
    "synthetic": "pressurepose.data.synthetic:synthetic_producer",
}


# the options each registered producer reads: name -> (low, high) of a number. A producer named by
# "module:function" declares none and gets its options unchecked.
PRODUCER_OPTIONS: dict[str, dict[str, tuple[float, float]]] = {
    "physics": {},
    "synthetic": {"reject_rate": (0.0, 1.0), "cost_ms": (0.0, 60_000.0), "sleep_ms": (0.0, 60_000.0)},
}


def check_options(config: GenerationConfig) -> None:
    """BadInput for an option the config's (registered) producer does not read, or a value out of its range."""
    known = PRODUCER_OPTIONS.get(config.producer)
    if known is None:
        return
    for key, value in config.options:
        if key not in known:
            raise BadInput(f"--option {key}: producer {config.producer!r} has no such option; "
                           f"it takes {', '.join(known) or 'none'}")
        low, high = known[key]
        if isinstance(value, bool) or not isinstance(value, (int, float)) or not low <= value <= high:
            raise BadInput(f"--option {key}={value}: expected a number from {low:g} to {high:g}")


def resolve_producer(name: str) -> Callable[[GenerationConfig, np.random.Generator], Union[Sample, Rejected]]:
    """The producer function for a registry name or a ``"module:function"`` path."""
    target = PRODUCERS.get(name, name)
    if ":" not in target:
        raise BadInput(f"producer {name!r} is not known; expected one of {', '.join(PRODUCERS)} "
                       f"or an importable 'module:function'")
    module, _, func = target.partition(":")
    try:
        fn = getattr(importlib.import_module(module), func)
    except (ImportError, AttributeError) as exc:
        raise BadInput(f"producer {name!r}: cannot import {target} ({exc})") from None
    if not callable(fn):
        raise BadInput(f"producer {name!r}: {target} is not callable")
    return fn


def attempt_rng(config: GenerationConfig, index: int, attempt: int) -> np.random.Generator:
    """The random generator of attempt ``attempt`` at sample ``index``: a pure function of
    (seed, partition, gender, limbs_on_bed, index, attempt)."""
    return np.random.default_rng(np.random.SeedSequence([config.seed, config.stream_key, index, attempt]))
