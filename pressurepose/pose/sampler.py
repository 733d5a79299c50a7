"""Rejection sampler of initial bodies on the bed (paper section 3 and appendix A.1).

For each body: betas ~ U(-3, 3)^10; the root's roll from the partition, yaw ~ U(-pi/6, pi/6), pitch
0 (see :mod:`pressurepose.pose.root`); the pelvis over the mattress centre shifted by U(-0.2, 0.2) m
across and along the bed; one Cartesian bin per limb drawn uniformly from the partition's bins.
Then each limb (left leg, right leg, left arm, right arm) redraws its joint angles uniformly within
the joint limits until its candidate passes, in this order (the first failure names the cause):

``height``        the distal joint (ankle, wrist) is within +-0.2 m of the proximal joint's height
                  (hip, shoulder; hands-behind-head: 0-0.4 m below the shoulder); with
                  ``SamplerConfig(height_reference="bed")``, within ``bed_height_band`` (-0.1 to
                  0.3 m) of the surface the body lies on instead (see below);
``bin``           the distal joint lies in the limb's bin (:mod:`pressurepose.pose.partitions`),
                  counted along the bed's long axis (the posed, yawed body, as the public code
                  measured it: the paper's bins are cuboids of the bed's Cartesian space);
``off_mattress``  with ``limbs_on_bed``, the limb's elbow, wrist, hand / knee, ankle, foot joints lie
                  inside the mattress outline;
``not_behind_head`` hands-behind-head only: the wrist is medial to its shoulder and within
                  ``Partition.wrist_to_head`` of the head joint;
``limb_collision`` the limb's checked capsules penetrate the trunk, neck, head or the limb's own
                  non-adjacent capsules (the self-collision pairs a limb decides alone, tested here
                  so that a colliding limb does not cost a redraw of the others).

Bins are redrawn in three cases: with ``limbs_on_bed``, after ``off_bed_patience`` candidates in
the bin fell off the mattress (as the public code did); after ``bin_patience`` candidates of any
cause, an escape for bins the body's shape and root cannot reach (prone, an ankle within half a leg
length of the hip takes a knee bent up out of the height band or a thigh pressed into the bed),
while bins that are merely rare (the supine ankle near the hip, about 1 candidate in 800) are
almost always found first; and for crossed legs (below). A limb that redraws its bin more than
``max_bin_redraws`` times in a row gives up, and the body redraws its shape, root and shift.

The legs are drawn first; for the crossed-legs partition both are redrawn until the left ankle lies
toward the body's right of the right ankle (``legs_not_crossed``; the leg bins are redrawn after
``cross_patience`` failures), before the arms, which take no part in it. Then the whole pose is
checked for ``self_collision`` (:mod:`pressurepose.pose.collision`: every checked pair again, by
MuJoCo); a colliding body redraws all four limbs with the same bins, and after
``collision_patience`` collisions also its shape, root and shift. Bins are kept through these
retries, so (but for the redraws above) the accepted bodies' distal joints are spread evenly over
the bins.

Where that test exempts a capsule (the hands behind the head, which rest against it), a pose it
passes also takes the settle's start test on the pairs it left out
(:func:`pressurepose.body.contact.start_overlap`: the ragdoll's contact geoms, their own radii, 2 mm),
and one that fails starts its body afresh (shape, root, shift and bins, counted as a
``self_collision``): the new attempt the settle's rejection would cause, so the accepted poses
follow the law they follow when the settle rejects the failing ones (docs/physics.md), and the
settle rejects none of them. Elsewhere the test checks every pair the settle does, on wider and longer capsules,
and the start test is not run.

Bed-referenced heights (an option, off by default). The paper keeps each distal joint near its
proximal joint's height because lying limbs "are more likely to end up close to the surface of the
bed". That holds for a supine or prone body, whose hips and shoulders lie 0.1-0.2 m above the bed,
but on its side the upper hip and shoulder are 0.3-0.45 m up, so the rule starts the upper arm and
leg in the air (the ankle or wrist up to 0.6 m above the bed); they sink on their soft joints
while the trunk rests on its narrow side, and the body rolls over. ``height_reference="bed"`` applies the band to the height above the bed instead.
Measured on ``general`` (seed 13, 200 bodies per gender, settled by :mod:`pressurepose.sim.settle`),
proximal -> bed: lateral starts that settled on their side 46 -> 61 of 106 (female), 38 -> 52 (male);
supine and prone starts alike (87 -> 87 female, 85 -> 86 male); settle CPU per accepted body 0.41 -> 0.26 s
(female), 0.62 -> 0.44 s (male). It changes which limb poses every partition draws.

Finally the body is lowered so that its lowest capsule surface is ``clearance`` above the mattress:
the capsules are what the ragdoll drops. The mesh, which this stage does not skin (4 ms a body), can
reach up to ~3 cm lower than the capsules (measured over 180 bodies: its lowest vertex from -1.2 to
+11 cm with the capsules at +1.5 cm).

Fidelity to the public sampler (``benchmarks/bench_sampler_fidelity.py`` against its own 2700
supine female poses, 22 sampled DOFs). Bins count along the bed, not along the body: counted along
the body, yaw up to 30 deg moves ankles between bins (hip twist W1 ~5 deg, knee flexion ~6; 2-3.5
along the bed). Like the public code, no test keeps a limb's capsules above the surface the body
lies on (docs/not-adopted.md: such a test raised the supine legs).

The rest is the body model, not the procedure. SMPL's rest ankle (neutral, betas 0) lies ~5 cm
behind the hip and 2 cm lateral of it; ours lies level with the hip and 6.4 cm lateral, so the
same tests admit other knee angles and hip twists (with SMPL's ankle offsets in the limb tests,
knee flexion and hip twist come to W1 ~1 deg). The public code's collision capsules (SMPLify's,
not available here) rejected more arms across the chest than ours do (14% of its wrists lie over
the chest, 21% of ours with our capsules' own radii); the self-collision tests therefore widen every
capsule 1.2x (``SamplerConfig.collision_radius_scale``): 19% of wrists over the chest, largest W1,
shoulder swing, 7.1 -> 4.6 deg, mean 2.43 -> 2.24 (the paper's settings).

Whole poses: the natural partitions (``Partition.natural``) and a pose file
(``SamplerConfig.poses``) draw every body pose at once instead of limb by limb, under the joint
limits, collision and mattress rules of :mod:`pressurepose.pose.whole` (:func:`pose_source`).

Randomness: body ``i`` of ``sample_bodies(..., seed)`` uses only its own generator
:func:`body_rng` ``(seed, i)``, so it does not depend on how many bodies are drawn with it, and
``sample_one(..., rng=body_rng(seed, i))`` returns the same body.
"""

from __future__ import annotations

import itertools
from functools import lru_cache

import numpy as np

from pressurepose.errors import BadInput, require_bool, require_whole
from pressurepose.pose.config import SamplerConfig
from pressurepose.pose.partitions import ARM_BINS, LEG_BINS, PARTITIONS, Partition, get_partition
from pressurepose.pose.posefile import PoseFile
from pressurepose.pose.rejection import Run
from pressurepose.pose.samples import BodySample, SampleBatch
from pressurepose.pose.whole import FileSource, MixtureSource, WholePoseRun, check_source

GENDER_NAMES = {"f": "female", "m": "male"}
BLOCK = 256  # bodies drawn together (vectorised); results do not depend on it


def body_rng(seed: int, index: int) -> np.random.Generator:
    """The generator of body ``index`` of a run with ``seed`` (both whole numbers >= 0)."""
    return np.random.default_rng(np.random.SeedSequence([seed, index]))


def check_gender(gender) -> str:
    """'f' / 'female' -> 'f', 'm' / 'male' -> 'm'; BadInput naming the valid genders otherwise."""
    g = {"f": "f", "female": "f", "m": "m", "male": "m"}.get(str(gender).strip().lower())
    if g is None:
        raise BadInput(f"gender {gender!r} is not known; expected f or m (female, male)")
    return g


def _whole(name: str, v, low: int) -> int:
    """``v`` as an int; BadInput unless it is a whole number >= ``low``."""
    require_whole(name, v, low)
    return int(v)


def sample_bodies(partition, gender, count: int, seed: int, limbs_on_bed: bool = False, body=None,
                  config: SamplerConfig = SamplerConfig(), start: int = 0) -> SampleBatch:
    """``count`` bodies of a partition (name or alias, see :mod:`pressurepose.pose.partitions`) and
    gender ('f' | 'm'); body ``k`` uses :func:`body_rng` ``(seed, start + k)``.

    body: the :class:`~pressurepose.body.BodyModel` to use (default: the shipped model of the gender).
    Same arguments -> same samples.
    """
    part = get_partition(partition)
    g = check_gender(gender)
    count = _whole("count", count, 1)
    seed = _whole("seed", seed, 0)
    start = _whole("start", start, 0)
    rngs = (body_rng(seed, start + k) for k in range(count))
    return _draw(part, g, rngs, limbs_on_bed, body, config, seed)


def sample_one(partition, gender, rng: np.random.Generator, limbs_on_bed: bool = False, body=None,
               config: SamplerConfig = SamplerConfig()) -> BodySample:
    """One body drawn with ``rng`` (e.g. the data engine's per-attempt generator); see
    :func:`sample_bodies`."""
    if not isinstance(rng, np.random.Generator):
        raise BadInput(f"rng is {type(rng).__name__}; expected a numpy.random.Generator")
    return _draw(get_partition(partition), check_gender(gender), [rng], limbs_on_bed, body, config, None)[0]


def whole_pose(part: Partition, config: SamplerConfig) -> bool:
    """Whether the partition's bodies take their whole pose from real lying poses (a natural
    partition's model of them, or the config's pose file) rather than from the limb sampler."""
    return config.poses is not None or part.natural


def pose_source(part: Partition, config: SamplerConfig):
    """Where a body's whole pose comes from (:mod:`pressurepose.pose.whole`): the config's pose file,
    the natural pose model for a natural partition, else None (the limb sampler). BadInput for a pose
    file with a partition that sets limb rules, or a source without the partition's postures."""
    if config.poses is not None:
        if not _rolls_only(part):
            allowed = ", ".join(n for n, p in PARTITIONS.items() if _rolls_only(p))
            raise BadInput(f"a pose file gives the limbs, so partition {part.name}'s limb rules cannot hold; "
                           f"use one that sets only the roll ({allowed})")
        source = _file_source(config.poses)
        check_source(source, part, f"pose file {config.poses.path!r}")
        return source
    if part.natural:
        from pressurepose.pose.natural import natural_poses

        source = MixtureSource(natural_poses())
        check_source(source, part, "the natural pose model")
        return source
    return None


def _rolls_only(p: Partition) -> bool:
    return (p.leg_bins == tuple(range(LEG_BINS)) and p.arm_bins == tuple(range(ARM_BINS)) and not p.straight_limbs
            and not p.hands_behind_head and not p.crossed_legs and not p.arm_height_band)


@lru_cache(maxsize=4)
def _file_source(poses: PoseFile) -> FileSource:
    return FileSource(poses.poses(), poses.noise_deg)


def _draw(part: Partition, gender: str, rngs, limbs_on_bed: bool, body, config: SamplerConfig,
          seed: int | None) -> SampleBatch:
    """Draw one body per generator (an iterable), BLOCK bodies at a time (no body depends on the others)."""
    from pressurepose.body import BodyModel

    if not isinstance(config, SamplerConfig):
        raise BadInput(f"config is {type(config).__name__}; expected a SamplerConfig")
    limbs_on_bed = require_bool("limbs_on_bed", limbs_on_bed)
    if body is None:
        body = BodyModel(GENDER_NAMES[gender])
    elif not isinstance(body, BodyModel):
        raise BadInput(f"body is {type(body).__name__}; expected a BodyModel (BodyModel('female'), ...), or None for "
                       f"the shipped body of the gender")
    source = pose_source(part, config)
    parts = []
    rngs = iter(rngs)
    while block := list(itertools.islice(rngs, BLOCK)):
        run = (Run(part, body, config, limbs_on_bed, block) if source is None
               else WholePoseRun(part, body, config, limbs_on_bed, block, source))
        run.run()
        parts.append(run)
    arrays = [np.concatenate([getattr(r, name) for r in parts])
              for name in ("betas", "pose", "transl", "joints", "bins", "roll", "yaw", "counts")]
    return SampleBatch(*arrays, gender, part.name, limbs_on_bed, seed)
