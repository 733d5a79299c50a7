"""The physics producer: the data engine's real per-sample function (``physics`` in
:data:`pressurepose.data.producers.PRODUCERS`), wrapping :func:`pressurepose.sim.simulate.simulate_one`
(pose sampler -> settle -> press -> mat reading) into a :class:`~pressurepose.data.schema.Sample`."""

from __future__ import annotations

from functools import lru_cache

import numpy as np

from pressurepose.body import BodyModel
from pressurepose.data.producers import Rejected
from pressurepose.data.schema import GenerationConfig, Sample


@lru_cache(maxsize=8)
def _setup(gender: str, mat: str):
    """Body model and bed, built once per worker process for a (gender, mat) pair."""
    from pressurepose.sim.bed import get_bed

    return BodyModel(gender), get_bed(mat)


def physics_producer(config: GenerationConfig, rng: np.random.Generator) -> Sample | Rejected:
    """One attempt at a labelled sample with the full physics; all randomness from ``rng``."""
    from pressurepose.pose.config import SamplerConfig
    from pressurepose.sim.simulate import simulate_one

    body, bed = _setup(config.gender, config.mat)
    sampler = SamplerConfig(shapes=config.shapes, placement=config.placement, hanging_limbs=config.hanging_limbs,
                            across_sd_m=config.across_sd_m, across_sd_lateral_m=config.across_sd_lateral_m)
    conditions = None
    if config.randomize:
        from pressurepose.sim.randomize import draw_conditions

        conditions = draw_conditions(rng, bed)
    sim = simulate_one(body, bed, config.partition, config.gender, rng, config.limbs_on_bed, sampler, conditions)
    if isinstance(sim, str):
        return Rejected(sim)
    betas = np.zeros(10)
    betas[: len(sim.betas)] = sim.betas
    img = sim.image
    return Sample(pressure=img.pressure, force=img.force, depth=img.depth, contact=img.contact, betas=betas,
                  pose=sim.pose, transl=sim.transl, joints=sim.joints, gender=config.gender, mass=sim.mass,
                  height=sim.height, partition=config.partition,
                  conditions=None if conditions is None else conditions.as_array())
