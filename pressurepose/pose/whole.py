"""Bodies whose whole pose comes from a pose source, under the sampler's rules.

The limb sampler (:mod:`pressurepose.pose.rejection`) draws each limb inside its joint-limit box and
Cartesian bin, the spine and neck held straight. A pose source gives the 23 body joints at once
(spine, neck and head included): the natural partitions' model of real lying poses
(:mod:`pressurepose.pose.natural`) or a user's pose file (:class:`FileSource`). The body's shape,
roll, yaw and place on the bed are drawn as for every partition (:mod:`pressurepose.pose.root`), the
body pose from the source for the posture class of the drawn roll
(:func:`pressurepose.pose.posture.posture_index`). Every pose value the sampler limits (hips, knee
flexion, collar + shoulder, elbow flexion: :mod:`pressurepose.pose.limits`) is then clipped to its
limits (:func:`clip_to_limits`); the values it holds at 0 while drawing limbs (spine, neck, ankles,
wrists, the hinges' other axes) stay as drawn. Clipped, not rejected: real people lie beyond the
limits (in the SMPL fits to SLP, 85 % of the supine poses twist a hip by more than the +-33 deg
allowed: supine legs roll outward; a fifth turn an arm beyond its limits; 11 % lie within them all),
so rejecting kept 7 % of the supine poses drawn from the natural model and doubled their distance
from the held-out people's (2.2 -> 4.5 cm, :mod:`pressurepose.pose.fidelity`), while clipping moves
only the values beyond (2.2 -> 2.5 cm). The limits are the settle's too
(:mod:`pressurepose.sim.ragdoll`), so it does not fight a clipped pose. Then, in order:

``self_collision`` the limbs' capsules penetrate no other (:mod:`pressurepose.pose.collision`), at
                   the capsules' own radii: the settle's test (:mod:`pressurepose.sim.settle`),
                   not the limb sampler's 1.2 x (``SamplerConfig.collision_radius_scale``, which
                   matches the public sampler's fuller capsules). A colliding pose is first moved
                   apart as little as frees it: only the colliding limbs' joints (hip, knee, ankle /
                   shoulder, elbow, wrist) turn, by Gauss-Newton steps on the capsules' summed
                   overlap (each step undoes the linearised overlap with the least movement of the
                   24 joints and the least turn of the pose values, no joint moving more than
                   ``SEPARATE_MAX_STEP_M`` a step), until the pairs lie ``SEPARATE_CLEARANCE_M``
                   apart; the move is then shortened to about the least part of it that frees the
                   pose (halving the way back to the drawn pose, ``SEPARATE_HALVINGS`` times).
                   Where ``SEPARATE_ITERATIONS`` steps do not free it (about 1 pose in 15),
                   Gaussian nudges of the same joints are tried instead, ``SEPARATE_TRIES`` per
                   round with the sd growing by ``SEPARATE_STEP_DEG`` a round, each free one
                   shortened the same way and the one that moves the joints least kept;
``off_mattress``   unless limbs may hang (``SamplerConfig.hanging_limbs``), the elbows, wrists,
                   hands, knees, ankles and feet lie over the mattress, ``side_margin_m`` from its
                   sides, once the body has slid across the bed as little as brings them there (a
                   person on their side lies back from the edge their knees point to).

Why separate: people rest their hands on their belly and chest and their legs against each other, which
capsules (rigid, fitted round the flesh) cannot do; about 9 in 10 of the real poses collide so.
Rejecting them keeps the tenth whose hands touch nothing: 300 held-out supine fits (subjects 61-80)
passed through these rules lay 7.4 cm from themselves (end-joint distance) with the 1.2 x radii and
no nudging; nudged, 4.1 cm at 1.2 x and 2.9 cm at 1.0 x (600 side-lying fits: 3.9, 2.1, 1.8 cm).
Separating is what most separates the natural partitions' bodies from real people: 400
``natural_supine`` bodies' poses lay 2.5 cm from the held-out fits as drawn and clipped and 3.4 cm
once nudged by random nudges kept whole (elbows 2.4 and 4.0 cm, wrists 3.1 and 5.6 cm; side-lying
2.3 and 2.7 cm). Measured on 600 drawn bodies per partition, seeds 0 and 1 (mean of the two; the
seeds alone differ by up to 0.6 cm), random nudges each shortened to the least that frees the pose
against the least move: ``natural_supine`` 3.56 -> 3.28 cm, ``natural_lateral`` 2.83 -> 2.70 cm, and
the held-out fits through the rules 3.01 -> 2.93 cm (supine) and 1.66 -> 1.58 cm (side-lying) from
themselves, at about the same CPU. (Uncapped Gauss-Newton steps, each undoing the whole linearised
overlap, moved folded arms twice as far as the best random nudge; without the cost of turning,
the least move bent wrists, which the end-joint distance does not see, by up to 130 degrees.)
The fits' own distance through the rules (2.93 cm supine) is about as close as drawn supine bodies
can come.

The hip twist is real in the fits, not an artefact of the angles: the limits bound the components
of SMPL's local axis-angle, as the paper's public sampler draws them (it writes each drawn angle
into the pose vector unchanged) and as the settle's limit torques read them
(:mod:`pressurepose.sim.ragdoll`). The supine fits' legs are near straight (median knee flexion
9-11 deg), so every reading of the hip's rotation agrees: the axis-angle's y component (left hip
median 42 deg outward), the twist about the rest femur (43 deg) and the y angle of XYZ, ZXY or YXZ
Euler angles (38-43 deg) all lie beyond the 32.6 deg allowed for 57-60 % of the supine fits of
subjects 1-60. (The fits hold the knee to its hinge and the feet nearly still, so an outward-rolled
shin and foot can only show as hip twist.) Nor is the clipping what costs the natural partitions
their distance: with no clipping at all 600 drawn ``natural_supine`` bodies lay 3.45 cm from the
held-out fits, clipped 3.47 cm. Projecting a pose beyond the limits onto them so that the knee,
ankle and foot (elbow, wrist, hand) move least, rather than clipping each value, moved the
held-out supine fits 0.9 cm from themselves instead of 1.1 cm and the drawn bodies 3.41 cm: not
kept, for its 2 ms a pose.

A rejected pose is redrawn, and after ``off_bed_patience`` or ``collision_patience`` rejections
the body's shape, root and place as well. Bins are not drawn: the returned bins are the ones the
accepted limbs lie in.
"""

from __future__ import annotations

import numpy as np

from pressurepose.body.capsules import capsule_endpoints
from pressurepose.body.contact import segment_distance
from pressurepose.body.joints import joint_index
from pressurepose.body.lbs_numpy import forward_kinematics, rodrigues
from pressurepose.errors import BadInput
from pressurepose.pose.limbs import LIMBS
from pressurepose.pose.limits import COLLAR_OF, JointLimits
from pressurepose.pose.partitions import Partition, arm_bin, leg_bin
from pressurepose.pose.posefile import PoseSet
from pressurepose.pose.posture import POSTURES, posture_index
from pressurepose.pose.rejection import Q, Run
from pressurepose.pose.root import root_axis_angle
from pressurepose.pose.samples import COUNTERS

_COL = {name: i for i, name in enumerate(COUNTERS)}
# separating a colliding pose: the least move (Gauss-Newton on the capsules' overlap) ...
SEPARATE_ITERATIONS = 40
SEPARATE_MAX_STEP_M = 0.02  # m the fastest joint moves at most a step: the steps follow the overlap's descent
SEPARATE_FD_RAD = 1e-5  # finite-difference step of the overlap's and the joints' derivatives
SEPARATE_CLEARANCE_M = 1e-3  # the least move aims for the pairs this far apart (then shortened back)
SEPARATE_DONE_M = 1e-6  # summed overlap (m) at which it is that far apart, less rounding
# the least move's cost of turning a pose value: a radian costs as much as 10 cm of joint movement. With
# 1 cm, moves that shift few joints (a wrist, which no limit bounds) bent up to 130 degrees
SEPARATE_ANGLE_COST_M2 = 1e-2
# ... else rounds of random nudges of the colliding limbs' joints, sd growing per round
SEPARATE_ROUNDS = 24
SEPARATE_TRIES = 16
SEPARATE_STEP_DEG = 1.5
SEPARATE_HALVINGS = 6  # each free nudge is shortened to within 1/64 of the least that frees the pose
# the joints a limb's nudges turn (its hinge about its own axis only): hip, knee, ankle / shoulder,
# elbow, wrist (the collar stays: it moves the shoulder's root)
_NUDGED = tuple(tuple(limb.chain[i] for i in ((0, 1, 2) if limb.is_leg else (1, 2, 3))) for limb in LIMBS)
MAX_POSES = 2000  # whole poses drawn for one body before the source is judged unable to give one
_ON_BED = sorted({j for limb in LIMBS for j in limb.on_bed})
_SHOULDERS = tuple((joint_index(COLLAR_OF[n]), joint_index(n)) for n in ("left_shoulder", "right_shoulder"))


def _judged(limits: JointLimits) -> np.ndarray:
    """(24, 3) True for the pose values the limits bound one by one (collar and shoulder: by their sum)."""
    judged = limits.limited[:, None] & (limits.lower != limits.upper)
    for c, s in _SHOULDERS:
        judged[[c, s]] = False
    return judged


def within_limits(body_pose, limits: JointLimits, tol: float = 1e-9) -> np.ndarray:
    """(N,) True where every pose value that ``limits`` bounds lies within them: body poses (N, 69)
    (``pose[3:]``); the collar and shoulder count by their sum, which the limits bound (the sampler
    splits it 1 : 2); values the limits hold at 0 are not judged."""
    p = _full(body_pose)
    ok = np.all(~_judged(limits) | ((p >= limits.lower - tol) & (p <= limits.upper + tol)), axis=(1, 2))
    for side, (c, s) in enumerate(_SHOULDERS):
        total = p[:, c] + p[:, s]
        ok &= np.all((total >= limits.shoulder_lower[side] - tol) & (total <= limits.shoulder_upper[side] + tol), 1)
    return ok


def clip_to_limits(body_pose, limits: JointLimits) -> np.ndarray:
    """Body poses (N, 69) with every value ``limits`` bounds moved to the nearest limit where it lies
    beyond (a collar + shoulder sum beyond its limits: the difference shared 1 : 2 between them, as
    the sampler splits the shoulder); the rest unchanged. Then :func:`within_limits` holds."""
    p = _full(body_pose)
    p = np.where(_judged(limits), np.clip(p, limits.lower, limits.upper), p)
    for side, (c, s) in enumerate(_SHOULDERS):
        total = p[:, c] + p[:, s]
        gap = np.clip(total, limits.shoulder_lower[side], limits.shoulder_upper[side]) - total
        p[:, c] += limits.shoulder_split * gap
        p[:, s] += (1.0 - limits.shoulder_split) * gap
    return p.reshape(len(p), -1)[:, 3:]


def _full(body_pose) -> np.ndarray:
    """(N, 24, 3) poses with a zero root from body poses (N, 69)."""
    b = np.atleast_2d(np.asarray(body_pose, dtype=np.float64))
    if b.ndim != 2 or b.shape[1] != 69:
        raise BadInput(f"body poses have shape {b.shape}; expected (N, 69)")
    return np.concatenate([np.zeros((len(b), 3)), b], 1).reshape(len(b), 24, 3)


def partition_postures(part: Partition) -> tuple[str, ...]:
    """The posture classes the partition's rolls fall in (:data:`pressurepose.pose.posture.POSTURES`)."""
    lo, hi = part.roll
    rolls = np.linspace(lo, hi, 721)
    if part.either_side:
        rolls = np.concatenate([rolls, -rolls])
    return tuple(POSTURES[k] for k in sorted(set(posture_index(rolls).tolist())))


class FileSource:
    """Body poses from a pose file: a pose of the wanted posture class (by its root) drawn uniformly,
    plus Gaussian noise of sd ``noise_deg`` degrees on each of its 69 body pose values."""

    def __init__(self, poses: PoseSet, noise_deg: float):
        self.poses, self.sd = poses, np.radians(noise_deg)
        self.name = f"pose file {poses.source!r}"
        classes = poses.postures
        self.by_class = {c: np.flatnonzero(classes == c) for c in POSTURES}
        self.groups = tuple(c for c in POSTURES if self.by_class[c].size)

    def draw(self, rng: np.random.Generator, group: str) -> np.ndarray:
        rows = self.by_class[group]
        if not rows.size:
            raise BadInput(f"pose file {self.poses.source!r} holds no {group} poses (by their root orientation); "
                           f"it has {', '.join(self.groups)}")
        out = self.poses.pose[rows[rng.integers(rows.size)], 3:].copy()
        if self.sd > 0:
            out += rng.normal(0.0, self.sd, out.shape)
        return out


class MixtureSource:
    """Body poses from a :class:`~pressurepose.pose.natural.NaturalPoses` model."""

    def __init__(self, model):
        self.model = model
        self.groups = tuple(model.mixtures)
        self.name = "the natural pose model"

    def draw(self, rng: np.random.Generator, group: str) -> np.ndarray:
        return self.model.draw(rng, group)


def check_source(source, part: Partition, what: str) -> None:
    """BadInput unless ``source`` has poses of every posture class the partition's rolls fall in."""
    lacking = [c for c in partition_postures(part) if c not in source.groups]
    if lacking:
        raise BadInput(f"{what} has no {', '.join(lacking)} poses, which partition {part.name} lies bodies in; "
                       f"it has {', '.join(source.groups) or 'none'}")


class WholePoseRun(Run):
    """A :class:`~pressurepose.pose.rejection.Run` whose bodies take whole poses from ``source``
    (see the module docstring)."""

    def __init__(self, part: Partition, body, config, limbs_on_bed: bool, rngs, source):
        self.source = source
        self.placed_x = np.zeros(len(rngs))
        super().__init__(part, body, config, limbs_on_bed, rngs)
        self.body_pose = np.zeros((len(rngs), 69))
        self.misses = np.zeros(len(rngs), dtype=np.int64)
        self.drawn = np.zeros(len(rngs), dtype=np.int64)

    def _draw_body(self, i: int) -> None:
        super()._draw_body(i)
        self.col_radius[i] = self.cap_radius[i]  # the capsules' own radii (see the module docstring)
        self.placed_x[i] = self.pelvis[i, 0]  # where the placement put it, before any slide across

    def _assemble_pose(self, idx: np.ndarray) -> np.ndarray:
        pose = np.zeros((len(idx), 72))
        pose[:, :3] = root_axis_angle(self.W[idx])
        pose[:, 3:] = self.body_pose[idx]
        return pose

    def _draw_poses(self, idx: np.ndarray) -> None:
        """A body pose for each of bodies idx, from the source for its roll's posture class, clipped to
        the joint limits."""
        self.drawn[idx] += 1
        stuck = idx[self.drawn[idx] > MAX_POSES]
        if stuck.size:
            c = self.counts[stuck[0]]
            raise BadInput(f"{MAX_POSES} poses drawn for one body of partition {self.part.name} from "
                           f"{getattr(self.source, 'name', 'the pose source')}, none kept: {c[_COL['off_mattress']]} "
                           f"off the mattress, {c[_COL['self_collision']]} colliding; do its poses fit on this bed?")
        drawn = [self.source.draw(self.rngs[i], POSTURES[int(posture_index(self.roll[i]))]) for i in idx]
        self.body_pose[idx] = clip_to_limits(np.array(drawn), self.limits)

    def _posed(self, i: int, body_poses: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Joints (K, 24, 3) and capsule ends (K, 20, 2, 3), bed frame, of body i with K body poses (K, 69)."""
        pose = np.zeros((len(body_poses), 72))
        pose[:, :3] = root_axis_angle(self.W[[i]])
        pose[:, 3:] = body_poses
        rest = np.broadcast_to(self.rest[i], (len(pose), 24, 3))
        G = forward_kinematics(rodrigues(pose.reshape(-1, 24, 3)), rest, self.body.parents)
        pos = G[..., :3, 3] @ Q.T + (self.pelvis[i] - self.rest[i, 0] @ Q.T)
        return pos, capsule_endpoints(self.caps[i], pos, Q @ G[..., :3, :3] @ Q.T)

    def _separate(self, idx: np.ndarray) -> None:
        """Move the colliding limbs of bodies idx apart (see the module docstring): the least move
        (:meth:`_least_move`), else random nudges (:meth:`_nudge`); a body neither frees keeps its
        pose (and :meth:`_check` rejects it)."""
        for i in idx:
            base = self.body_pose[i]
            joints, ends = self._posed(i, base[None])
            hit = self.collision.contacts(ends[0], self.col_radius[i])
            if not hit:
                continue
            caps = {c for pair in hit for c in pair}
            mask = np.zeros((24, 3), dtype=bool)
            moving: set[int] = set()
            for li, limb in enumerate(LIMBS):
                if caps & set(limb.capsules):
                    moving |= set(limb.capsules)
                    for j in _NUDGED[li]:
                        axis = self.limits.hinge_axis[j]
                        mask[j] = True if axis < 0 else np.arange(3) == axis
            dofs = np.flatnonzero(mask[1:].reshape(69))
            free = self._least_move(i, base, dofs, moving)
            if free is not None:
                self.body_pose[i] = self._shortest_free(i, base, free)
                continue
            free = self._nudge(i, base, dofs, joints)
            if free is not None:
                self.body_pose[i] = free

    def _overlap(self, i: int, poses: np.ndarray, a: np.ndarray, b: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Summed overlap (K,) m of the capsule pairs (a[p], b[p]) of body i, each pair counted as
        overlapping until ``SEPARATE_CLEARANCE_M`` apart, and the joints (K, 24, 3), for body poses (K, 69)."""
        pos, ends = self._posed(i, poses)
        r = self.col_radius[i]
        gap = segment_distance(ends[:, a, 0], ends[:, a, 1], ends[:, b, 0], ends[:, b, 1]) - r[a] - r[b]
        return np.maximum(SEPARATE_CLEARANCE_M - gap, 0.0).sum(axis=1), pos

    def _least_move(self, i: int, base: np.ndarray, dofs: np.ndarray, moving: set[int]) -> np.ndarray | None:
        """A free body pose (69,) of body i reached from the colliding ``base`` by moving only the pose
        values ``dofs``: Gauss-Newton steps that undo the summed overlap of the pairs with a capsule
        in ``moving`` (:meth:`_overlap`) at the least movement of the body's 24 joints and turn of
        its pose values (the step ``-t A^-1 g``, g the overlap's gradient, A = J^T J +
        ``SEPARATE_ANGLE_COST_M2`` I with J the joints' Jacobian, both by
        finite differences of ``SEPARATE_FD_RAD``, t the step that zeroes the linearised overlap
        or, if less, the one that moves the fastest joint ``SEPARATE_MAX_STEP_M``), each step
        clipped to the limits. None where ``SEPARATE_ITERATIONS`` steps leave it colliding."""
        pairs = np.array([p for p in self.collision.pairs if p[0] in moving or p[1] in moving])
        a, b = pairs[:, 0], pairs[:, 1]
        n = len(dofs)
        probe = np.zeros((n + 1, 69))
        probe[np.arange(1, n + 1), dofs] = SEPARATE_FD_RAD
        angle_cost = SEPARATE_ANGLE_COST_M2 * np.eye(n)
        q = base
        for _ in range(SEPARATE_ITERATIONS):
            over, pos = self._overlap(i, q + probe, a, b)
            if over[0] <= SEPARATE_DONE_M:
                _, ends = self._posed(i, q[None])
                return q if not self.collision.contacts(ends[0], self.col_radius[i]) else None
            g = (over[1:] - over[0]) / SEPARATE_FD_RAD
            J = (pos[1:] - pos[0]).reshape(n, -1).T / SEPARATE_FD_RAD  # (72, n) m/rad
            d = -np.linalg.solve(J.T @ J + angle_cost, g)
            slope = g @ d
            if not slope < 0:
                return None
            t = over[0] / -slope
            reach = np.linalg.norm((J @ d).reshape(-1, 3), axis=1).max()  # m per unit t, fastest joint
            step = np.zeros(69)
            step[dofs] = min(t, SEPARATE_MAX_STEP_M / max(reach, 1e-12)) * d
            q = clip_to_limits(q + step, self.limits)[0]
        return None

    def _nudge(self, i: int, base: np.ndarray, dofs: np.ndarray, joints: np.ndarray) -> np.ndarray | None:
        """A free body pose (69,) of body i from random nudges of the pose values ``dofs`` of the
        colliding ``base`` (joints (1, 24, 3) at base): ``SEPARATE_TRIES`` Gaussian nudges a round,
        their sd growing by ``SEPARATE_STEP_DEG`` a round; in the first round with free nudges each
        is shortened (:meth:`_shortest_free`) and the one that moves the joints least is kept.
        None when no round frees it."""
        mask = np.zeros(69)
        mask[dofs] = 1.0
        for r in range(1, SEPARATE_ROUNDS + 1):
            noise = self.rngs[i].standard_normal((SEPARATE_TRIES, 69))
            tries = clip_to_limits(base + mask * np.radians(SEPARATE_STEP_DEG * r) * noise, self.limits)
            pos, ends = self._posed(i, tries)
            free = [k for k in range(len(tries)) if not self.collision.contacts(ends[k], self.col_radius[i])]
            if free:
                shortened = np.array([self._shortest_free(i, base, tries[k]) for k in free])
                pos, _ = self._posed(i, shortened)
                moved = np.linalg.norm(pos - joints, axis=-1).sum(axis=1)
                return shortened[int(np.argmin(moved))]
        return None

    def _shortest_free(self, i: int, base: np.ndarray, free: np.ndarray) -> np.ndarray:
        """The body pose (69,) on the way from a colliding pose ``base`` to a free one ``free`` of body
        i, ``SEPARATE_HALVINGS`` halvings from the first free one along it (a free pose; both ends lie
        within the limits, whose set is convex, and so does every pose between)."""
        lo, hi = 0.0, 1.0  # fractions of the way: lo collides, hi is free
        for _ in range(SEPARATE_HALVINGS):
            mid = 0.5 * (lo + hi)
            _, ends = self._posed(i, (base + mid * (free - base))[None])
            if self.collision.contacts(ends[0], self.col_radius[i]):
                lo = mid
            else:
                hi = mid
        return base + hi * (free - base)

    def _over_mattress(self, idx: np.ndarray) -> np.ndarray:
        """(len(idx),) True where the limbs' on-bed joints lie over the mattress (see module doc),
        after sliding each body across the bed as little as brings them within its sides."""
        self.pelvis[idx, 0] = self.placed_x[idx]
        pose = self._assemble_pose(idx)
        G = forward_kinematics(rodrigues(pose.reshape(-1, 24, 3)), self.rest[idx], self.body.parents)
        pos = G[..., :3, 3] @ Q.T + (self.pelvis[idx] - self.rest[idx, 0] @ Q.T)[:, None]
        x0, x1, y0, y1 = self.cfg.mattress
        if not self.cfg.hanging_limbs:
            x0, x1 = x0 + self.cfg.side_margin_m, x1 - self.cfg.side_margin_m
        xy = pos[:, _ON_BED, :2]
        lo, hi = xy[..., 0].min(axis=1), xy[..., 0].max(axis=1)
        fits = hi - lo < x1 - x0
        slide = np.where(fits, np.maximum(x0 - lo, 0.0) + np.minimum(x1 - hi, 0.0), 0.0)
        self.pelvis[idx, 0] += slide
        return fits & np.all((xy[..., 1] > y0) & (xy[..., 1] < y1), axis=1)

    def run(self) -> None:
        pending = np.arange(len(self.rngs))
        while pending.size:
            self._draw_poses(pending)
            self._separate(pending)
            active = pending
            if self.on_bed:
                over = self._over_mattress(pending)
                for i in pending[~over]:
                    self.counts[i, _COL["off_mattress"]] += 1
                    self.misses[i] += 1
                    if self.misses[i] >= self.cfg.off_bed_patience:
                        self.misses[i] = 0
                        self._draw_body(i)
                        self.counts[i, _COL["bodies_redrawn"]] += 1
                active = pending[over]
            done = active[self._check(active)] if active.size else active
            pending = pending[~np.isin(pending, done)]
        self._bins_reached()

    def _bins_reached(self) -> None:
        """The bins the accepted limbs' distal joints lie in, along the bed (as the limb sampler counts)."""
        for li, limb in enumerate(LIMBS):
            footward = self.joints[:, limb.distal, 1] - self.joints[:, limb.proximal, 1]
            self.bins[:, li] = (leg_bin if limb.is_leg else arm_bin)(footward, self.lengths[:, li])
