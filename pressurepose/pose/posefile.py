"""SMPL pose files: a set of lying poses read into the bed frame, and the record that names one.

Two layouts of ``.npz`` (read without pickle):

* SMPL fits: ``global_orient`` (N, 3) and ``body_pose`` (N, 69), axis-angle in SMPL's joint order,
  with optional ``betas`` (N, S), ``transl`` (N, 3), ``subject`` (N,) whole numbers, ``gender``
  (N,) 'f' / 'm' and ``posture`` (N,) labels: the layout of the SMPL fits to the SLP dataset
  (``slp_3dfits_train.npz``, converted from pgrady3/SLP-3Dfits; see NOTICE.md);
* plain poses: ``pose`` (N, 72), SMPL's 72 values, root orientation first (as ``pressurepose
  sample`` writes them), with the same optional arrays.

Frames. ``bed``: the project's bed frame (z up, y toward the feet, x across the bed; a supine body
faces +z with its left toward -x; :mod:`pressurepose.pose.root`). ``camera``: an overhead camera's
frame, as SMPL fitters write it: looking straight down, x image-right, y image-down (toward the
feet), z away from the camera into the bed (a supine body faces -z). Turning the camera frame 180
deg about its y axis gives the bed frame (:data:`CAMERA_TO_BED`); a translation turns the same way
(its origin stays the camera's). ``auto`` (default) takes the file's own ``frame`` entry if it has
one, else ``camera`` for the fit layout and ``bed`` for the plain layout.
"""

from __future__ import annotations

import hashlib
from dataclasses import dataclass, replace
from functools import lru_cache
from pathlib import Path

import numpy as np

from pressurepose.body.lbs_numpy import Y_UP_TO_Z_UP, rodrigues, rotation_to_axis_angle
from pressurepose.errors import BadInput, require_between
from pressurepose.files import load_npz
from pressurepose.pose.posture import posture_classes

FRAMES = ("auto", "bed", "camera")
# camera frame (x image-right, y toward the feet, z into the bed) -> bed frame (z up, y toward the feet)
CAMERA_TO_BED = np.diag([-1.0, 1.0, -1.0])
WHAT = "pose file"


@dataclass(frozen=True, eq=False)
class PoseSet:
    """N poses read from a file. pose: (N, 72) SMPL axis-angle, root orientation in the bed frame,
    rad; the optional per-pose arrays as the file holds them (None where it has none): betas (N, S)
    (the file's shape space), transl (N, 3) m (turned into the bed frame's axes, origin as in the
    file), subject (N,) int, gender (N,) 'f' / 'm', labels (N,) the file's own ``posture`` labels.
    source: the file's path."""

    pose: np.ndarray
    source: str
    betas: np.ndarray | None = None
    transl: np.ndarray | None = None
    subject: np.ndarray | None = None
    gender: np.ndarray | None = None
    labels: np.ndarray | None = None

    def __len__(self) -> int:
        return len(self.pose)

    @property
    def postures(self) -> np.ndarray:
        """(N,) posture class of each pose from its root (:mod:`pressurepose.pose.posture`)."""
        return posture_classes(self.pose)

    def select(self, mask) -> "PoseSet":
        """The poses where ``mask`` (N,) bool (or an index array) selects them."""
        pick = (lambda a: None if a is None else a[mask])
        return replace(self, pose=self.pose[mask], betas=pick(self.betas), transl=pick(self.transl),
                       subject=pick(self.subject), gender=pick(self.gender), labels=pick(self.labels))


def camera_to_bed(root) -> np.ndarray:
    """SMPL root axis-angles (N, 3) giving, on the project's body model (whose output is turned by
    ``Y_UP_TO_Z_UP``), the bed-frame orientation of bodies whose camera-frame root axis-angles are
    ``root`` (N, 3): with R the camera-frame rotation, the bed frame's is ``CAMERA_TO_BED R`` and
    the model's root ``Q^T CAMERA_TO_BED R`` (Q = ``Y_UP_TO_Z_UP``)."""
    R = rodrigues(np.asarray(root, dtype=np.float64))
    return rotation_to_axis_angle(Y_UP_TO_Z_UP.T @ CAMERA_TO_BED @ R)


def _numbers(d: dict, key: str, path: str, shape: tuple) -> np.ndarray:
    """d[key] as float64 with the given shape (-1: any length; None: the pose count n); BadInput
    naming the file and the field otherwise."""
    a = d[key]
    if a.dtype.kind not in "fiu":
        raise BadInput(f"{WHAT} {path!r}: {key} holds {a.dtype} values; expected numbers")
    if a.ndim != len(shape) or any(s not in (-1, t) for s, t in zip(shape, a.shape)):
        want = " x ".join("S" if s == -1 else str(s) for s in shape)
        raise BadInput(f"{WHAT} {path!r}: {key} has shape {a.shape}; expected ({want})")
    a = a.astype(np.float64)
    if not np.all(np.isfinite(a)):
        raise BadInput(f"{WHAT} {path!r}: {key} contains NaN or infinite values")
    return a


def read_poses(path, frame: str = "auto") -> PoseSet:
    """The poses of an ``.npz`` pose file (see the module docstring for the layouts and frames),
    the root orientations turned into the bed frame. BadInput naming the file and the field for a
    missing, unreadable or pickled file, a missing or malformed field, or an empty file."""
    if frame not in FRAMES:
        raise BadInput(f"pose frame {frame!r}; expected one of {', '.join(FRAMES)}")
    p = str(path)
    if not Path(p).is_file():
        raise BadInput(f"{WHAT} {p!r} does not exist")
    d = load_npz(p, WHAT)
    if "pose" in d:
        if d["pose"].ndim != 2:
            raise BadInput(f"{WHAT} {p!r}: pose has shape {d['pose'].shape}; expected (N, 72)")
        n = len(d["pose"])
        pose = _numbers(d, "pose", p, (n, 72))
        layout = "bed"
    elif "global_orient" in d and "body_pose" in d:
        if d["global_orient"].ndim != 2:
            raise BadInput(f"{WHAT} {p!r}: global_orient has shape {d['global_orient'].shape}; expected (N, 3)")
        n = len(d["global_orient"])
        pose = np.concatenate([_numbers(d, "global_orient", p, (n, 3)), _numbers(d, "body_pose", p, (n, 69))], 1)
        layout = "camera"
    else:
        raise BadInput(f"{WHAT} {p!r} has neither pose (N x 72) nor global_orient (N x 3) with body_pose "
                       f"(N x 69) (it has: {', '.join(d) or 'nothing'})")
    if n == 0:
        raise BadInput(f"{WHAT} {p!r} holds no poses")
    if frame == "auto":
        frame = layout
        if "frame" in d:
            frame = str(d["frame"])
            if d["frame"].ndim != 0 or frame not in FRAMES[1:]:
                raise BadInput(f"{WHAT} {p!r}: frame is {d['frame']!r}; expected 'bed' or 'camera'")
    transl = _numbers(d, "transl", p, (n, 3)) if "transl" in d else None
    if frame == "camera":
        pose[:, :3] = camera_to_bed(pose[:, :3])
        transl = None if transl is None else transl @ CAMERA_TO_BED.T
    betas = _numbers(d, "betas", p, (n, -1)) if "betas" in d else None
    subject = None
    if "subject" in d:
        subject = _numbers(d, "subject", p, (n,))
        if np.any(subject != np.round(subject)):
            raise BadInput(f"{WHAT} {p!r}: subject holds fractions; expected whole numbers")
        subject = subject.astype(np.int64)
    gender = labels = None
    for key in ("gender", "posture"):
        if key in d:
            a = d[key]
            if a.dtype.kind != "U" or a.shape != (n,):
                raise BadInput(f"{WHAT} {p!r}: {key} is {a.dtype} {a.shape}; expected ({n},) text")
            if key == "gender":
                gender = np.char.lower(np.char.strip(a))
                bad = sorted(set(gender) - {"f", "m"})
                if bad:
                    raise BadInput(f"{WHAT} {p!r}: gender holds {bad[:3]}; expected 'f' or 'm'")
            else:
                labels = a
    return PoseSet(pose, p, betas, transl, subject, gender, labels)


def file_sha256(path) -> str:
    """Hex sha256 of a file's bytes."""
    h = hashlib.sha256()
    with open(path, "rb") as fh:
        for block in iter(lambda: fh.read(1 << 20), b""):
            h.update(block)
    return h.hexdigest()


@dataclass(frozen=True)
class PoseFile:
    """A user's pose file as the sampler draws from it (saved with a dataset's config).

    path: the file (absolute); sha256: its bytes' digest (a changed file is refused, so a dataset
    resumes with the poses it began with); frame: as :func:`read_poses`; noise_deg: sd of the
    Gaussian noise added to each component of each body joint's axis-angle, degrees.
    """

    path: str
    sha256: str
    frame: str = "auto"
    noise_deg: float = 5.0

    def __post_init__(self):
        if self.frame not in FRAMES:
            raise BadInput(f"pose frame {self.frame!r}; expected one of {', '.join(FRAMES)}")
        require_between("pose noise_deg (degrees)", self.noise_deg, 0, 90)
        object.__setattr__(self, "noise_deg", float(self.noise_deg))

    @classmethod
    def of(cls, path, frame: str = "auto", noise_deg: float = 5.0) -> "PoseFile":
        """The record of a file on disk (read once here, so a bad file fails now)."""
        p = Path(path).expanduser().resolve()
        read_poses(p, frame)
        return cls(str(p), file_sha256(p), frame, noise_deg)

    @classmethod
    def from_dict(cls, d) -> "PoseFile":
        if not isinstance(d, dict) or not {"path", "sha256"} <= set(d) or not set(d) <= {"path", "sha256", "frame",
                                                                                            "noise_deg"}:
            raise BadInput(f"pose file record {d!r}; expected path, sha256 and optionally frame, noise_deg")
        return cls(**d)

    def poses(self) -> PoseSet:
        """The file's poses (read once per process); BadInput if the file is gone or its bytes are not
        those recorded."""
        return _load(self.path, self.sha256, self.frame)


@lru_cache(maxsize=4)
def _load(path: str, sha256: str, frame: str) -> PoseSet:
    if not Path(path).is_file():
        raise BadInput(f"{WHAT} {path!r} does not exist")
    now = file_sha256(path)
    if now != sha256:
        raise BadInput(f"{WHAT} {path!r} has changed since it was given (sha256 {now[:12]}... vs "
                       f"{sha256[:12]}...); its poses would differ. Give the file it was, or start anew")
    return read_poses(path, frame)

