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

    check_one_split(path)
    reader = DatasetReader(path, verify=verify)
    arrays = reader.load_arrays(FIELDS, image_dtype=np.float32)
    mat_name, grid = reader.datasets[0].config.mat, reader.datasets[0].config.grid
    sl = slice(None) if limit is None else slice(0, int(limit))
    tensors = {k: torch.from_numpy(np.ascontiguousarray(arrays[k][sl])) for k in FIELDS}
    tensors["gender"] = torch.from_numpy(arrays["gender"][sl].astype(np.int64))  # 0 'f', 1 'm'
    tensors["partition"] = torch.from_numpy(arrays["partition"][sl].astype(np.int64))
    return LoadedData(tensors, grid, mat_name, tuple(PARTITIONS))


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


def check_arrays(arrays, image_shape: tuple[int, int], partitions: int | None, what: str) -> None:
    """BadInput naming ``what`` and the field unless ``arrays`` ({field: numpy array}) hold N samples
    of pressure (N, rows, cols) mmHg >= 0 for ``image_shape`` (rows, cols) and the labels of
    :data:`_LABEL_SHAPES` (betas (N, 10), pose (N, 72) rad, transl (N, 3) m, joints (N, 24, 3) m,
    gender (N,) 0 'f' / 1 'm', partition (N,) an index below ``partitions``), all numbers, all finite.
    ``partitions`` None: no partition field (training reads none)."""
    n = len(arrays["pressure"]) if np.ndim(arrays["pressure"]) else 0
    shapes = {"pressure": tuple(image_shape), **_LABEL_SHAPES}
    if partitions is None:
        del shapes["partition"]
    for k, shape in shapes.items():
        a = arrays[k]
        if a.shape != (n, *shape):
            raise BadInput(f"{what}: {k} has shape {a.shape}; expected {(n, *shape)}")
        if a.dtype.kind not in "fiub":
            raise BadInput(f"{what}: {k} holds {a.dtype} values; expected numbers")
        if a.dtype.kind == "f" and not np.isfinite(a).all():
            raise BadInput(f"{what}: {k} holds NaN or infinite values")
    if (arrays["pressure"] < 0).any():
        raise BadInput(f"{what}: pressure holds negative values; expected mmHg >= 0")
    if not np.isin(arrays["gender"], (0, 1)).all():
        raise BadInput(f"{what}: gender must be 0 or 1 (female, male); it holds "
                       f"{sorted(set(np.unique(arrays['gender']).tolist()) - {0, 1})[:3]}")
    if partitions is None:
        return
    part = arrays["partition"].astype(np.float64)
    if not (np.all(part == np.floor(part)) and ((part >= 0) & (part < partitions)).all()):
        raise BadInput(f"{what}: partition must be an index of its {partitions} partition_names (0 to "
                       f"{partitions - 1})")


def check_loaded(data) -> LoadedData:
    """``data`` (a LoadedData, perhaps built by hand) with its tensors as :func:`load_dataset` gives
    them (float32 images and labels, int64 gender and partition), checked as a training pack is
    (:func:`check_arrays`); BadInput naming the field that is missing, of another type or shape,
    not finite, negative (pressure) or out of range (gender, partition)."""
    what = "LoadedData"
    if not isinstance(data, LoadedData):
        raise BadInput(f"data is {type(data).__name__}; expected a LoadedData (load_dataset(path))")
    if not isinstance(data.grid, MatSpec):
        raise BadInput(f"{what}: grid is {type(data.grid).__name__}; expected a MatSpec (get_mat(name))")
    names = data.partition_names
    if isinstance(names, (str, bytes)) or not isinstance(names, (tuple, list)) or not all(
            isinstance(x, str) for x in names):
        raise BadInput(f"{what}: partition_names is {names!r:.80}; expected a tuple of partition names")
    tensors = data.tensors
    if not isinstance(tensors, dict):
        raise BadInput(f"{what}: tensors is {type(tensors).__name__}; expected a dict of torch tensors")
    need = (*FIELDS, "gender", "partition")
    missing = [k for k in need if k not in tensors]
    if missing:
        raise BadInput(f"{what}: tensors lack {', '.join(missing)}; expected {', '.join(need)}")
    bad = [k for k in need if not isinstance(tensors[k], (torch.Tensor, np.ndarray))]
    if bad:
        raise BadInput(f"{what}: tensors[{bad[0]!r}] is {type(tensors[bad[0]]).__name__}; expected a torch tensor")
    arrays = {k: as_numpy(tensors[k]) for k in need}
    check_arrays(arrays, data.grid.shape, len(names), what)
    out = {k: torch.as_tensor(np.ascontiguousarray(arrays[k]), dtype=torch.float32) for k in FIELDS}
    out.update({k: torch.as_tensor(arrays[k]).long() for k in ("gender", "partition")})
    return LoadedData({**tensors, **out}, data.grid, str(data.mat), tuple(names))


def as_numpy(t) -> np.ndarray:
    """A tensor's values as a numpy array (its memory where it can; bfloat16 as float32)."""
    if not isinstance(t, torch.Tensor):
        return np.asarray(t)
    t = t.detach().cpu()
    return (t.float() if t.dtype == torch.bfloat16 else t).numpy()


def _load_pack(path: Path, limit: int | None) -> LoadedData:
    """A training pack written by :func:`save_pack`; BadInput naming the file for anything else."""
    from pressurepose.files import load_npz

    arrays = load_npz(path, "training pack")
    need = ("format", "mat", "grid", "partition_names", *FIELDS, "gender", "partition")
    missing = [k for k in need if k not in arrays]
    if missing or str(arrays.get("format")) != PACK_FORMAT:
        raise BadInput(f"training pack {path}: expected a file written by `pressurepose pack` ({PACK_FORMAT}); "
                       + (f"it lacks {', '.join(missing)}" if missing else f"its format is {arrays['format']}"))
    grid = arrays["grid"]
    if grid.shape != (4,) or not np.isfinite(grid).all():
        raise BadInput(f"training pack {path}: grid {grid.tolist()} is not (rows, cols, pitch_row, pitch_col)")
    rows, cols = int(grid[0]), int(grid[1])
    names = tuple(str(s) for s in arrays["partition_names"])
    check_arrays(arrays, (rows, cols), len(names), f"training pack {path}")
    sl = slice(None) if limit is None else slice(0, int(limit))
    tensors = {k: torch.from_numpy(np.ascontiguousarray(arrays[k][sl], dtype=np.float32)) for k in FIELDS}
    for k in ("gender", "partition"):
        tensors[k] = torch.from_numpy(arrays[k][sl].astype(np.int64))
    mat = str(arrays["mat"])
    return LoadedData(tensors, custom_mat(rows, cols, float(grid[2]), float(grid[3]), name=mat), mat, names)
