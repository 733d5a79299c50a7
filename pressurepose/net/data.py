"""Generated datasets (:mod:`pressurepose.data`) as PressureNet's in-memory training/test data."""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

import numpy as np
import torch

from pressurepose.errors import BadInput, require_path, require_whole
from pressurepose.mat import MatSpec, custom_mat

FIELDS = ("pressure", "betas", "pose", "transl", "joints")


@dataclass
class LoadedData:
    """A dataset in memory: ``tensors`` in the layout :func:`pressurepose.net.train.train` takes
    (plus ``partition`` (N,) int64 indexing ``partition_names``), its mat grid and mat name."""

    tensors: dict[str, torch.Tensor]
    grid: MatSpec
    mat: str
    partition_names: tuple[str, ...]

    def __len__(self) -> int:
        return int(self.tensors["pressure"].shape[0])


def load_dataset(path: str | Path, limit: int | None = None, verify: bool = True) -> LoadedData:
    """Read a generated dataset (one directory or a folder of them), or a training pack (one ``.npz``
    file from :func:`save_pack`), into memory (float32 images).

    limit: keep only the first ``limit`` samples (>= 1). BadInput (from the reader) for a missing,
    incomplete or corrupt dataset or pack, and for a folder holding more than one split (train and test).
    """
    if limit is not None:
        require_whole("limit (None: all samples)", limit, 1)
    require_path("dataset (a folder made by `generate`, or a training pack .npz)", path)
    if Path(path).suffix.lower() == ".npz":
        if not Path(path).is_file():
            raise BadInput(f"training pack {path} does not exist (write one with `pressurepose pack DATA --out FILE.npz`)")
        return _load_pack(Path(path), limit)  # needs neither the simulator nor h5py (a GPU machine may lack them)
    from pressurepose.data.dataset import DatasetReader, check_one_split
    from pressurepose.data.schema import PARTITIONS
    from pressurepose.mat import get_mat

    check_one_split(path)
    reader = DatasetReader(path, verify=verify)
    arrays = reader.load_arrays(FIELDS, image_dtype=np.float32)
    mat_name = reader.datasets[0].config.mat
    sl = slice(None) if limit is None else slice(0, int(limit))
    tensors = {k: torch.from_numpy(np.ascontiguousarray(arrays[k][sl])) for k in FIELDS}
    tensors["gender"] = torch.from_numpy(arrays["gender"][sl].astype(np.int64))  # 0 'f', 1 'm'
    tensors["partition"] = torch.from_numpy(arrays["partition"][sl].astype(np.int64))
    return LoadedData(tensors, get_mat(mat_name), mat_name, tuple(PARTITIONS))


PACK_FORMAT = "pressurepose-training-pack-1"
_LABEL_SHAPES = {"betas": (10,), "pose": (72,), "transl": (3,), "joints": (24, 3), "gender": (), "partition": ()}


def save_pack(data: LoadedData, path: str | Path) -> None:
    """Write ``data`` to one compressed ``.npz`` file (a *training pack*): exactly the arrays that
    training and evaluation read (pressure in mmHg, labels, gender, partition), with the mat's name and
    grid, so a dataset made on CPU machines can be copied to a GPU machine at about a third of its
    size (the images PMR and the realism report use, force, depth and contact, are left out).
    :func:`load_dataset` reads it back. Written atomically."""
    from pressurepose.files import save_npz_atomic

    g = data.grid
    arrays = {k: data.tensors[k].numpy() for k in (*FIELDS, "gender", "partition")}
    save_npz_atomic(path, format=np.array(PACK_FORMAT), mat=np.array(data.mat),
                    grid=np.array([g.rows, g.cols, g.pitch_row_m, g.pitch_col_m], dtype=np.float64),
                    partition_names=np.array(data.partition_names), **arrays)


def _load_pack(path: Path, limit: int | None) -> LoadedData:
    """A training pack written by :func:`save_pack`; BadInput naming the file for anything else."""
    from pressurepose.files import load_npz

    arrays = load_npz(path, "training pack")
    need = ("format", "mat", "grid", "partition_names", *FIELDS, "gender", "partition")
    missing = [k for k in need if k not in arrays]
    if missing or str(arrays.get("format")) != PACK_FORMAT:
        raise BadInput(f"training pack {path}: expected a file written by `pressurepose pack` ({PACK_FORMAT}); "
                       + (f"it lacks {', '.join(missing)}" if missing else f"its format is {arrays['format']}"))
    n = len(arrays["pressure"])
    grid = arrays["grid"]
    if grid.shape != (4,) or not np.isfinite(grid).all():
        raise BadInput(f"training pack {path}: grid {grid.tolist()} is not (rows, cols, pitch_row, pitch_col)")
    rows, cols = int(grid[0]), int(grid[1])
    for k, shape in {"pressure": (rows, cols), **_LABEL_SHAPES}.items():
        a = arrays[k]
        if a.shape != (n, *shape):
            raise BadInput(f"training pack {path}: {k} has shape {a.shape}; expected {(n, *shape)}")
        if a.dtype.kind == "f" and not np.isfinite(a).all():
            raise BadInput(f"training pack {path}: {k} holds NaN or infinite values")
    names = tuple(str(s) for s in arrays["partition_names"])
    if (arrays["pressure"] < 0).any():
        raise BadInput(f"training pack {path}: pressure holds negative values; expected mmHg >= 0")
    if not np.isin(arrays["gender"], (0, 1)).all() or not ((arrays["partition"] >= 0)
                                                           & (arrays["partition"] < len(names))).all():
        raise BadInput(f"training pack {path}: gender must be 0 or 1 and partition an index of its partition_names")
    sl = slice(None) if limit is None else slice(0, int(limit))
    tensors = {k: torch.from_numpy(np.ascontiguousarray(arrays[k][sl], dtype=np.float32)) for k in FIELDS}
    for k in ("gender", "partition"):
        tensors[k] = torch.from_numpy(arrays[k][sl].astype(np.int64))
    mat = str(arrays["mat"])
    return LoadedData(tensors, custom_mat(rows, cols, float(grid[2]), float(grid[3]), name=mat), mat, names)
