"""The official PressurePose release (Bodies at Rest): read its pickles, convert them to this project's
datasets, and export ours back to its format.

Synthetic files are Python-2 pickles of a dict of per-sample lists (the release's layout): ``images``
(N x 1728, a 64 x 27 image row-major, mmHg), ``markers_xyz_m`` (N x 72, 24 joints), ``root_xyz_shift``
(N x 3, root joint position), ``joint_angles`` (N x 72, SMPL axis-angle), ``body_shape`` (N x 10),
``body_mass`` (kg), ``body_height`` (m), ``bed_angle_deg``, ``mesh_depth`` (N x 64 x 27 int, mm)
and ``mesh_contact``. Real-data folders (one per participant, e.g. ``S103``) hold
``participant_info_red.p`` (``gender``, ``height_in``, ``weight_lbs``), ``prescribed.p`` and
``p_select.p`` (``images``, ``RGB``, ``depth``, ``pc``, ``pmat_corners``).

Every pickle is read by :class:`ArrayUnpickler`, which builds numpy arrays and plain Python values
and refuses any other class, so a crafted file cannot run code.

Their frame and ours. Their x runs along the image columns and y along the rows toward the HEAD,
z up, with the origin 10 taxels (0.286 m) outside the mat's corner on both axes: taxel column c
covers x in [(c + 10), (c + 11)) * 0.0286 m and image row r covers y in [(73 - r), (74 - r)) * 0.0286 m
(their mesh-depth code). An SMPL body with zero root rotation lies supine with its head at row 0 and
its LEFT side toward higher columns. In our bed frame (y toward the foot, z up, right-handed) a supine
body with its head at row 0 has its left side toward LOWER columns, so their images are mirror
images of ours. The map is therefore a rotation by 180 degrees about the vertical, not a shift:

    ours (x, y, z) = (37 p - x, 74 p - y, z),  p = 0.0286 m;  image_ours = image_theirs[:, ::-1]

which is its own inverse. Poses: joint rotations are SMPL-native in both; the root rotation becomes
``R_ours = Q^T Rz(pi) R_theirs`` with ``Q = Y_UP_TO_Z_UP`` (our body model's output rotation), and
``transl`` is chosen so that our body model puts the root joint where theirs was. ``mesh_depth``
(mm) becomes ``depth`` (m); their 0 for "no body here" is kept as 0 (they do not mark empty
taxels), and our +1 m "empty" becomes 0 on export. ``force`` is pressure x taxel area.
"""

from __future__ import annotations

import io
import pickle
import re
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, Sequence

import numpy as np

from pressurepose.body.lbs_numpy import Y_UP_TO_Z_UP, rodrigues, rotation_to_axis_angle
from pressurepose.data.resample import MMHG_PA
from pressurepose.data.schema import (
    PAPER_SAMPLING,
    PARTITIONS,
    GenerationConfig,
    Sample,
    check_gender,
    check_partition,
)
from pressurepose.data.store import Manifest, write_dataset
from pressurepose.errors import BadInput
from pressurepose.files import write_bytes_atomic
from pressurepose.mat import get_mat

PITCH = 0.0286          # their taxel spacing (INTER_SENSOR_DISTANCE), m
ORIGIN_TAXELS = 10      # their origin lies this many taxels outside the mat corner
ROWS, COLS = 64, 27
SYNTHETIC_KEYS = ("images", "markers_xyz_m", "root_xyz_shift", "joint_angles", "body_shape", "body_mass",
                  "body_height", "bed_angle_deg", "mesh_depth", "mesh_contact")
_RZ_PI = np.diag([-1.0, -1.0, 1.0])
_CENTER2 = np.array([(COLS + ORIGIN_TAXELS) * PITCH, (ROWS + ORIGIN_TAXELS) * PITCH, 0.0])


# --------------------------------------------------------------------------- safe unpickling


def _numpy_reconstruct():
    try:
        from numpy._core.multiarray import _reconstruct
    except ImportError:  # numpy < 2
        from numpy.core.multiarray import _reconstruct
    return _reconstruct


def _numpy_scalar():
    try:
        from numpy._core.multiarray import scalar
    except ImportError:  # numpy < 2
        from numpy.core.multiarray import scalar
    return scalar


class UnsafePickle(pickle.UnpicklingError):
    """The pickle asked for something other than arrays and plain values."""


def _latin1_bytes(text, encoding="latin1"):
    """Stand-in for ``_codecs.encode``, which Python 3 protocol-2 pickles use for bytes: latin-1 only."""
    if not isinstance(text, str) or encoding.lower().replace("-", "") != "latin1":
        raise UnsafePickle("refusing _codecs.encode other than str -> latin-1 bytes")
    return text.encode("latin1")


_ALLOWED = {
    ("_codecs", "encode"): lambda: _latin1_bytes,
    ("numpy.core.multiarray", "_reconstruct"): _numpy_reconstruct,
    ("numpy._core.multiarray", "_reconstruct"): _numpy_reconstruct,
    ("numpy.core.multiarray", "scalar"): _numpy_scalar,
    ("numpy._core.multiarray", "scalar"): _numpy_scalar,
    ("numpy", "ndarray"): lambda: np.ndarray,
    ("numpy", "dtype"): lambda: np.dtype,
}


class ArrayUnpickler(pickle.Unpickler):
    """Unpickles numpy arrays, numpy scalars and plain Python containers and values; nothing else."""

    def find_class(self, module: str, name: str):
        make = _ALLOWED.get((module, name))
        if make is None:
            raise UnsafePickle(f"refusing to load global {module}.{name}")
        return make()


def load_pickle(path: str | Path) -> Any:
    """Read a (Python 2 or 3) pickle of arrays safely; BadInput for unsafe, corrupt or missing files."""
    path = Path(path)
    try:
        data = path.read_bytes()
    except OSError as exc:
        raise BadInput(f"pickle {path}: cannot read ({exc.strerror or exc})") from None
    try:
        return ArrayUnpickler(io.BytesIO(data), encoding="latin1").load()
    except UnsafePickle as exc:
        raise BadInput(f"pickle {path}: unsafe, refused ({exc})") from None
    except (pickle.UnpicklingError, EOFError, ValueError, TypeError, AttributeError, IndexError, KeyError, MemoryError) as exc:
        raise BadInput(f"pickle {path}: corrupt or truncated ({type(exc).__name__}: {exc})") from None


# --------------------------------------------------------------------------- frames


def their_points_to_bed(points: np.ndarray) -> np.ndarray:
    """(..., 3) points in their frame -> our bed frame (and back: the map is its own inverse)."""
    p = np.asarray(points, dtype=np.float64)
    return np.concatenate([_CENTER2[:2] - p[..., :2], p[..., 2:3]], axis=-1)


bed_points_to_theirs = their_points_to_bed


def their_image_to_ours(images: np.ndarray) -> np.ndarray:
    """(..., 64, 27) images in their column order -> ours (a left-right flip; its own inverse)."""
    return np.asarray(images)[..., ::-1]


def their_root_to_ours(root_aa: np.ndarray) -> np.ndarray:
    """(..., 3) root axis-angle in their frame -> ours."""
    R = rodrigues(root_aa)
    return rotation_to_axis_angle(Y_UP_TO_Z_UP.T @ _RZ_PI @ R)


def our_root_to_theirs(root_aa: np.ndarray) -> np.ndarray:
    R = rodrigues(root_aa)
    return rotation_to_axis_angle(_RZ_PI @ Y_UP_TO_Z_UP @ R)


# --------------------------------------------------------------------------- synthetic files


def infer_labels(path: str | Path) -> dict[str, Any]:
    """Partition, gender and limbs_on_bed from a release file name such as
    ``train_roll0_plo_hbh_f_lay_set1to2_2000.p`` (what cannot be told is left out)."""
    tokens = set(re.split(r"[_\-.]", Path(path).name.lower()))
    out: dict[str, Any] = {"limbs_on_bed": "plo" in tokens}
    for tok, g in (("f", "f"), ("m", "m")):
        if tok in tokens:
            out["gender"] = g
    for tok, part in (("hbh", "hands_behind_head"), ("phu", "prone_hands_up"), ("xl", "supine_crossed_legs"),
                      ("sl", "supine_straight_limbs")):
        if tok in tokens:
            out["partition"] = part
    if "partition" not in out:
        if "rollpi" in tokens:
            out["partition"] = "general"
        elif "roll0" in tokens:
            out["partition"] = "general_supine"
    return out


def read_synthetic(path: str | Path) -> dict[str, np.ndarray]:
    """A synthetic release file as a dict of stacked arrays (their frame, their units), checked."""
    raw = load_pickle(path)
    if not isinstance(raw, dict):
        raise BadInput(f"{path}: holds {type(raw).__name__}; expected a dict of per-sample lists")
    need = ("images", "markers_xyz_m", "root_xyz_shift", "joint_angles", "body_shape", "body_mass", "body_height")
    missing = [k for k in need if k not in raw]
    if missing:
        raise BadInput(f"{path}: missing keys {', '.join(missing)}; expected {', '.join(SYNTHETIC_KEYS)}")
    shapes = {"images": (ROWS * COLS,), "markers_xyz_m": (72,), "root_xyz_shift": (3,), "joint_angles": (72,),
              "body_shape": (10,), "body_mass": (), "body_height": (), "bed_angle_deg": (),
              "mesh_depth": (ROWS, COLS), "mesh_contact": (ROWS, COLS)}
    out, n = {}, len(raw["images"])
    for key, shape in shapes.items():
        if key not in raw:
            continue
        try:
            arr = np.asarray(raw[key], dtype=np.float64)
        except (ValueError, TypeError):
            raise BadInput(f"{path}: {key} is not a list of equal-sized numeric arrays") from None
        if arr.ndim == 0 or len(arr) != n or arr[0].size != int(np.prod(shape)):
            raise BadInput(f"{path}: {key} has shape {arr.shape}; expected {(n,) + shape}")
        arr = arr.reshape((n,) + shape)
        if not np.all(np.isfinite(arr)):
            raise BadInput(f"{path}: {key} contains NaN or infinite values")
        out[key] = arr
    return out


def synthetic_to_samples(raw: dict[str, np.ndarray], *, gender: str, partition: str, body) -> list[Sample]:
    """Our samples (bed frame, our image orientation) from :func:`read_synthetic` arrays.

    body: a :class:`pressurepose.body.BodyModel` used to express the root position as our ``transl``.
    """
    mat = get_mat("boditrak_bt3510")
    n = len(raw["images"])
    pressure = their_image_to_ours(np.clip(raw["images"].reshape(n, ROWS, COLS), 0, None))
    if "mesh_depth" in raw:
        depth = their_image_to_ours(raw["mesh_depth"]) / 1000.0
    else:
        depth = np.zeros_like(pressure)
    contact = their_image_to_ours(raw["mesh_contact"] > 0) if "mesh_contact" in raw else depth < 0
    joints = their_points_to_bed(raw["markers_xyz_m"].reshape(n, 24, 3))
    root = their_points_to_bed(raw["root_xyz_shift"])
    pose = raw["joint_angles"].copy()
    pose[:, :3] = their_root_to_ours(pose[:, :3])
    betas = raw["body_shape"]
    _, rest_joints = body.rest(betas[:, :body.num_betas])
    transl = root - rest_joints[:, 0]
    f32 = np.float32
    return [Sample(pressure=pressure[i].astype(f32), force=(pressure[i] * MMHG_PA * mat.taxel_area_m2).astype(f32),
                   depth=depth[i].astype(f32), contact=contact[i].astype(bool), betas=betas[i].astype(f32),
                   pose=pose[i].astype(f32), transl=transl[i].astype(f32), joints=joints[i].astype(f32),
                   gender=gender, mass=float(raw["body_mass"][i]), height=float(raw["body_height"][i]),
                   partition=partition, index=i)
            for i in range(n)]


def convert_synthetic(path: str | Path, out: str | Path, *, body=None, partition: str | None = None,
                      gender: str | None = None, limbs_on_bed: bool | None = None,
                      shard_size: int = 256) -> Manifest:
    """Convert one synthetic release file into a dataset directory ``out`` (new or empty).

    partition, gender and limbs_on_bed default to what the file name says (:func:`infer_labels`);
    body defaults to the shipped model of that gender. The manifest's producer records the source.
    """
    from pressurepose.body import BodyModel

    out = Path(out)
    if out.exists() and any(out.iterdir()):
        raise BadInput(f"{out} is not empty; nothing was written (choose a new directory)")
    guess = infer_labels(path)
    partition = partition or guess.get("partition")
    gender = gender or guess.get("gender")
    if partition is None or gender is None:
        what = "partition" if partition is None else "gender"
        raise BadInput(f"{path}: cannot tell the {what} from the file name; give it with --{what} "
                       f"({', '.join(PARTITIONS) if what == 'partition' else 'f or m'})")
    partition, gender = check_partition(partition), check_gender(gender)
    plo = guess["limbs_on_bed"] if limbs_on_bed is None else bool(limbs_on_bed)
    raw = read_synthetic(path)
    body = body or BodyModel(gender)
    samples = synthetic_to_samples(raw, gender=gender, partition=partition, body=body)
    config = GenerationConfig(partition=partition, gender=gender, limbs_on_bed=plo, count=len(samples),
                              shard_size=shard_size, producer=f"converted:pressurepose:{Path(path).name}",
                              **PAPER_SAMPLING)  # the paper's sampler made the release
    return write_dataset(out, config, samples)


def samples_to_synthetic(samples: Sequence[Sample]) -> dict[str, list]:
    """Our samples (BodiTrak 64 x 27 mat) as a release-format dict of per-sample lists."""
    out: dict[str, list] = {k: [] for k in SYNTHETIC_KEYS}
    for s in samples:
        if np.shape(s.pressure) != (ROWS, COLS):
            raise BadInput(f"sample {s.index}: pressure is {np.shape(s.pressure)}; the release format is "
                           f"{ROWS} x {COLS} (resample to boditrak_bt3510 first)")
        pose = np.asarray(s.pose, dtype=np.float64).copy()
        pose[:3] = our_root_to_theirs(pose[:3])
        depth_mm = np.where(np.asarray(s.depth) >= 1.0, 0.0, np.asarray(s.depth, dtype=np.float64) * 1000.0)
        out["images"].append(their_image_to_ours(np.asarray(s.pressure, np.float64)).reshape(-1).copy())
        out["markers_xyz_m"].append(bed_points_to_theirs(s.joints).reshape(-1))
        out["root_xyz_shift"].append(bed_points_to_theirs(np.asarray(s.joints)[0]))
        out["joint_angles"].append(pose)
        out["body_shape"].append(np.asarray(s.betas, np.float64))
        out["body_mass"].append(float(s.mass))
        out["body_height"].append(float(s.height))
        out["bed_angle_deg"].append(0.0)
        out["mesh_depth"].append(their_image_to_ours(np.rint(depth_mm).astype(np.int32)).copy())
        out["mesh_contact"].append(their_image_to_ours(np.asarray(s.contact)).astype(np.int32).copy())
    return out


def export_synthetic(samples: Sequence[Sample], path: str | Path) -> Path:
    """Write samples as a release-format pickle (protocol 2, readable by their Python 2 code)."""
    path = Path(path)
    write_bytes_atomic(path, pickle.dumps(samples_to_synthetic(samples), protocol=2))
    return path


# --------------------------------------------------------------------------- real data


@dataclass
class RealRecording:
    """One pose set of one participant (``prescribed`` or ``p_select``).

    pressure: (N, 64, 27) mmHg in OUR image orientation. point_clouds, rgb, depth_images,
    pmat_corners: as released (their camera / render frames; see the module docstring).
    """

    pressure: np.ndarray
    point_clouds: list[np.ndarray] = field(default_factory=list)
    rgb: list[np.ndarray] = field(default_factory=list)
    depth_images: list[np.ndarray] = field(default_factory=list)
    pmat_corners: list[np.ndarray] = field(default_factory=list)


@dataclass
class RealParticipant:
    name: str
    gender: str
    mass: float     # kg
    height: float   # m
    recordings: dict[str, RealRecording]


def read_real_participant(folder: str | Path, pose_types: Sequence[str] = ("prescribed", "p_select")) -> RealParticipant:
    """One participant's folder of the real release."""
    folder = Path(folder)
    if not folder.is_dir():
        raise BadInput(f"real-data folder {folder} does not exist")
    info = load_pickle(folder / "participant_info_red.p")
    if not isinstance(info, dict) or not {"gender", "height_in", "weight_lbs"} <= set(info):
        raise BadInput(f"{folder / 'participant_info_red.p'}: expected a dict with gender, height_in, weight_lbs")
    recordings = {}
    for kind in pose_types:
        path = folder / f"{kind}.p"
        if not path.exists():
            continue
        dat = load_pickle(path)
        if not isinstance(dat, dict) or "images" not in dat:
            raise BadInput(f"{path}: expected a dict with 'images'")
        try:
            images = np.asarray(dat["images"], dtype=np.float64).reshape(-1, ROWS, COLS)
        except ValueError:
            raise BadInput(f"{path}: images are not {ROWS} x {COLS} = {ROWS * COLS} taxels each") from None
        recordings[kind] = RealRecording(
            pressure=their_image_to_ours(np.clip(images, 0, None)).astype(np.float32),
            point_clouds=[np.asarray(p, np.float64) for p in dat.get("pc", [])],
            rgb=[np.asarray(p) for p in dat.get("RGB", [])],
            depth_images=[np.asarray(p) for p in dat.get("depth", [])],
            pmat_corners=[np.asarray(p, np.float64) for p in dat.get("pmat_corners", [])])
    if not recordings:
        raise BadInput(f"{folder} has none of {', '.join(f'{k}.p' for k in pose_types)}")
    return RealParticipant(name=folder.name, gender=check_gender(str(info["gender"])),
                           mass=float(info["weight_lbs"]) * 0.45359237, height=float(info["height_in"]) * 0.0254,
                           recordings=recordings)


def save_real_hdf5(participant: RealParticipant, path: str | Path) -> Path:
    """Write a participant's pressure images (our orientation), body facts and point clouds
    (as released, concatenated with per-image offsets) to one HDF5 file, atomically."""
    import h5py

    buf = io.BytesIO()
    with h5py.File(buf, "w") as f:
        f.attrs.update(name=participant.name, gender=participant.gender, mass=participant.mass,
                       height=participant.height)
        for kind, rec in participant.recordings.items():
            g = f.create_group(kind)
            g.create_dataset("pressure", data=rec.pressure, compression="gzip", shuffle=True)
            if rec.point_clouds:
                offsets = np.cumsum([0] + [len(p) for p in rec.point_clouds])
                g.create_dataset("pc_points", data=np.concatenate(rec.point_clouds).astype(np.float32),
                                 compression="gzip", shuffle=True)
                g.create_dataset("pc_offsets", data=offsets.astype(np.int64))
    write_bytes_atomic(Path(path), buf.getvalue())
    return Path(path)
