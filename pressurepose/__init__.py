"""pressurepose: 3D body pose and shape from bed pressure images (Bodies at Rest, open).

Subpackages: ``body`` (body model, body sites), ``pose`` (sampler), ``sim`` (physics), ``data``
(datasets, real-mat readers), ``net`` (PressureNet: training, ``estimate``), ``eval`` (metrics,
real-image scoring, monitoring a night), ``calibrate`` (fitting the bed and sensor), ``viz``
(pictures), ``cli`` (the ``pressurepose`` command); below them ``mat`` (the mat's geometry),
``files`` (atomic files) and ``errors`` (:class:`BadInput`, raised for bad input).

The main entry points are also here, loaded on first use so that ``import pressurepose`` stays
fast (no PyTorch or MuJoCo until one is called)::

    import pressurepose as pp

    est = pp.estimate("images.npy", "f")                       # the shipped PressureNet
    night = pp.monitor(raw, pp.frame_times(len(raw), fps=1), "m", mat="fsa_softflex_2048",
                       units="raw", weight_kg=87)
    pp.generate(pp.GenerationConfig(partition="general", gender="f", count=100, seed=1), "data/gen")
    result = pp.train(pp.load_dataset("data/gen"), "runs/net", pp.TrainConfig(epochs_mod1=2, epochs_mod2=1))

Their defaults are the command line's: ``TrainConfig()`` holds the ``train`` verb's options, and the
functions that run over a dataset, a recording or a training run (``generate``, ``train``,
``evaluate``, ``evaluate_real``, ``monitor``) show a progress bar on stderr unless given
``progress=False``; ``estimate``, called per image or per frame in loops, shows one only with
``progress=True``.
"""

from __future__ import annotations

import importlib

from pressurepose.errors import BadInput

__version__ = "0.1.0"

# name -> the module that defines it (imported when the name is first used)
_ENTRY_POINTS = {
    "sample_bodies": "pressurepose.pose.sampler",
    "simulate_one": "pressurepose.sim.simulate",
    "GenerationConfig": "pressurepose.data.schema",
    "generate": "pressurepose.data.generate",
    "read_recording": "pressurepose.data.readers.recording",
    "read_real": "pressurepose.data.readers.real",
    "load_dataset": "pressurepose.net.data",
    "TrainConfig": "pressurepose.net.train_config",
    "train": "pressurepose.net.train",
    "load_model": "pressurepose.net.checkpoint",
    "estimate": "pressurepose.net.infer",
    "evaluate": "pressurepose.eval.report",
    "evaluate_real": "pressurepose.eval.real",
    "frame_times": "pressurepose.eval.monitor",
    "monitor": "pressurepose.eval.monitor",
}

__all__ = ["BadInput", "__version__", *_ENTRY_POINTS]


def __getattr__(name: str):
    module = _ENTRY_POINTS.get(name)
    if module is None:
        raise AttributeError(f"module 'pressurepose' has no attribute {name!r}")
    value = getattr(importlib.import_module(module), name)
    globals()[name] = value  # later uses skip this function
    return value


def __dir__() -> list[str]:
    return sorted({*globals(), *_ENTRY_POINTS})
