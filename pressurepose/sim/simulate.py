"""One body through both simulations: sample -> settle (MuJoCo) -> press (mesh on the bed) -> mat image.

:func:`simulate_one` makes one attempt: a :class:`Simulated` body, or :class:`Rejected` with the
cause. The labels describe the body where the image was made: the press's small rigid correction (a
tilt about the centre of mass and a vertical shift) is folded into the root orientation and
translation, so ``BodyModel.forward(betas, pose, transl)`` reproduces the pressed mesh exactly.
"""

from __future__ import annotations

import time
from dataclasses import dataclass
from typing import TYPE_CHECKING

import numpy as np

from pressurepose.body.lbs_numpy import (
    Y_UP_TO_Z_UP,
    rodrigues,
    rotation_to_axis_angle,
    shaped_rest,
)
from pressurepose.errors import BadInput
from pressurepose.sim.settle_config import HANG_DEPTH_M, LIMB_JOINTS, hanging

if TYPE_CHECKING:
    from pressurepose.sim.press import PressResult
    from pressurepose.sim.randomize import Conditions
    from pressurepose.sim.wedge import Wedge



@dataclass(frozen=True, eq=False)
class Simulated:
    """A settled, pressed body: labels (betas (S,), pose (72,), transl (3,), joints (24, 3) bed frame,
    mass kg, height m) and ``image``, the :class:`~pressurepose.sim.press.PressResult`
    (pressure, force, depth, contact maps); ``settle_steps``: steps the ragdoll took to rest;
    ``conditions``: the randomised bed it was pressed on (:class:`~pressurepose.sim.randomize.Conditions`),
    or None (the nominal bed); ``wedge``: the :class:`~pressurepose.sim.wedge.Wedge` that propped the
    body, in the labels' frame (None without one); ``wedge_force``: (rows, cols) N, the part of
    ``image.force`` that is the wedge's load on the mat (None without one), so the body's own print
    is ``read_sensor(image.force - wedge_force, bed)``."""

    betas: np.ndarray
    pose: np.ndarray
    transl: np.ndarray
    joints: np.ndarray
    mass: float
    height: float
    image: PressResult
    settle_steps: int
    conditions: Conditions | None = None
    wedge: Wedge | None = None
    wedge_force: np.ndarray | None = None


@dataclass(frozen=True)
class Rejected:
    """An attempt that produced no usable sample.

    cause: a short snake_case reason. From :func:`simulate_one`: a settle's status other than
    'settled' (:data:`pressurepose.sim.settle.STATUSES`: ``not_settled``, ``unstable``,
    ``fell_off_bed``, ``posture_changed``, ``self_collision``, ``support_overlap``),
    ``limb_off_bed`` or ``press_failed``; another producer
    (:mod:`pressurepose.data.producers`) names its own. detail: what happened, in words ("" when
    the cause says it all).
    """

    cause: str
    detail: str = ""

    def __post_init__(self):
        if not isinstance(self.cause, str) or not self.cause:
            raise TypeError(f"Rejected cause is {self.cause!r}; expected a short snake_case reason")


def apply_rigid_motion(body, betas: np.ndarray, pose: np.ndarray, transl: np.ndarray,
                       transform: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """SMPL root parameters of a body after a rigid motion of the whole body.

    betas (S,), pose (72,), transl (3,) place the body; transform (4, 4) moves it in the bed frame.
    Returns (pose', transl') with ``forward(betas, pose', transl') == transform applied to
    forward(betas, pose, transl)``: only the root orientation (pose'[:3]) and transl change.
    """
    Q = Y_UP_TO_Z_UP
    R, t = transform[:3, :3], transform[:3, 3]
    _, rest = shaped_rest(body.arrays, np.asarray(betas)[None])
    root = Q @ rest[0, 0]                      # the root joint's offset, z-up, before transl
    new_pose = np.array(pose, dtype=np.float64)
    new_pose[:3] = rotation_to_axis_angle(Q.T @ R @ Q @ rodrigues(new_pose[:3]))
    new_transl = R @ (root + transl) + t - root
    return new_pose, new_transl


def press_at(body, betas, pose, transl, mass_kg: float, bed, *, verts=None, com_xy=None):
    """The :class:`~pressurepose.sim.press.PressResult` of the body at (betas (S,), pose (72,),
    transl (3,)) pressed into ``bed`` with its soft tissue (bones from the pose, fractions from the
    bed), its ``label`` the body site (:data:`pressurepose.body.sites.SITES`) that carried each
    taxel's force. verts: (1, V, 3) the mesh at that pose, if already computed; com_xy: as ``press``'s."""
    from pressurepose.body.sites import vertex_sites
    from pressurepose.sim.press import press
    from pressurepose.sim.tissue import body_bones

    if verts is None:
        verts, _ = body.forward(betas, pose, transl)
    return press(verts[0], body.faces, mass_kg, bed, com_xy=com_xy,
                 bones=body_bones(body, betas, pose, transl, bed.tissue_bone_fraction),
                 vertex_label=vertex_sites(body))


def limb_off_bed(joints: np.ndarray, bed) -> bool:
    """Whether a limb hangs over the mattress's edge: a limb joint of ``joints`` (24, 3) bed frame
    beyond the mattress's outline and more than HANG_DEPTH_M below its top. (A hand or foot that
    rests across the edge a few cm past it, as arms above the head of a body lying near the head
    end do, is not hanging.)"""
    return hanging(np.asarray(joints)[list(LIMB_JOINTS)], bed.mattress_bounds, HANG_DEPTH_M)


def check_body_gender(body, gender) -> str:
    """``gender`` as 'f' or 'm'; BadInput unless it is f or m (female, male) and, for a body that
    records a gender (``body.gender`` 'female' or 'male'), that one: the body's shape space and the
    mass table would otherwise belong to different people. A neutral body takes either (the gender
    then picks the mass table, as :func:`pressurepose.sim.settle.settle`'s does)."""
    from pressurepose.pose.sampler import check_gender

    g = check_gender(gender)
    own = getattr(body, "gender", "neutral")
    if own in ("female", "male") and own[0] != g:
        raise BadInput(f"gender is {gender!r} but the body is the {own} model ({body!r}); expected {own[0]!r}, or "
                       f"a neutral body (BodyModel('n')) to settle with the {'female' if g == 'f' else 'male'} "
                       f"mass table")
    return g


def simulate_one(body, bed, partition: str, gender: str, rng: np.random.Generator,
                 limbs_on_bed: bool = False, sampler=None, conditions=None, timings: dict | None = None,
                 settle_config=None) -> Simulated | Rejected:
    """One attempt: a :class:`Simulated` body, or :class:`Rejected` when settling fails (the
    settle's status), when pressing fails (``press_failed``) or when a limb hangs over the
    mattress's edge (``limb_off_bed``, :func:`limb_off_bed`) and the sampler does not allow
    hanging limbs: tested while the body settles (it stops where the limb first hangs, see
    :mod:`pressurepose.sim.settle`) and on the resting body. All randomness comes from
    ``rng``. ``sampler``: the pose sampler's :class:`~pressurepose.pose.config.SamplerConfig`
    (default: its defaults). ``conditions`` (:class:`~pressurepose.sim.randomize.Conditions`):
    settle on ``bed``, then press and read the body on ``conditions.bed(bed)``, the mat moved under
    it (the labels are in that mat's frame).

    A partition with a wedge (:attr:`~pressurepose.pose.partitions.Partition.wedge`) settles the
    body against it; the mattress then carries the body less what the wedge holds
    (:func:`pressurepose.sim.wedge.relieved_body`), and the mat reads both (:func:`~pressurepose.sim.wedge.with_wedge`).
    A body posed from real lying poses (a natural partition or a pose file,
    :func:`pressurepose.pose.sampler.whole_pose`) holds that pose: its joint springs rest at the
    drawn pose, not the paper's home pose (docs/physics.md, "Springs of real poses").

    ``gender`` ('f' or 'm') labels the body and picks its mass table; a female or male ``body`` must
    be of that gender (:func:`check_body_gender`), a neutral one may take either.

    ``timings``: a dict to fill with the CPU seconds of the attempt's phases (``sample``, ``settle``,
    ``press``: what ran) and the settle's ``steps`` (for benchmarks). ``settle_config``: a
    :class:`~pressurepose.sim.settle_config.SettleConfig` (default: its defaults, the "relaxed" settle)."""
    from pressurepose.body.model import BodyModel
    from pressurepose.pose.config import SamplerConfig
    from pressurepose.pose.partitions import get_partition
    from pressurepose.pose.sampler import sample_one, whole_pose
    from pressurepose.sim.bed import BedSpec
    from pressurepose.sim.press import PressFailed, mesh_centroid
    from pressurepose.sim.randomize import Conditions
    from pressurepose.sim.settle import settle
    from pressurepose.sim.settle_config import SettleConfig
    from pressurepose.sim.wedge import relieved_body, with_wedge

    for name, value, kind, what, optional in (("body", body, BodyModel, "a BodyModel (BodyModel('female'), ...)", False),
                                              ("bed", bed, BedSpec, "a BedSpec (see get_bed)", False),
                                              ("sampler", sampler, SamplerConfig, "a SamplerConfig", True),
                                              ("conditions", conditions, Conditions, "a Conditions", True),
                                              ("timings", timings, dict, "a dict to fill", True),
                                              ("settle_config", settle_config, SettleConfig, "a SettleConfig", True)):
        if not isinstance(value, kind) and not (optional and value is None):
            raise BadInput(f"{name} is {type(value).__name__}; expected {what}" + (" or None" if optional else ""))
    check_body_gender(body, gender)
    clock = {} if timings is None else timings
    sampler = SamplerConfig() if sampler is None else sampler
    t0 = time.process_time()
    drawn = sample_one(partition, gender, rng, limbs_on_bed, body=body, config=sampler)
    t1 = time.process_time()
    part = get_partition(partition)
    rest = settle(body, drawn.betas, drawn.pose, drawn.transl, gender, bed=bed, config=settle_config,
                  wedge=part.wedge, hang_depth_m=None if sampler.hanging_limbs else HANG_DEPTH_M,
                  spring_pose=drawn.pose if whole_pose(part, sampler) else None)
    t2 = time.process_time()
    clock.update(sample=t1 - t0, settle=t2 - t1, press=0.0, steps=int(rest.steps))
    if not rest.ok:
        steps = f"{rest.steps} settle step{'' if rest.steps == 1 else 's'}"
        moved = f", ended {rest.posture}" if rest.posture != rest.posture_start else ""
        return Rejected(rest.status, f"{steps}, started {rest.posture_start}{moved}")
    verts, joints = body.forward(rest.betas, rest.pose, rest.transl)
    if not sampler.hanging_limbs and limb_off_bed(joints[0], bed):
        return Rejected("limb_off_bed")
    pose, transl, press_bed = rest.pose, rest.transl, bed
    wedge, points = rest.wedge, rest.wedge_points
    if conditions is not None:
        press_bed = conditions.bed(bed)
        motion = conditions.body_motion(bed)
        pose, transl = apply_rigid_motion(body, rest.betas, pose, transl, motion)
        verts, _ = body.forward(rest.betas, pose, transl)
        if wedge is not None:
            wedge, points = wedge.moved(motion), points @ motion[:3, :3].T + motion[:3, 3]
    mass, com_xy, wedge_force = rest.mass_kg, None, None
    t3 = time.process_time()
    try:
        if wedge is not None:
            mass, com_xy = relieved_body(rest.mass_kg, mesh_centroid(verts[0], body.faces)[1][:2], points,
                                         rest.wedge_force_z)
        image = press_at(body, rest.betas, pose, transl, mass, press_bed, verts=verts, com_xy=com_xy)
        if wedge is not None:
            body_force = image.force
            image = with_wedge(image, wedge, points, rest.wedge_force_z, press_bed)
            wedge_force = image.force - body_force
    except PressFailed as exc:
        return Rejected("press_failed", str(exc))
    finally:
        clock["press"] = time.process_time() - t3
    pose, transl = apply_rigid_motion(body, rest.betas, pose, transl, image.transform)
    _, joints = body.forward(rest.betas, pose, transl)
    return Simulated(betas=np.asarray(rest.betas, dtype=np.float64), pose=pose, transl=transl, joints=joints[0],
                     mass=float(rest.mass_kg), height=float(body.height(rest.betas)[0]), image=image,
                     settle_steps=int(rest.steps), conditions=conditions, wedge=wedge, wedge_force=wedge_force)
