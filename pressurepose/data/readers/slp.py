"""SLP (Simultaneously-collected multimodal Lying Pose, Liu & Ostadabbas) pressure arrays.

Layout of the release's ``danaLab`` folder (as its reference code reads it)::

    danaLab/physiqueData.npy                 one row per subject: gender (0 f, 1 m), height, weight (kg), ...
    danaLab/00001/PMcali.npy                 (3, 45) scale from raw readings to kPa, per cover and frame
    danaLab/00001/PMarray/uncover/000001.npy 192 x 84 raw pressure array (also cover1/, cover2/)

Subjects are numbered from 1 (``00001``), frames from 1 (``000001``), 45 frames per cover. Images are
returned as stored (192 rows along the bed, 84 across; the SLP mat is ``get_mat("slp")``, 1 cm
taxels) and, when calibrated, converted from kPa to mmHg. Every ``.npy`` is read with
``allow_pickle=False``. Resample to another mat with :mod:`pressurepose.data.resample`.
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path
from typing import Sequence

import numpy as np

from pressurepose.data.resample import resample_pressure
from pressurepose.errors import BadInput, finite_float32
from pressurepose.files import read_npy
from pressurepose.mat import get_mat

COVERS = ("uncover", "cover1", "cover2")
FRAMES = 45
KPA_TO_MMHG = 1000.0 / 133.322


@dataclass(frozen=True)
class SlpPressure:
    """Pressure images and where each came from.

    images: (N, 192, 84) float32, mmHg when ``calibrated`` else raw sensor units.
    subject, frame: (N,) int (1-based, as in the file names); cover: (N,) str.
    gender ('f'/'m'), mass (kg), height (m): (N,) per image, from physiqueData.npy (NaN / '' if absent).
    """

    images: np.ndarray
    subject: np.ndarray
    cover: np.ndarray
    frame: np.ndarray
    calibrated: bool
    gender: np.ndarray
    mass: np.ndarray
    height: np.ndarray


def list_subjects(root: str | Path) -> list[int]:
    """Subject numbers found under an SLP ``danaLab`` folder."""
    root = Path(root)
    if not root.is_dir():
        raise BadInput(f"SLP folder {root} does not exist")
    return sorted(int(p.name) for p in root.iterdir() if p.is_dir() and p.name.isdigit())


def _physique(root: Path) -> np.ndarray | None:
    path = root / "physiqueData.npy"
    if not path.exists():
        return None
    arr = np.asarray(read_npy(path, "SLP"), dtype=np.float64)
    if arr.ndim != 2 or arr.shape[1] < 3:
        raise BadInput(f"{path} has shape {arr.shape}; expected (subjects, >= 3): gender, height, weight")
    return arr


def read_slp(root: str | Path, subjects: Sequence[int] | None = None, covers: Sequence[str] = ("uncover",),
             frames: Sequence[int] | None = None, calibrated: bool = True) -> SlpPressure:
    """Read SLP pressure images (by default every subject folder and every frame file found).

    calibrated: multiply each raw array by its ``PMcali.npy`` factor (kPa) and convert to mmHg.
    """
    root = Path(root)
    subjects = list(subjects) if subjects is not None else list_subjects(root)
    bad = [c for c in covers if c not in COVERS]
    if bad:
        raise BadInput(f"SLP covers {bad} are not known; expected some of {', '.join(COVERS)}")
    shape = get_mat("slp").shape
    phys = _physique(root)
    images, subj, cov, frm, gender, mass, height = [], [], [], [], [], [], []
    for s in subjects:
        folder = root / f"{int(s):05d}"
        cali = None
        if calibrated:
            cali = np.asarray(read_npy(folder / "PMcali.npy", "SLP calibration"), dtype=np.float64)
            if cali.ndim != 2 or cali.shape[0] < len(COVERS):
                raise BadInput(f"{folder / 'PMcali.npy'} has shape {cali.shape}; expected (3, {FRAMES})")
        row = phys[int(s) - 1] if phys is not None and 0 < int(s) <= len(phys) else None
        for c in covers:
            chosen = frames if frames is not None else sorted(
                int(p.stem) for p in (folder / "PMarray" / c).glob("*.npy") if p.stem.isdigit())
            for f in chosen:
                path = folder / "PMarray" / c / f"{int(f):06d}.npy"
                if cali is not None and not 0 < int(f) <= cali.shape[1]:
                    raise BadInput(f"{folder / 'PMcali.npy'} has no factor for frame {f}")
                img = np.asarray(read_npy(path, "SLP"), dtype=np.float64)
                if img.shape != shape:
                    raise BadInput(f"SLP array {path} has shape {img.shape}; the SLP mat is {shape[0]} x {shape[1]}")
                if cali is not None:
                    img = img * cali[COVERS.index(c), int(f) - 1] * KPA_TO_MMHG
                images.append(finite_float32(img, f"SLP array {path}" + (" (calibrated)" if cali is not None else "")))
                subj.append(int(s))
                cov.append(c)
                frm.append(int(f))
                gender.append("" if row is None else ("m" if row[0] >= 0.5 else "f"))
                # height is stored in cm in the release; accept metres too
                height.append(np.nan if row is None else (row[1] / 100.0 if row[1] > 3 else row[1]))
                mass.append(np.nan if row is None else row[2])
    if not images:
        raise BadInput(f"no SLP images selected under {root}")
    return SlpPressure(np.stack(images), np.array(subj), np.array(cov), np.array(frm), calibrated,
                       np.array(gender), np.array(mass), np.array(height))


def slp_to_mat(images: np.ndarray, mat: str = "boditrak_bt3510", align: str = "center") -> np.ndarray:
    """SLP images (N, 192, 84) resampled to another mat's grid, keeping the force on the overlap."""
    return resample_pressure(images, get_mat("slp"), get_mat(mat), align).astype(np.float32)
