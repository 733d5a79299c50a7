"""A model of how people lie: Gaussian mixtures over the body joints' axis-angles, per posture.

The natural partitions (``natural_supine``, ``natural_lateral``; :mod:`pressurepose.pose.partitions`)
draw a body's 23 joint rotations (SMPL's ``pose[3:]``, the body pose without the root) from a
:class:`GaussianMixture` of its posture class: ``supine``, ``left_lateral`` or ``right_lateral``
(prone has none: the poses it was fitted to hold no prone bodies). The shipped model,
``assets/natural_poses.npz``, holds only each mixture's weights, means and covariances (and which
pose values they cover); ``tools/fit_natural_poses.py`` rebuilds it from SMPL fits to the SLP
dataset (subjects 1-60; NOTICE.md says what was fitted to what). Every component averages over at
least ``MIN_COUNT`` poses (``2 MIN_COUNT`` points of the mirrored supine set), and a mean and
covariance of that many poses do not determine any of them.

What was fitted (:func:`fit_natural_poses`): the supine mixture to the supine poses and their
mirror images (left and right swapped: :func:`mirror_poses`; supine people lie about as often
either way, and the mirrored half brought the held-out distance from 3.5-3.9 to 2.4-2.6 cm when
choosing the settings on subjects 1-45 against 46-60), each side's mixture to that side's poses
alone (mirroring the other side made it worse there, 2.5 -> 2.7 cm). The pose values the fits hold
still (within 0.01 rad in every fit: hands, feet, the knees' and elbows' off-hinge axes) are held at
0 and not modelled.
"""

from __future__ import annotations

import json
from dataclasses import dataclass
from functools import lru_cache
from pathlib import Path

import numpy as np

from pressurepose.body.joints import NUM_JOINTS, mirror_permutation
from pressurepose.errors import BadInput
from pressurepose.files import load_npz, save_npz_atomic
from pressurepose.pose.mixture import GaussianMixture, fit_mixture

ASSET = Path(__file__).resolve().parent / "assets" / "natural_poses.npz"
GROUPS: tuple[str, ...] = ("supine", "left_lateral", "right_lateral")
MIN_COUNT = 50  # poses each component averages over, at least
HELD_SD_RAD = np.radians(1.0)  # pose values varying less than this over the fits are held at 0
BODY_POSE = 3 * (NUM_JOINTS - 1)  # 69


# the ``posture`` labels of the SLP fits (SLP's instructed postures) as posture classes
LABEL_GROUPS = {"supine": "supine", "left": "left_lateral", "right": "right_lateral"}
FITS_ENV = "PRESSUREPOSE_SLP_FITS"  # where tools and benchmarks look for the SLP fits when not told


def posture_groups(poses) -> np.ndarray:
    """(N,) posture class of each pose of a :class:`~pressurepose.pose.posefile.PoseSet`: its file's
    own ``posture`` label where it has one of :data:`LABEL_GROUPS` (the posture a person was asked to
    take: in the SLP fits 7 % of the side-lying bodies have a root turned into another class), else
    the class of its root orientation."""
    groups = np.array(poses.postures, dtype=object)
    if poses.labels is not None:
        named = np.isin(poses.labels, list(LABEL_GROUPS))
        groups[named] = [LABEL_GROUPS[str(v)] for v in poses.labels[named]]
    return groups.astype(str)


def mirror_poses(pose) -> np.ndarray:
    """SMPL poses (N, 72) of the mirrored bodies (left and right swapped: joints permuted, each
    axis-angle's y and z negated, the root included)."""
    p = np.asarray(pose, dtype=np.float64).reshape(-1, NUM_JOINTS, 3)[:, mirror_permutation()].copy()
    p[..., 1:] *= -1.0
    return p.reshape(-1, 3 * NUM_JOINTS)


@dataclass(frozen=True, eq=False)
class NaturalPoses:
    """Per posture class (``mixtures`` keys, some of :data:`GROUPS`), a mixture over the body pose
    values ``dims`` (indices into the 69 of ``pose[3:]``; the rest are 0); ``poses``: how many poses
    each was fitted to (so ``weights x poses`` is how many each component averages over);
    ``fitted_to``: a line saying what the mixtures were fitted to."""

    mixtures: dict
    dims: np.ndarray
    poses: dict
    fitted_to: str = ""

    def __post_init__(self):
        dims = np.asarray(self.dims, dtype=np.int64)
        if dims.ndim != 1 or not len(dims) or len(set(dims.tolist())) != len(dims) or dims.min() < 0 \
                or dims.max() >= BODY_POSE:
            raise BadInput(f"natural poses: dims {dims.tolist()[:8]}...; expected distinct indices into the "
                           f"{BODY_POSE} body pose values")
        object.__setattr__(self, "dims", dims)
        for group, mix in self.mixtures.items():
            if group not in GROUPS:
                raise BadInput(f"natural poses: posture {group!r}; expected some of {', '.join(GROUPS)}")
            if mix.dim != len(dims):
                raise BadInput(f"natural poses: the {group} mixture has {mix.dim} dimensions; dims has {len(dims)}")
            if group not in self.poses:
                raise BadInput(f"natural poses: the {group} mixture has no pose count")

    def draw(self, rng: np.random.Generator, group: str) -> np.ndarray:
        """One body pose (69,) (``pose[3:]``, rad) of posture class ``group`` drawn with ``rng``."""
        mix = self.mixtures.get(group)
        if mix is None:
            raise BadInput(f"the natural pose model has no {group} poses; it has {', '.join(self.mixtures)}")
        out = np.zeros(BODY_POSE)
        out[self.dims] = mix.sample(rng, 1)[0]
        return out

    def save(self, path) -> None:
        """Write an ``.npz`` (no pickles; float32) readable by :meth:`load`."""
        arrays = {"dims": self.dims, "groups": np.array(list(self.mixtures)), "fitted_to": np.array(self.fitted_to)}
        for group, mix in self.mixtures.items():
            for name in ("weights", "means", "covariances"):
                arrays[f"{group}.{name}"] = getattr(mix, name).astype(np.float32)
            arrays[f"{group}.poses"] = np.array(int(self.poses[group]))
        save_npz_atomic(path, **arrays)

    @classmethod
    def load(cls, path=ASSET) -> "NaturalPoses":
        d = load_npz(path, "natural pose model")
        missing = [k for k in ("dims", "groups", "fitted_to") if k not in d]
        if missing:
            raise BadInput(f"natural pose model {str(path)!r} lacks {', '.join(missing)}")
        mixtures, poses = {}, {}
        for group in map(str, d["groups"]):
            keys = [f"{group}.{n}" for n in ("weights", "means", "covariances", "poses")]
            missing = [k for k in keys if k not in d]
            if missing:
                raise BadInput(f"natural pose model {str(path)!r} lacks {', '.join(missing)}")
            w, m, c = (d[k].astype(np.float64) for k in keys[:3])
            mixtures[group] = GaussianMixture(w / w.sum(), m, 0.5 * (c + np.swapaxes(c, 1, 2)))
            poses[group] = int(d[keys[3]])
        return cls(mixtures, d["dims"], poses, str(d["fitted_to"]))

    def describe(self) -> dict:
        """Components per posture and the fitted_to line, for reports."""
        return {"components": {g: len(m.weights) for g, m in self.mixtures.items()}, "poses": dict(self.poses),
                "dims": len(self.dims), "fitted_to": self.fitted_to}


@lru_cache(maxsize=1)
def natural_poses() -> NaturalPoses:
    """The shipped model (``assets/natural_poses.npz``), read once."""
    if not ASSET.is_file():
        raise BadInput(f"the natural pose model {ASSET} is missing; rebuild it with tools/fit_natural_poses.py")
    return NaturalPoses.load(ASSET)


@dataclass(frozen=True)
class FitSettings:
    """How :func:`fit_natural_poses` fits: components (at most, per posture), reg_deg (sd added to
    every covariance's diagonal, degrees), min_count (poses per component, at least), seed (EM's
    first start), restarts (EM runs from seeds seed, seed + 1, ...; the one most likely on the
    poses it was fitted to is kept), mirror_supine (fit supine to the poses and their mirror images)."""

    components: int = 16
    reg_deg: float = 1.0
    min_count: int = MIN_COUNT
    seed: int = 0
    restarts: int = 4
    mirror_supine: bool = True


def fit_natural_poses(pose, posture, settings: FitSettings = FitSettings(), fitted_to: str = "") -> NaturalPoses:
    """Mixtures fitted to poses (N, 72) whose posture classes (N,) (names of :data:`GROUPS`; others
    ignored) are given, as the module docstring says; a class with fewer than ``min_count`` poses
    gets no mixture. A mirrored supine fit counts each pose twice, so its components keep at least
    twice ``min_count`` points."""
    pose = np.asarray(pose, dtype=np.float64)
    posture = np.asarray(posture)
    if pose.ndim != 2 or pose.shape[1] != 3 * NUM_JOINTS or posture.shape != (len(pose),):
        raise BadInput(f"poses {pose.shape} and postures {posture.shape}; expected (N, 72) and (N,)")
    used = np.isin(posture, GROUPS)
    if not used.any():
        raise BadInput(f"no pose has a posture of {', '.join(GROUPS)}")
    held = pose[used, 3:].std(axis=0) < HELD_SD_RAD
    dims = np.flatnonzero(~held)
    mixtures, counts = {}, {}
    for group in GROUPS:
        x = pose[posture == group]
        counts[group] = len(x)
        least = settings.min_count
        if len(x) < least:
            continue
        if group == "supine" and settings.mirror_supine:
            # each pose comes twice (itself, its mirror): twice the points keep min_count poses apiece
            x, least = np.concatenate([x, mirror_poses(x)]), 2 * least
        fits = [fit_mixture(x[:, 3:][:, dims], settings.components, np.radians(settings.reg_deg) ** 2,
                            seed=settings.seed + k, min_count=least) for k in range(settings.restarts)]
        mixtures[group] = max(fits, key=lambda m: float(m.log_density(x[:, 3:][:, dims]).mean()))
    record = json.dumps({k: getattr(settings, k) for k in settings.__dataclass_fields__}, sort_keys=True)
    return NaturalPoses(mixtures, dims, {g: counts[g] for g in mixtures}, f"{fitted_to} {record}".strip())
