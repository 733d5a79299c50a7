"""The physics producer: the data engine's real per-sample function (``physics`` in
:data:`pressurepose.data.producers.PRODUCERS`), wrapping :func:`pressurepose.sim.simulate.simulate_one`
(pose sampler -> settle -> press -> mat reading) into a :class:`~pressurepose.data.schema.Sample`."""

from __future__ import annotations

import dataclasses
import json
from functools import lru_cache

import numpy as np

from pressurepose.body import BodyModel
from pressurepose.data.schema import GenerationConfig, Sample
from pressurepose.sim.settle_config import settle_preset
from pressurepose.sim.simulate import Rejected


@lru_cache(maxsize=8)
def _body(gender: str) -> BodyModel:
    """The body model, built once per worker process for a gender."""
    return BodyModel(gender)


def setup(config: GenerationConfig):
    """(body model, bed) of a config, built once per worker process."""
    return _body(config.gender), config.bed_spec()


def sampler_config(config: GenerationConfig):
    """The pose sampler's :class:`~pressurepose.pose.config.SamplerConfig` for a dataset's config:
    its defaults with the settings the config holds."""
    from pressurepose.pose.config import SamplerConfig

    return SamplerConfig(shapes=config.shapes, placement=config.placement, hanging_limbs=config.hanging_limbs,
                         across_sd_m=config.across_sd_m, across_sd_lateral_m=config.across_sd_lateral_m,
                         height_reference=config.height_reference, poses=config.pose_file())


def check_poses(config: GenerationConfig) -> None:
    """BadInput now, not in a worker, if the config's pose file cannot serve its partition (missing or
    changed file, limb rules, postures it lacks: :func:`pressurepose.pose.sampler.pose_source`)."""
    if config.poses:
        from pressurepose.pose.partitions import get_partition
        from pressurepose.pose.sampler import pose_source

        pose_source(get_partition(config.partition), sampler_config(config))


def settle_config(config: GenerationConfig):
    """The settle's :class:`~pressurepose.sim.settle_config.SettleConfig` for a dataset's config."""
    return settle_preset(config.settle)


def provenance(config: GenerationConfig) -> dict:
    """Every setting of the physics a dataset is made with, as JSON-ready values: the sampler's
    (``sampler``), the settle's (``settle``), the bed's before randomisation (``bed``), for a
    randomised dataset the ranges drawn from (``randomize``), for bodies posed from real lying poses
    where their joint springs rest (``springs``: "drawn pose") and, for a partition with a wedge,
    the wedge's constants (``wedge``). The
    manifest keeps it, so it says which constants made the data (not only the config's options),
    and a resume under other constants is refused."""
    sampler = dataclasses.asdict(sampler_config(config))
    if sampler["poses"] is None:
        del sampler["poses"]  # recorded only when set, so datasets begun before it existed resume
    record = {"sampler": sampler,
              "settle": dataclasses.asdict(settle_config(config)), "bed": config.bed_spec().to_dict()}
    if config.randomize:
        from pressurepose.sim.randomize import RandomizationRanges

        record["randomize"] = dataclasses.asdict(RandomizationRanges())
    from pressurepose.pose.partitions import get_partition
    from pressurepose.pose.sampler import whole_pose

    part = get_partition(config.partition)
    if whole_pose(part, sampler_config(config)):
        record["springs"] = "drawn pose"  # the joint springs rest at the drawn pose (simulate_one)
    if part.wedge:
        from pressurepose.sim import wedge

        record["wedge"] = wedge.constants()
    return json.loads(json.dumps(record))  # tuples as lists: as it reads back


def physics_producer(config: GenerationConfig, rng: np.random.Generator) -> Sample | Rejected:
    """One attempt at a labelled sample with the full physics; all randomness from ``rng``."""
    from pressurepose.sim.simulate import simulate_one

    body, bed = setup(config)
    sampler = sampler_config(config)
    conditions = None
    if config.randomize:
        from pressurepose.sim.randomize import draw_conditions

        conditions = draw_conditions(rng, bed)
    sim = simulate_one(body, bed, config.partition, config.gender, rng, config.limbs_on_bed, sampler, conditions,
                       settle_config=settle_config(config))
    if isinstance(sim, Rejected):
        return sim
    betas = np.zeros(10)
    betas[: len(sim.betas)] = sim.betas
    img = sim.image
    return Sample(pressure=img.pressure, force=img.force, depth=img.depth, contact=img.contact, betas=betas,
                  pose=sim.pose, transl=sim.transl, joints=sim.joints, gender=config.gender, mass=sim.mass,
                  height=sim.height, partition=config.partition,
                  conditions=None if conditions is None else conditions.as_array(),
                  sites=None if img.label is None else img.label.astype(np.int8))
