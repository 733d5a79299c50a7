"""What a dataset holds: the per-sample record and the configuration that produced it.

A labelled sample (:class:`Sample`), in the bed frame (metres, z up; origin at the head-end corner of
the mat's sensing area on the unloaded mattress top; x across the bed along the mat's columns, y
toward the foot along its rows, row 0 at the head):

============== =============== ===========================================================
field          shape / type    meaning
============== =============== ===========================================================
``pressure``   (R, C) float32  pressure per taxel, mmHg
``force``      (R, C) float32  normal force per taxel, N
``depth``      (R, C) float32  height of the body's lowest surface over each taxel above the
                               unloaded mattress top, m (negative = sunk into the mattress,
                               the sign of PressurePose's ``mesh_depth``; +1 m where no body
                               is above, as ``pressurepose.sim.press`` reports it)
``contact``    (R, C) bool     taxel touched by the body (``depth < 0``)
``betas``      (10,) float32   body shape
``pose``       (72,) float32   SMPL-order axis-angle, root orientation first, rad
``transl``     (3,) float32    the body model's translation: ``BodyModel.forward(betas, pose,
                               transl)`` puts the body where it lies, m
``joints``     (24, 3) float32 joint positions, m
``gender``     str             ``"f"`` or ``"m"``
``mass``       float           kg
``height``     float           m
``partition``  str             one of :data:`PARTITIONS`
``index``      int             sample index within its dataset (set by the pipeline)
``conditions`` (7,) float32    only in randomised datasets: the bed the sample was pressed on
                               (``pressurepose.sim.randomize.CONDITION_NAMES``); else None
``sites``      (R, C) int8     the body site that carried each taxel's force, as an index into
                               ``pressurepose.body.sites.SITES`` (-1: no body force on the taxel);
                               None in datasets made before it was recorded and in
                               samples that were not pressed (the synthetic producer)
============== =============== ===========================================================

A dataset on disk is a pure function of its :class:`GenerationConfig`: see ``pipeline.py``.
"""

from __future__ import annotations

import hashlib
import json
from dataclasses import asdict, dataclass, field, fields
from functools import lru_cache
from typing import Any

import numpy as np

from pressurepose.errors import BadInput, require_between, require_whole
from pressurepose.mat import MATS, MatSpec, get_mat
from pressurepose.pose.partitions import PARTITIONS as _POSE_PARTITIONS
from pressurepose.pose.partitions import get_partition

# The paper's partitions (appendix A.7; defined in pressurepose.pose.partitions): general,
# general_supine, hands_behind_head, prone_hands_up, supine_crossed_legs, supine_straight_limbs.
PARTITIONS: tuple[str, ...] = tuple(_POSE_PARTITIONS)
GENDERS: tuple[str, ...] = ("f", "m")
NUM_BETAS = 10
NUM_JOINTS = 24
POSE_SIZE = 72
MAX_COUNT = 10_000_000  # samples per dataset

IMAGE_FIELDS: tuple[str, ...] = ("pressure", "force", "depth", "contact")
LABEL_FIELDS: tuple[str, ...] = ("betas", "pose", "transl", "joints", "mass", "height")
# float arrays of a sample, with their per-sample shapes ((R, C) images resolved per mat)
_LABEL_SHAPES: dict[str, tuple[int, ...]] = {
    "betas": (NUM_BETAS,), "pose": (POSE_SIZE,), "transl": (3,), "joints": (NUM_JOINTS, 3),
    "mass": (), "height": (),
}


def check_partition(name: str) -> str:
    """The partition's name (aliases such as ``supine`` resolved), else BadInput listing the known ones."""
    return get_partition(name).name


def check_gender(gender: str) -> str:
    """'f' / 'female' -> 'f', 'm' / 'male' -> 'm'; BadInput otherwise."""
    g = {"f": "f", "female": "f", "m": "m", "male": "m"}.get(str(gender).strip().lower())
    if g is None:
        raise BadInput(f"gender {gender!r} is not known; expected f or m")
    return g


@dataclass(frozen=True, eq=False)
class Sample:
    """One labelled pressure image (see the module docstring for fields, shapes and units)."""

    pressure: np.ndarray
    force: np.ndarray
    depth: np.ndarray
    contact: np.ndarray
    betas: np.ndarray
    pose: np.ndarray
    transl: np.ndarray
    joints: np.ndarray
    gender: str
    mass: float
    height: float
    partition: str
    index: int = -1
    conditions: np.ndarray | None = None
    sites: np.ndarray | None = None

    def validate(self, shape: tuple[int, int] | None = None, *, what: str = "sample") -> "Sample":
        """Check shapes, dtypes and finiteness; return self. ``shape`` is the mat's (rows, cols).

        Raises BadInput naming the field and what was expected.
        """
        img_shape = shape or np.shape(self.pressure)
        if len(img_shape) != 2:
            raise BadInput(f"{what}: pressure has shape {np.shape(self.pressure)}; expected (rows, cols)")
        for name in IMAGE_FIELDS:
            arr = np.asarray(getattr(self, name))
            if arr.shape != tuple(img_shape):
                raise BadInput(f"{what}: {name} has shape {arr.shape}; the mat is "
                               f"{img_shape[0]} x {img_shape[1]}")
        for name, shp in _LABEL_SHAPES.items():
            arr = np.asarray(getattr(self, name))
            if arr.shape != shp:
                raise BadInput(f"{what}: {name} has shape {arr.shape}; expected {shp}")
        for name in ("pressure", "force", "depth", *_LABEL_SHAPES):
            if not np.all(np.isfinite(np.asarray(getattr(self, name), dtype=np.float64))):
                raise BadInput(f"{what}: {name} contains NaN or infinite values")
        if np.any(np.asarray(self.pressure) < 0) or np.any(np.asarray(self.force) < 0):
            raise BadInput(f"{what}: pressure and force must be >= 0")
        if self.conditions is not None:
            c = np.asarray(self.conditions, dtype=np.float64)
            if c.shape != (7,) or not np.all(np.isfinite(c)):
                raise BadInput(f"{what}: conditions has shape {c.shape}; expected 7 finite values")
        if self.sites is not None:
            from pressurepose.body.sites import SITES

            s = np.asarray(self.sites)
            if s.shape != tuple(img_shape) or s.dtype.kind not in "iu" or (s.size and not (
                    s.min() >= -1 and s.max() < len(SITES))):
                raise BadInput(f"{what}: sites has shape {s.shape} and dtype {s.dtype}; expected {tuple(img_shape)} "
                               f"integers from -1 (no body) to {len(SITES) - 1} (indices into the body sites)")
        check_gender(self.gender)
        check_partition(self.partition)
        return self


def _freeze_options(options: Any) -> tuple[tuple[str, Any], ...]:
    if options is None:
        return ()
    items = list(options.items()) if isinstance(options, dict) else options
    if not (isinstance(items, (list, tuple)) and all(isinstance(i, (list, tuple)) and len(i) == 2 for i in items)):
        raise BadInput(f"options = {options!r:.80}; expected a dict of producer settings (name -> string, number or "
                       f"bool)")
    out = []
    for key, value in items:
        if not isinstance(value, (str, int, float, bool)):
            raise BadInput(f"producer option {key!r} = {value!r}: expected a string, number or bool")
        out.append((str(key), value))
    return tuple(sorted(out))


# The paper's pose sampler without randomisation: what made the paper's released data (its
# converted datasets carry these settings), and the reference of :attr:`GenerationConfig.stream_key`,
# which mixes in only the settings that differ from it. Its spreads (0.03 m) are the reference
# 'centred' configs' spreads are compared with; the paper's uniform placement does not use them.
PAPER_SAMPLING: dict[str, Any] = {"shapes": "uniform", "placement": "uniform", "hanging_limbs": True,
                                  "randomize": False, "across_sd_m": 0.03, "across_sd_lateral_m": 0.03,
                                  "height_reference": "proximal"}


@lru_cache(maxsize=16)
def _bed_spec(bed: str, mat: str):
    from pressurepose.sim.bed import BedSpec, get_bed

    return BedSpec.from_dict(json.loads(bed)) if bed else get_bed(mat)


def _json_record(value, name: str, what: str):
    """``value`` parsed when it is a JSON string, else as given; BadInput naming ``name`` when the
    string is not JSON (``what``: the record it should hold)."""
    if not isinstance(value, str):
        return value
    try:
        return json.loads(value)
    except json.JSONDecodeError as exc:
        raise BadInput(f"{name} is not a JSON {what} ({exc})") from None


def _canonical_mat_bed(mat: str, bed) -> tuple[str, str]:
    """(mat name, canonical JSON of the bed record) of a config: ``bed`` a JSON string or dict of
    ``BedSpec.to_dict`` ("" for the mat preset's default bed). A bed on a mat preset must carry it
    unchanged; a mat that is no preset (any grid, ``pressurepose.mat.custom_mat``) comes with its
    bed, and ``mat`` then names the bed's mat."""
    from pressurepose.sim.bed import BedSpec

    if bed is None or bed == "":
        return get_mat(mat).name, ""
    spec = BedSpec.from_dict(_json_record(bed, "bed", "bed record"))
    record = json.dumps(spec.to_dict(), sort_keys=True)
    if str(mat).strip().lower() in MATS:
        if spec.mat != get_mat(mat):
            raise BadInput(f"the bed's mat ({spec.mat.name}, {spec.mat.rows} x {spec.mat.cols}) is not the preset "
                           f"{mat!r}; a dataset's bed must carry its mat preset unchanged")
        return get_mat(mat).name, record
    if spec.mat.name.lower() in MATS:
        raise BadInput(f"the bed's mat is named {spec.mat.name!r} but is not that preset; give it a name of its own")
    if mat != spec.mat.name:
        raise BadInput(f"mat {mat!r} is neither a preset ({', '.join(sorted(MATS))}) nor the name of the bed's mat "
                       f"({spec.mat.name!r})")
    return spec.mat.name, record


def _canonical_poses(poses) -> str:
    """The canonical JSON of a pose file record (a PoseFile, its dict or JSON; None or "" for none)."""
    from pressurepose.pose.posefile import PoseFile

    if poses is None or poses == "":
        return ""
    poses = _json_record(poses, "poses", "pose file record")
    record = poses if isinstance(poses, PoseFile) else PoseFile.from_dict(poses)
    return json.dumps(asdict(record), sort_keys=True)


@dataclass(frozen=True)
class GenerationConfig:
    """Everything that decides a dataset's content; saved in its manifest.

    partition, gender ('f' | 'm'), limbs_on_bed (the paper's "plo": limbs start over the bed),
    count (samples), seed; mat (the mat's name: a preset, or with ``bed`` the name of the bed's mat,
    which may be any grid; :attr:`grid` is the mat itself); shard_size (samples per file; ``pressurepose
    generate`` gives a new dataset 64, a script's config without it has 256); producer (name in
    ``pressurepose.data.producers.PRODUCERS`` or ``"module:function"``); max_attempts (tries per
    sample before the run fails); options (producer-specific settings, str -> str/number/bool).
    shapes, placement, across_sd_m, across_sd_lateral_m, hanging_limbs: the pose sampler's
    body-shape distribution, placement on the bed, its spread across the bed for supine or prone
    and for lateral bodies (m, 'centred' only) and hanging-limbs rule
    (:class:`~pressurepose.pose.config.SamplerConfig`; defaults: SMPL's shape population, bodies
    centred as people lie, 3 and 8 cm spreads, no limb over the edge). height_reference: what the
    sampler's ankle and wrist start heights are measured from ('proximal', the default, the paper's
    public code's rule: their hip's or shoulder's height; 'bed': the surface the body lies on, which keeps
    more side-lying bodies on their side). randomize: draw the
    bed's, tissue's and sensor's constants and the mat's placement per sample
    (:mod:`pressurepose.sim.randomize`). bed: the bed the bodies lie on, as the canonical JSON
    of a :meth:`~pressurepose.sim.bed.BedSpec.to_dict` record (e.g. one fitted by ``pressurepose
    calibrate``; its mat must be the preset ``mat`` or, for a mat that is no preset, be named ``mat``),
    or "" for the mat preset's default bed; it
    does not change which bodies are drawn, so two beds with one seed give paired datasets. settle:
    how bodies come to rest (:data:`pressurepose.sim.settle_config.SETTLES`: 'relaxed', the default, or
    'paper', the paper's joint springs); like the bed it changes no draw. The saved record
    (:meth:`to_dict`) leaves out the bed, the settle and the height reference at their defaults, and
    poses when unset.
    poses: "" (default: the partition's own draws) or the canonical JSON of a
    :class:`~pressurepose.pose.posefile.PoseFile` record (path, sha256, frame, noise_deg): every body
    takes its pose from that file (:mod:`pressurepose.pose.whole`); the file must stay where it was,
    unchanged, for the dataset to resume (every worker, Ray nodes too, reads it at that path).

    Sample ``i`` depends only on (seed, partition, gender, limbs_on_bed, the sampler and
    randomisation settings, i) for its random draws, so ``count`` and ``shard_size`` do not change it.
    """

    partition: str
    gender: str
    limbs_on_bed: bool = False
    count: int = 1000
    seed: int = 0
    mat: str = "boditrak_bt3510"
    shard_size: int = 256
    producer: str = "physics"
    max_attempts: int = 200
    options: tuple[tuple[str, Any], ...] = field(default_factory=tuple)
    shapes: str = "normal"
    placement: str = "centred"
    hanging_limbs: bool = False
    randomize: bool = False
    across_sd_m: float = 0.03
    across_sd_lateral_m: float = 0.08
    bed: str = ""
    settle: str = "relaxed"
    poses: str = ""
    height_reference: str = "proximal"

    def __post_init__(self):
        object.__setattr__(self, "partition", check_partition(self.partition))
        object.__setattr__(self, "gender", check_gender(self.gender))
        object.__setattr__(self, "options", _freeze_options(self.options))
        for name in ("count", "shard_size", "max_attempts"):
            require_whole(name, getattr(self, name), 1)
        if self.count > MAX_COUNT:
            raise BadInput(f"count = {self.count}; at most {MAX_COUNT} samples per dataset (the paper's whole "
                           f"mix is 206,000): split it into several datasets with different seeds")
        require_whole("seed", self.seed, 0)
        for name in ("limbs_on_bed", "hanging_limbs", "randomize"):
            if not isinstance(getattr(self, name), (bool, np.bool_)):
                raise BadInput(f"{name} = {getattr(self, name)!r}; expected true or false")
            object.__setattr__(self, name, bool(getattr(self, name)))
        from pressurepose.pose.config import HEIGHT_REFERENCES, PLACEMENTS, SHAPES

        if self.shapes not in SHAPES:
            raise BadInput(f"shapes = {self.shapes!r}; expected one of {', '.join(SHAPES)}")
        if self.placement not in PLACEMENTS:
            raise BadInput(f"placement = {self.placement!r}; expected one of {', '.join(PLACEMENTS)}")
        if self.height_reference not in HEIGHT_REFERENCES:
            raise BadInput(f"height_reference = {self.height_reference!r}; expected one of "
                           f"{', '.join(HEIGHT_REFERENCES)}")
        for name in ("across_sd_m", "across_sd_lateral_m"):
            require_between(f"{name} (a spread in metres)", getattr(self, name), 0, 0.5)
            object.__setattr__(self, name, float(getattr(self, name)))
        from pressurepose.sim.settle_config import SETTLES

        if self.settle not in SETTLES:
            raise BadInput(f"settle = {self.settle!r}; expected one of {', '.join(SETTLES)}")
        mat, bed = _canonical_mat_bed(self.mat, self.bed)
        object.__setattr__(self, "mat", mat)
        object.__setattr__(self, "bed", bed)
        object.__setattr__(self, "poses", _canonical_poses(self.poses))
        if not isinstance(self.producer, str) or not self.producer:
            raise BadInput(f"producer = {self.producer!r}; expected a producer name")

    # ---------------------------------------------------------------- derived
    def pose_file(self):
        """The :class:`~pressurepose.pose.posefile.PoseFile` bodies take their poses from, or None."""
        from pressurepose.pose.posefile import PoseFile

        return PoseFile.from_dict(json.loads(self.poses)) if self.poses else None

    def bed_spec(self):
        """The :class:`~pressurepose.sim.bed.BedSpec` the bodies lie on (``bed``, or the mat's default bed)."""
        return _bed_spec(self.bed, self.mat)

    @property
    def grid(self) -> MatSpec:
        """The mat the images are on: the bed's (a preset, or any grid that came with the bed)."""
        return self.bed_spec().mat if self.bed else get_mat(self.mat)

    @property
    def option_dict(self) -> dict[str, Any]:
        return dict(self.options)

    def option(self, key: str, default: Any = None) -> Any:
        return self.option_dict.get(key, default)

    @property
    def num_shards(self) -> int:
        return -(-self.count // self.shard_size)

    def shard_range(self, shard: int) -> range:
        """Sample indices of shard ``shard``."""
        start = shard * self.shard_size
        return range(start, min(start + self.shard_size, self.count))

    @property
    def stream_key(self) -> int:
        """32-bit key of (partition, gender, limbs_on_bed and the sampler and randomisation settings
        where they differ from :data:`PAPER_SAMPLING`) mixed into every sample's seed, so that two
        partitions or samplers run with the same seed draw different bodies."""
        text = f"{self.partition}|{self.gender}|{int(bool(self.limbs_on_bed))}"
        extra = [f"{k}={getattr(self, k)}" for k in PAPER_SAMPLING if getattr(self, k) != PAPER_SAMPLING[k]
                 and not (k.startswith("across_sd") and self.placement != "centred")]  # spreads only 'centred' uses
        if extra:
            text += "|" + "|".join(extra)
        return int.from_bytes(hashlib.sha256(text.encode()).digest()[:4], "little")

    # ---------------------------------------------------------------- serialising
    def to_dict(self) -> dict[str, Any]:
        d = asdict(self)
        d["options"] = dict(self.options)
        d["limbs_on_bed"] = bool(self.limbs_on_bed)
        if self.bed:
            d["bed"] = json.loads(self.bed)
        else:
            del d["bed"]  # the default bed and settle are left out of the record and so of the digest
        if self.settle == "relaxed":
            del d["settle"]  # likewise the default settle
        if self.poses:
            d["poses"] = json.loads(self.poses)
        else:
            del d["poses"]  # likewise no pose file
        if self.height_reference == "proximal":
            del d["height_reference"]  # likewise the default height reference
        return d

    def to_json(self) -> str:
        return json.dumps(self.to_dict(), sort_keys=True)

    @property
    def digest(self) -> str:
        """sha256 of the canonical JSON: the dataset's identity."""
        return hashlib.sha256(self.to_json().encode()).hexdigest()

    @classmethod
    def from_dict(cls, d: dict[str, Any], *, what: str = "config") -> "GenerationConfig":
        if not isinstance(d, dict):
            raise BadInput(f"{what}: expected a JSON object, got {type(d).__name__}")
        known = {f.name for f in fields(cls)}
        unknown = sorted(set(d) - known)
        if unknown:
            raise BadInput(f"{what}: unknown keys {', '.join(unknown)}; expected some of {', '.join(sorted(known))}")
        # to_dict leaves out the bed, the settle, the pose file and the height reference at their defaults
        missing = sorted(known - set(d) - {"bed", "settle", "poses", "height_reference"})
        if missing:
            raise BadInput(f"{what}: lacks {', '.join(missing)}; a dataset's config records every setting "
                           f"(the bed, the settle, a pose file and the height reference only when not the "
                           f"defaults)")
        d = dict(d)
        if isinstance(d.get("bed"), dict):
            d["bed"] = json.dumps(d["bed"], sort_keys=True)
        if isinstance(d.get("poses"), dict):
            d["poses"] = json.dumps(d["poses"], sort_keys=True)
        try:
            return cls(**d)
        except TypeError as exc:
            raise BadInput(f"{what}: {exc}") from None

    @classmethod
    def from_json(cls, text: str, *, what: str = "config") -> "GenerationConfig":
        try:
            return cls.from_dict(json.loads(text), what=what)
        except json.JSONDecodeError as exc:
            raise BadInput(f"{what}: not valid JSON ({exc})") from None
