"""Initial bodies for the data engine: joint limits, posture partitions, the rejection sampler.

>>> from pressurepose.pose import sample_bodies
>>> batch = sample_bodies("general", "f", count=100, seed=0)   # betas, pose, transl, joints (bed frame)
"""

from pressurepose.pose.config import SamplerConfig, mattress_outline
from pressurepose.pose.limits import JointLimits, joint_limits
from pressurepose.pose.partitions import PARTITIONS, Partition, get_partition
from pressurepose.pose.sampler import body_rng, sample_bodies, sample_one
from pressurepose.pose.samples import CAUSES, COUNTERS, BodySample, SampleBatch, load_samples

__all__ = ["JointLimits", "joint_limits", "PARTITIONS", "Partition", "get_partition", "SamplerConfig",
           "body_rng", "mattress_outline", "sample_bodies", "sample_one", "CAUSES", "COUNTERS",
           "BodySample", "SampleBatch", "load_samples"]
