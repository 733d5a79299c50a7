"""Small real-data folders in each layout, written by the tests (no shared data needed)."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np


def body_image(rows: int, cols: int, head_row0: bool = True, seed: int = 0, scale: float = 100.0) -> np.ndarray:
    """A crude supine footprint (rows, cols): head blob near row 0, trunk, two legs (raw units)."""
    rng = np.random.default_rng(seed)
    img = np.zeros((rows, cols))
    c = cols // 2
    img[1:4, c - 1:c + 2] = 0.8
    img[8:int(0.5 * rows), c - 4:c + 4] = 1.0
    img[int(0.5 * rows):rows - 2, c - 4:c - 1] = 0.6
    img[int(0.5 * rows):rows - 2, c + 1:c + 4] = 0.6
    img = img * scale * rng.uniform(0.8, 1.2, img.shape)
    return img if head_row0 else img[::-1]


def write_pmd_i(root: Path, subjects=(1, 2), postures=(1, 2, 15), frames: int = 4) -> Path:
    """PMD experiment I layout: frame 0 blank, frame 1 a saturated start-up frame, then the body."""
    root.mkdir(parents=True, exist_ok=True)
    (root / "subject-info-i.csv").write_text("Subject-Number,Age,Height/cm,Weight/kg\n" +
                                            "".join(f"{s},30,{170 + s},{70 + s}\n" for s in subjects))
    for s in subjects:
        (root / f"S{s}").mkdir(exist_ok=True)
        for p in postures:
            img = body_image(64, 32, seed=10 * s + p)
            lines = [np.zeros(2048), np.full(2048, 3000.0)] + [img.ravel() * (1 + 0.01 * k) for k in range(frames - 2)]
            (root / f"S{s}" / f"{p}.txt").write_text("".join("\t".join(f"{v:.0f}" for v in ln) + "\n" for ln in lines))
    return root


def write_pmd_ii(root: Path, subjects=(1,), files=("B1", "C1")) -> Path:
    """PMD experiment II layout: 64 lines of 27 values, the feet at row 0; UTF-16 subject file."""
    root.mkdir(parents=True, exist_ok=True)
    (root / "subject-info-ii.csv").write_text("Subject,Height (cm),Weight (kg)\n" +
                                             "".join(f"{s},{180 + s},{80 + s}\n" for s in subjects), encoding="utf-16")
    for s in subjects:
        for mattress in ("Sponge", "Air"):
            d = root / f"S{s}" / f"{mattress}_Mat"
            d.mkdir(parents=True, exist_ok=True)
            for name in files:
                img = body_image(64, 27, head_row0=False, seed=s)
                (d / f"Matrix_{mattress}_{name}.txt").write_text(
                    "".join(" ".join(f"{v:.0f}" for v in row) + "\n" for row in img))
    return root


def write_labelled(root: Path, images: np.ndarray, postures, mat: dict, heights=None, weights=None,
                   genders=None) -> Path:
    """Generic labelled layout."""
    root.mkdir(parents=True, exist_ok=True)
    n = len(images)
    np.save(root / "images.npy", np.asarray(images))
    heights = [1.75] * n if heights is None else heights
    weights = [70.0] * n if weights is None else weights
    head = "posture,height_m,weight_kg,subject" + (",gender" if genders is not None else "") + "\n"
    rows = [f"{postures[i]},{heights[i]},{weights[i]},s{i % 2}" + (f",{genders[i]}" if genders is not None else "")
            for i in range(n)]
    (root / "labels.csv").write_text(head + "\n".join(rows) + "\n")
    (root / "mat.json").write_text(json.dumps(mat))
    return root
