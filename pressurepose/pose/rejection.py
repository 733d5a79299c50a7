"""The rejection machinery of the pose sampler (see :mod:`pressurepose.pose.sampler` for the rules).

``Run`` holds the state of n bodies, each with its own random generator, and draws them together:
the tests are vectorised over bodies and limb candidates, while every random draw of a body comes
from its own generator in an order fixed by its own history.
"""

from __future__ import annotations

import itertools
from dataclasses import replace

import numpy as np

from pressurepose.body.capsules import (
    CAPSULE_JOINTS,
    CAPSULE_NAMES,
    capsule_endpoints,
    capsules_for,
    load_regressors,
    regressor_path,
)
from pressurepose.body.contact import START_PAIRS, segment_distance, start_overlap, trunk_contact_lengths
from pressurepose.body.joints import NUM_BETAS, joint_index
from pressurepose.body.lbs_numpy import Y_UP_TO_Z_UP, forward_kinematics, rodrigues
from pressurepose.pose.collision import CHECKED_DEFAULT, checker, limb_pairs
from pressurepose.pose.config import SamplerConfig
from pressurepose.pose.limbs import LIMBS, limb_geometry, limb_lengths, to_world
from pressurepose.pose.limits import JointLimits, joint_limits
from pressurepose.pose.partitions import (
    WEDGE_LENGTH_M,
    WEDGE_TRUNK,
    Partition,
    arm_bin,
    leg_bin,
)
from pressurepose.pose.root import (
    draw_betas,
    draw_placement,
    root_axis_angle,
    slide_along_bed,
    world_rotation,
)
from pressurepose.pose.samples import COUNTERS, LIMB_CAUSES

Q = Y_UP_TO_Z_UP
# capsules whose rest-pose lowest surface is the surface the body lies on (height_reference 'bed')
SUPPORT_CAPSULES = tuple(CAPSULE_NAMES.index(n) for n in (
    "pelvis", "spine", "spine1", "spine2", "left_shoulder", "right_shoulder", "left_thigh", "right_thigh"))
_COL = {name: i for i, name in enumerate(COUNTERS)}
# cause codes of limb candidates: 0 accepted, i + 1 for LIMB_CAUSES[i]
_HEIGHT, _BIN, _OFF_MATTRESS, _NOT_BEHIND_HEAD, _LIMB_COLLISION = range(1, len(LIMB_CAUSES) + 1)
HEAD = joint_index("head")
# a wedge partition's limbs stay in front of the trunk's back (where the wedge goes), within this
# tolerance (m): the settle rejects a capsule starting more than 1 cm inside the wedge
WEDGE_CLEARANCE_M = 0.005
MAX_ROUND_GROWTH = 16  # limb candidates per round grow up to this factor (memory stays bounded)


_BODY_CACHE: list[tuple[object, tuple]] = []


def _body_data(body) -> tuple[np.ndarray, np.ndarray, object]:
    """Per body model, computed once: rest joints (24, 3) of the template and their shape directions
    (24, 3, S) in SMPL's frame (shaped rest joints = template + dirs @ betas: the joint regressor is
    linear), and the shipped capsule regressors if they were fitted to this body, else None (then
    ``capsules_for`` fits capsules to each shape)."""
    for arrays, data in _BODY_CACHE:
        if arrays is body.arrays:
            return data
    a = body.arrays
    jt = a.J_regressor @ a.v_template
    jd = np.einsum("jv,vcs->jcs", a.J_regressor, a.shapedirs)
    path = regressor_path(body.gender)
    reg = load_regressors(path) if path.is_file() else None
    data = (jt, jd, reg if reg is not None and reg.model_identity == body.identity else None)
    _BODY_CACHE.insert(0, (a, data))
    del _BODY_CACHE[4:]
    return data


def _pair_index(limb, pairs) -> tuple[np.ndarray, ...]:
    """Index arrays of a limb's checked pairs (a, c) for :meth:`Run._limb_collides`: the capsules a
    and c, a's and c's places among the limb's capsules (0 where c is not the limb's), c's joint, and
    whether c is the limb's own."""
    a = np.array([p[0] for p in pairs], dtype=np.int64)
    c = np.array([p[1] for p in pairs], dtype=np.int64)
    own = np.array([k in limb.capsules for k in c], dtype=bool)
    return (a, c, np.array([limb.capsules.index(k) for k in a], dtype=np.int64),
            np.array([limb.capsules.index(k) if o else 0 for k, o in zip(c, own)], dtype=np.int64),
            np.array([CAPSULE_JOINTS[k] for k in c], dtype=np.int64), own)


class Run:
    """The state of one sampling run: n bodies, each with its own generator (see module doc)."""

    def __init__(self, part: Partition, body, config: SamplerConfig, limbs_on_bed: bool, rngs):
        self.part, self.body, self.cfg, self.rngs = part, body, config, rngs
        self.on_bed = limbs_on_bed or not config.hanging_limbs
        self.limits: JointLimits = joint_limits(part)
        self.boxes = [limb.box(self.limits, part.straight_limbs) for limb in LIMBS]
        self.j_template, j_dirs, self.cap_regressors = _body_data(body)
        self.j_dirs = j_dirs[..., :NUM_BETAS]
        checked = tuple(c for c in CHECKED_DEFAULT if not (part.hands_behind_head and c.endswith("_hand")))
        self.collision = checker(checked)
        self.limb_pairs = [limb_pairs(limb.capsules, checked) for limb in LIMBS]
        self.pair_index = [_pair_index(limb, pairs) for limb, pairs in zip(LIMBS, self.limb_pairs)]
        # the settle's start test (pressurepose.body.contact) on the pairs this test leaves out (the
        # exempt hands'), applied to the whole poses this test accepts
        tested = set(self.collision.pairs)
        self.start_pairs = tuple(p for p in START_PAIRS if p not in tested)
        self.leg_limbs = tuple(li for li, limb in enumerate(LIMBS) if limb.is_leg)
        self.arm_limbs = tuple(li for li, limb in enumerate(LIMBS) if not limb.is_leg)
        n, s = len(rngs), min(NUM_BETAS, body.num_betas)
        self.betas = np.zeros((n, s))
        self.rest = np.zeros((n, 24, 3))
        self.caps = [None] * n
        self.contact_caps = [None] * n  # the settle's contact geoms (with start pairs to test)
        self.cap_ends = np.zeros((n, 20, 2, 3))  # capsule ends in their joint's rest frame, SMPL axes
        self.cap_radius = np.zeros((n, 20))
        self.col_radius = np.zeros((n, 20))  # radii in the self-collision tests (SamplerConfig.collision_radius_scale)
        self.roll, self.yaw = np.zeros(n), np.zeros(n)
        self.W, self.M = np.zeros((n, 3, 3)), np.zeros((n, 3, 3))
        self.pelvis = np.zeros((n, 3))
        self.support = np.zeros(n)  # height of the surface the body lies on (pelvis at height 0)
        self.back = np.zeros((n, 2))  # wedge partitions: the trunk's back (SMPL z) and top (SMPL y)
        self.lengths = np.zeros((n, len(LIMBS)))
        self.bins = np.zeros((n, len(LIMBS)), dtype=np.int64)
        self.angles = [np.zeros((n, lo.size)) for lo, _ in self.boxes]
        self.collisions = np.zeros(n, dtype=np.int64)
        self.cross_fails = np.zeros(n, dtype=np.int64)
        self.counts = np.zeros((n, len(COUNTERS)), dtype=np.int64)
        self.pose = np.zeros((n, 72))
        self.transl = np.zeros((n, 3))
        self.joints = np.zeros((n, 24, 3))
        for i in range(n):
            self._draw_body(i)
            self._draw_bins(i, range(len(LIMBS)))

    # ------------------------------------------------------------------ per-body draws
    def _draw_body(self, i: int) -> None:
        """Shape, root and shift of body i from its generator, and what follows from them."""
        rng, cfg, part = self.rngs[i], self.cfg, self.part
        self.betas[i] = draw_betas(rng, cfg, self.betas.shape[1])
        lo, hi = part.roll
        self.roll[i] = rng.uniform(lo, hi) if hi > lo else lo
        if part.either_side and rng.random() < 0.5:
            self.roll[i] = -self.roll[i]
        self.rest[i] = self.j_template + self.j_dirs @ self.betas[i]
        caps = capsules_for(self.body, self.betas[i], self.cap_regressors)
        head = CAPSULE_NAMES.index("head")  # the crown: the head capsule's top, SMPL's +y up at rest
        crown = (self.rest[i, CAPSULE_JOINTS[head], 1] + (caps.center[head] @ Q)[1]
                 + 0.5 * caps.length[head] * abs((caps.axis[head] @ Q)[1]) + caps.radius[head] - self.rest[i, 0, 1])
        self.yaw[i], pelvis_xy = draw_placement(rng, cfg, crown, self.roll[i])
        self.caps[i] = caps
        if self.start_pairs:
            self.contact_caps[i] = replace(caps, length=trunk_contact_lengths(self.body, self.betas[i], caps))
        self.cap_radius[i] = caps.radius
        self.col_radius[i] = caps.radius * cfg.collision_radius_scale
        half = 0.5 * caps.length[:, None, None] * np.array([-1.0, 1.0])[None, :, None]
        self.cap_ends[i] = (caps.center[:, None, :] + half * caps.axis[:, None, :]) @ Q  # z-up -> SMPL axes
        self.W[i] = world_rotation(self.roll[i], self.yaw[i])[0]
        self.M[i] = self.W[i] @ Q
        self.pelvis[i] = [*pelvis_xy, 0.0]
        self.lengths[i] = limb_lengths(self.rest[i:i + 1])[0]
        rest_ends = [self.rest[i, CAPSULE_JOINTS[k]] + self.cap_ends[i, k] for k in SUPPORT_CAPSULES]
        z = to_world(np.stack(rest_ends)[None], self.M[i:i + 1], self.rest[i:i + 1, 0], self.pelvis[i:i + 1])
        self.support[i] = np.min(z[0, ..., 2] - caps.radius[list(SUPPORT_CAPSULES), None])
        if self.part.wedge:
            k = [CAPSULE_NAMES.index(c) for c in WEDGE_TRUNK]
            trunk = self.rest[i, [CAPSULE_JOINTS[c] for c in k]][:, None] + self.cap_ends[i, k]  # (4, 2, 3) SMPL axes
            self.back[i] = (np.min(trunk[..., 2] - caps.radius[k, None]), np.max(trunk[..., 1]))

    def _draw_bins(self, i: int, limbs) -> None:
        for li in limbs:
            allowed = self.part.leg_bins if LIMBS[li].is_leg else self.part.arm_bins
            self.bins[i, li] = allowed[self.rngs[i].integers(len(allowed))]

    # ------------------------------------------------------------------ limbs
    def _limb_causes(self, li: int, b: np.ndarray, cand: np.ndarray) -> np.ndarray:
        """Cause code (P, K) of each candidate (0: accepted, c + 1: LIMB_CAUSES[c]) for bodies b.

        Heights are the bed-frame z = M[2] . (p - pelvis_rest) (pelvis at height 0) and bins count
        along the bed's long axis, footward = M[1] . (distal - proximal) (the bed frame's +y is
        footward), as the public code measured both on the posed, yawed body. Height and bin, the
        most selective tests, run on the joints alone; the rest only on the candidates left.
        """
        limb, part, cfg = LIMBS[li], self.part, self.cfg
        aa = limb.local_axis_angles(cand, self.limits)
        pos, _ = limb_geometry(limb, aa, self.rest[b])
        ip, id_ = limb.chain.index(limb.proximal), limb.chain.index(limb.distal)
        reach = pos[:, :, id_] - pos[:, :, ip]  # (P, K, 3), SMPL frame
        rise = np.sum(reach * self.M[b, 2][:, None, :], axis=-1)
        band = part.arm_height_band if (not limb.is_leg and part.arm_height_band) else (
            -cfg.height_band, cfg.height_band)
        length = self.lengths[b, li][:, None]
        footward = np.sum(reach * self.M[b, 1][:, None, :], axis=-1)
        got = leg_bin(footward, length) if limb.is_leg else arm_bin(footward, length)
        if cfg.height_reference == "bed" and not (part.arm_height_band and not limb.is_leg):
            # the distal joint's height above the surface the body lies on (both pelvis-relative)
            proximal = np.sum((pos[:, :, ip] - self.rest[b, 0][:, None]) * self.M[b, 2][:, None, :], axis=-1)
            rise = proximal + rise - self.support[b][:, None]
            band = cfg.bed_height_band
        cause = np.where((rise < band[0]) | (rise > band[1]), _HEIGHT,
                         np.where(got != self.bins[b, li][:, None], _BIN, 0))
        p, k = np.nonzero(cause == 0)
        if p.size:
            cause[p, k] = self._limb_details(li, b[p], aa[p, k][:, None], reach[p, k])
        return cause

    def _limb_details(self, li: int, bodies: np.ndarray, aa: np.ndarray, reach: np.ndarray) -> np.ndarray:
        """Cause codes (N,) of the tests after height and bin, for N candidates (one per row):
        bodies (N,), local axis-angles aa (N, 1, C, 3), distal reach (N, 3)."""
        limb, part, cfg = LIMBS[li], self.part, self.cfg
        pos, ends = limb_geometry(limb, aa, self.rest[bodies], self.cap_ends[bodies])
        pos, ends = pos[:, 0], ends[:, 0]
        no = np.zeros(len(bodies), dtype=bool)
        tests = {_OFF_MATTRESS: no, _NOT_BEHIND_HEAD: no}
        if self.on_bed:
            x0, x1, y0, y1 = cfg.mattress
            if not cfg.hanging_limbs:  # keep clear of the sides: a limb at the edge slides off as it settles
                x0, x1 = x0 + cfg.side_margin_m, x1 - cfg.side_margin_m
            pts = pos[:, None, [limb.chain.index(j) for j in limb.on_bed]]
            xy = to_world(pts, self.M[bodies], self.rest[bodies, 0], self.pelvis[bodies])[:, 0, :, :2]
            inside = (xy[..., 0] > x0) & (xy[..., 0] < x1) & (xy[..., 1] > y0) & (xy[..., 1] < y1)
            tests[_OFF_MATTRESS] = ~inside.all(-1)
        if part.hands_behind_head and not limb.is_leg:
            # medial: toward the body's right (-x) for the left wrist, toward its left for the right
            lateral = reach[:, 0] * (1.0 if limb.side == 0 else -1.0) >= 0.0
            to_head = np.linalg.norm(pos[:, limb.chain.index(limb.distal)] - self.rest[bodies, HEAD], axis=-1)
            tests[_NOT_BEHIND_HEAD] = lateral | (to_head > part.wrist_to_head)
        cause = np.zeros(len(bodies), dtype=np.int64)
        for code in sorted(tests, reverse=True):  # the first failing test names the cause
            cause[tests[code]] = code
        left = np.flatnonzero(cause == 0)
        if left.size and self.limb_pairs[li]:
            cause[left[self._limb_collides(li, bodies[left], ends[left])]] = _LIMB_COLLISION
        left = np.flatnonzero(cause == 0)
        if left.size and part.wedge:
            cause[left[self._behind_back(li, bodies[left], ends[left])]] = _LIMB_COLLISION
        return cause

    def _behind_back(self, li: int, bodies: np.ndarray, ends: np.ndarray) -> np.ndarray:
        """(N,) True where a capsule of the limb reaches behind the trunk's back, inside the wedge
        that a wedge partition puts there (it runs ``WEDGE_LENGTH_M`` footward from the trunk's top;
        counted as a limb collision). The body faces SMPL's +z; ends (N, n_caps, 2, 3) as
        :meth:`_limb_collides`'."""
        r = self.cap_radius[bodies][:, list(LIMBS[li].capsules), None]
        back, top = self.back[bodies, 0][:, None, None], self.back[bodies, 1][:, None, None]
        span = (ends[..., 1] <= top) & (ends[..., 1] >= top - WEDGE_LENGTH_M)
        return np.any(span & (ends[..., 2] - r < back - WEDGE_CLEARANCE_M), axis=(1, 2))

    def _limb_collides(self, li: int, bodies: np.ndarray, ends: np.ndarray) -> np.ndarray:
        """(N,) True where a limb's checked capsule penetrates another capsule it alone decides.

        bodies: (N,) body of each candidate; ends: (N, n_caps, 2, 3) the candidates' limb capsule
        ends (SMPL frame, no root); fixed capsules rest at their joints.
        """
        a, c, a_in_limb, c_in_limb, c_joint, own = self.pair_index[li]
        ea = ends[:, a_in_limb]  # (N, P, 2, 3)
        fixed = self.rest[bodies][:, c_joint][:, :, None] + self.cap_ends[bodies][:, c]
        ec = np.where(own[None, :, None, None], ends[:, c_in_limb], fixed)
        d = segment_distance(ea[..., 0, :], ea[..., 1, :], ec[..., 0, :], ec[..., 1, :])  # (N, P)
        radius = self.col_radius[bodies]
        return np.any(d < radius[:, a] + radius[:, c], axis=1)

    def _sample_limb(self, li: int, idx: np.ndarray) -> np.ndarray:
        """Choose limb li's angles for bodies idx (each body in its own generator's order).

        Returns a mask over idx of the bodies that gave up (bin redrawn max_bin_redraws + 1 times).
        """
        lo, hi = self.boxes[li]
        cfg = self.cfg
        tries = np.zeros(len(idx), dtype=np.int64)
        off_fails = np.zeros(len(idx), dtype=np.int64)
        redraws = np.zeros(len(idx), dtype=np.int64)
        pending = np.arange(len(idx))
        for r in itertools.count():
            if not pending.size:
                break
            # rounds grow so that rare bins take few rounds; the same for every pending body
            k_round = cfg.candidates_per_round * min(2 ** r, MAX_ROUND_GROWTH)
            ks = np.arange(k_round)
            b = idx[pending]
            cand = np.stack([self.rngs[i].uniform(lo, hi, (k_round, lo.size)) for i in b])
            cause = self._limb_causes(li, b, cand)
            ok = cause == 0
            first_ok = np.where(ok.any(1), ok.argmax(1), k_round)
            trig = np.clip(cfg.bin_patience - tries[pending] - 1, 0, k_round)  # bin_patience-th try
            if self.on_bed:
                cum_off = off_fails[pending, None] + np.cumsum(cause == _OFF_MATTRESS, axis=1)
                hit = cum_off >= cfg.off_bed_patience
                trig = np.minimum(trig, np.where(hit.any(1), hit.argmax(1), k_round))
            accepted = (first_ok <= trig) & (first_ok < k_round)
            redraw = ~accepted & (trig < k_round)
            stop = np.where(accepted, first_ok, np.where(redraw, trig + 1, k_round))  # candidates failed
            failed = ks[None, :] < stop[:, None]
            for c in range(len(LIMB_CAUSES)):
                np.add.at(self.counts[:, c], b, (failed & (cause == c + 1)).sum(1))
            np.add.at(self.counts[:, _COL["limb_candidates"]], b, stop + accepted)
            for p in np.flatnonzero(accepted):
                self.angles[li][b[p]] = cand[p, first_ok[p]]
            for p in np.flatnonzero(redraw):
                self._draw_bins(b[p], [li])
                self.counts[b[p], _COL["bins_redrawn"]] += 1
            cont = ~accepted & ~redraw
            tries[pending[cont]] += k_round
            off_fails[pending[cont]] = off_fails[pending[cont]] + (cause[cont] == _OFF_MATTRESS).sum(1)
            tries[pending[redraw]] = 0
            off_fails[pending[redraw]] = 0
            redraws[pending[redraw]] += 1
            pending = pending[~accepted & (redraws[pending] <= cfg.max_bin_redraws)]
        return redraws > cfg.max_bin_redraws

    # ------------------------------------------------------------------ whole bodies
    def _assemble_pose(self, idx: np.ndarray) -> np.ndarray:
        pose = np.zeros((len(idx), 24, 3))
        pose[:, 0] = root_axis_angle(self.W[idx])
        for li, limb in enumerate(LIMBS):
            pose[:, list(limb.chain)] += limb.local_axis_angles(self.angles[li][idx], self.limits)
        return pose.reshape(len(idx), 72)

    def _legs_crossed(self, idx: np.ndarray) -> np.ndarray:
        """(len(idx),) True where the chosen left ankle lies toward the body's right (SMPL -x) of
        the chosen right ankle."""
        ankle_x = []
        for li in self.leg_limbs:
            limb = LIMBS[li]
            aa = limb.local_axis_angles(self.angles[li][idx], self.limits)[:, None]
            pos, _ = limb_geometry(limb, aa, self.rest[idx])
            ankle_x.append(pos[:, 0, limb.chain.index(limb.distal), 0])
        return ankle_x[0] < ankle_x[1]

    def _sample_limbs(self, limbs: tuple[int, ...], idx: np.ndarray) -> np.ndarray:
        """Draw the given limbs for bodies idx; returns the bodies that got them all. A body whose
        limb gave up is redrawn (shape, root, shift) and left out."""
        for li in limbs:
            stuck = self._sample_limb(li, idx)
            for i in idx[stuck]:
                self._draw_body(i)
                self.counts[i, _COL["bodies_redrawn"]] += 1
            idx = idx[~stuck]
        return idx

    def _sample_legs(self, idx: np.ndarray) -> np.ndarray:
        """Draw both legs of bodies idx (until crossed, for crossed-legs partitions: legs only, as the
        arms do not take part); returns the bodies that got them."""
        done = []
        while idx.size:
            idx = self._sample_limbs(self.leg_limbs, idx)
            if not self.part.crossed_legs:
                return idx
            crossed = self._legs_crossed(idx)
            done.append(idx[crossed])
            idx = idx[~crossed]
            for i in idx:
                self.counts[i, _COL["legs_not_crossed"]] += 1
                self.cross_fails[i] += 1
                if self.cross_fails[i] >= self.cfg.cross_patience:
                    self.cross_fails[i] = 0
                    self._draw_bins(i, self.leg_limbs)
                    self.counts[i, _COL["bins_redrawn"]] += len(self.leg_limbs)
        return np.sort(np.concatenate(done)) if done else idx

    def _check(self, idx: np.ndarray) -> np.ndarray:
        """Self-collision of whole poses of bodies idx; fills accepted bodies' outputs (lowered to
        ``clearance`` above the mattress); returns the accepted mask. A pose that passes, but fails the
        settle's start test on ``start_pairs``, starts its body afresh (shape, root, shift and bins, as
        a new attempt would): the settle would have rejected it."""
        pose = self._assemble_pose(idx)
        G = forward_kinematics(rodrigues(pose.reshape(-1, 24, 3)), self.rest[idx], self.body.parents)
        transl = self.pelvis[idx] - self.rest[idx, 0] @ Q.T
        pos = G[..., :3, 3] @ Q.T + transl[:, None]
        Wj = Q @ G[..., :3, :3] @ Q.T
        np.add.at(self.counts[:, _COL["full_poses"]], idx, 1)
        accepted = np.zeros(len(idx), dtype=bool)
        for p, i in enumerate(idx):
            caps = self.caps[i]
            ends = capsule_endpoints(caps, pos[p:p + 1], Wj[p:p + 1])[0]
            if self.collision.collides(ends, self.col_radius[i]):
                self.counts[i, _COL["self_collision"]] += 1
                self.collisions[i] += 1
                if self.collisions[i] > self.cfg.collision_patience:
                    self.collisions[i] = 0
                    self._draw_body(i)
                    self.counts[i, _COL["bodies_redrawn"]] += 1
                continue
            if self.start_pairs and start_overlap(capsule_endpoints(self.contact_caps[i], pos[p:p + 1], Wj[p:p + 1])[0],
                                                  caps.radius, pairs=self.start_pairs):
                self.counts[i, _COL["self_collision"]] += 1
                self.counts[i, _COL["bodies_redrawn"]] += 1
                self.counts[i, _COL["bins_redrawn"]] += len(LIMBS)
                self.collisions[i] = self.cross_fails[i] = 0
                self._draw_body(i)
                self._draw_bins(i, range(len(LIMBS)))
                continue
            lift = self.cfg.clearance - np.min(ends[..., 2] - caps.radius[:, None])
            slide = slide_along_bed(pos[p], self.cfg)
            self.pose[i] = pose[p]
            self.transl[i] = transl[p] + [0.0, slide, lift]
            self.joints[i] = pos[p] + [0.0, slide, lift]
            accepted[p] = True
        return accepted

    def run(self) -> None:
        pending = np.arange(len(self.rngs))
        while pending.size:
            active = self._sample_limbs(self.arm_limbs, self._sample_legs(pending))
            done = active[self._check(active)] if active.size else active
            pending = pending[~np.isin(pending, done)]
