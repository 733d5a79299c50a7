"""Generated datasets (:mod:`pressurepose.data`) as PressureNet's in-memory training/test data."""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

import numpy as np
import torch

from pressurepose.errors import BadInput
from pressurepose.net.pmr import MatGrid

FIELDS = ("pressure", "betas", "pose", "transl", "joints")


@dataclass
class LoadedData:
    """A dataset in memory: ``tensors`` in the layout :func:`pressurepose.net.train.train` takes
    (plus ``partition`` (N,) int64 indexing ``partition_names``), its mat grid and mat name."""

    tensors: dict[str, torch.Tensor]
    grid: MatGrid
    mat: str
    partition_names: tuple[str, ...]

    def __len__(self) -> int:
        return int(self.tensors["pressure"].shape[0])


def load_dataset(path: str | Path, limit: int | None = None, verify: bool = True) -> LoadedData:
    """Read a generated dataset (one directory or a folder of them) into memory (float32 images).

    limit: keep only the first ``limit`` samples (>= 1). BadInput (from the reader) for a missing,
    incomplete or corrupt dataset, and for a folder holding more than one split (train and test).
    """
    from pressurepose.data.dataset import DatasetReader, check_one_split
    from pressurepose.data.schema import PARTITIONS
    from pressurepose.sim.bed import get_mat

    if limit is not None and (isinstance(limit, bool) or not isinstance(limit, (int, np.integer)) or limit < 1):
        raise BadInput(f"limit is {limit!r}; expected a whole number >= 1 (or None for all samples)")
    check_one_split(path)
    reader = DatasetReader(path, verify=verify)
    arrays = reader.load_arrays(FIELDS, image_dtype=np.float32)
    mat_name = reader.datasets[0].config.mat
    sl = slice(None) if limit is None else slice(0, int(limit))
    tensors = {k: torch.from_numpy(np.ascontiguousarray(arrays[k][sl])) for k in FIELDS}
    tensors["gender"] = torch.from_numpy(arrays["gender"][sl].astype(np.int64))  # 0 'f', 1 'm'
    tensors["partition"] = torch.from_numpy(arrays["partition"][sl].astype(np.int64))
    return LoadedData(tensors, MatGrid.from_mat(get_mat(mat_name)), mat_name, tuple(PARTITIONS))
