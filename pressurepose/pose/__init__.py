"""Initial bodies for the data engine: joint limits, posture partitions, the rejection sampler.

>>> from pressurepose.pose import sample_bodies
>>> batch = sample_bodies("general", "f", count=100, seed=0)   # betas, pose, transl, joints (bed frame)
"""

from pressurepose.pose.config import SamplerConfig, mattress_outline
from pressurepose.pose.limits import JointLimits, joint_limits
from pressurepose.pose.partitions import PARTITIONS, Partition, get_partition
from pressurepose.pose.posefile import PoseFile, PoseSet, read_poses
from pressurepose.pose.samples import (
    CAUSES,
    COUNTERS,
    BodySample,
    SampleBatch,
    load_samples,
)

_SAMPLER = ("body_rng", "sample_bodies", "sample_one")


def __getattr__(name: str):
    # the sampler's collision checks need MuJoCo; joint limits and partitions (which training reads) do not,
    # so a machine that only trains (no simulator installed) can import this package
    if name in _SAMPLER:
        from pressurepose.pose import sampler

        return getattr(sampler, name)
    raise AttributeError(f"module {__name__!r} has no attribute {name!r}")

__all__ = ["JointLimits", "joint_limits", "PARTITIONS", "Partition", "get_partition", "SamplerConfig",
           "body_rng", "mattress_outline", "sample_bodies", "sample_one", "CAUSES", "COUNTERS",
           "BodySample", "SampleBatch", "load_samples", "PoseFile", "PoseSet", "read_poses"]
