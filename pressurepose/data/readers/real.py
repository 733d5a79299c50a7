"""Real pressure images with their labels, from any supported folder layout.

``read_real(folder)`` detects the layout and returns :class:`RealImages`:

* PhysioNet PMD experiment I (``subject-info-i.csv``, ``S<n>/<posture>.txt``) and experiment II
  (``subject-info-ii.csv``, ``S<n>/{Sponge,Air}_Mat/Matrix_*.txt``): :mod:`.pmd`;
* a generic labelled folder (``images.npy``, ``labels.csv``, ``mat.json``): :mod:`.labelled`.

Images come back as recorded (raw units or mmHg, on their own mat) but turned so that row 0 is the
head end; :meth:`RealImages.model_input` makes them model input. A bare recording without labels
(one person's frames, e.g. for ``infer``) is read by :func:`.recording.read_recording`.
"""

from __future__ import annotations

from pathlib import Path

from pressurepose.data.readers import pmd
from pressurepose.data.readers.images import FRAME_MODES, RealImages
from pressurepose.data.readers.labelled import read_labelled
from pressurepose.errors import BadInput, require_path


def detect_layout(folder: str | Path) -> str:
    """'pmd-i', 'pmd-ii' or 'labelled' for a folder; BadInput naming what each layout needs."""
    folder = require_path("real-data folder", folder)
    if not folder.is_dir():
        raise BadInput(f"real-data folder {folder} does not exist (or is not a folder)")
    if (folder / "images.npy").is_file() or (folder / "labels.csv").is_file():
        return "labelled"
    subjects = [p for p in folder.glob("S*") if p.is_dir() and p.name[1:].isdigit()]
    if (folder / "subject-info-ii.csv").is_file() or any((s / "Air_Mat").is_dir() or (s / "Sponge_Mat").is_dir()
                                                         for s in subjects):
        return "pmd-ii"
    if (folder / "subject-info-i.csv").is_file() or any(any(s.glob("[0-9]*.txt")) for s in subjects):
        return "pmd-i"
    raise BadInput(f"{folder} is neither a PMD experiment folder (subject-info-i.csv with S<n>/<posture>.txt, or "
                   f"subject-info-ii.csv with S<n>/Air_Mat|Sponge_Mat/Matrix_*.txt) nor a labelled folder "
                   f"(images.npy, labels.csv, mat.json)")


def read_real(folder: str | Path, frames: str = "one") -> RealImages:
    """Read a real-data folder of any supported layout (:func:`detect_layout`).

    frames: 'one' (default) one image per recording (the median of its non-blank frames; a still
    person's frames barely differ) or 'all' (every non-blank frame). Generic folders hold one image
    per row already.
    """
    if frames not in FRAME_MODES:
        raise BadInput(f"frames {frames!r} is not known; expected one of {', '.join(FRAME_MODES)}")
    layout = detect_layout(folder)
    if layout == "labelled":
        return read_labelled(folder)
    return pmd.read_pmd_i(folder, frames) if layout == "pmd-i" else pmd.read_pmd_ii(folder)
