"""``PressureDataset``: a torch ``Dataset`` over a whole dataset held in memory (images float16)."""

from __future__ import annotations

from typing import Sequence

import numpy as np
import torch
from torch.utils.data import Dataset

from pressurepose.data.dataset import DatasetReader
from pressurepose.data.schema import IMAGE_FIELDS, LABEL_FIELDS


class PressureDataset(Dataset):
    """Every sample of a dataset in memory, served as dicts of tensors.

    source: a dataset path (one dataset or a folder of them), a :class:`DatasetReader`, or the dict
    returned by :meth:`DatasetReader.load_arrays`. fields: which images and labels to hold.
    Images are stored float16 (64 x 27 x 2 bytes each) and served as ``image_dtype`` (float32 by
    default; torch.float16 serves them as stored, to convert on the GPU), ``contact`` as bool,
    labels as float32 (``betas`` (10,), ``pose`` (72,), ``transl`` (3,), ``joints`` (24, 3),
    ``mass``, ``height`` scalars), and ``gender`` / ``partition`` / ``index`` as int64 scalars
    (gender and partition index into ``schema.GENDERS`` and ``schema.PARTITIONS``).
    ``tensors`` holds the whole set (e.g. to move it to a GPU in one go).
    """

    def __init__(self, source, fields: Sequence[str] = ("pressure", "contact") + LABEL_FIELDS, *,
                 image_dtype: torch.dtype = torch.float32):
        if isinstance(source, dict):
            arrays = source
        else:
            reader = source if isinstance(source, DatasetReader) else DatasetReader(source)
            arrays = reader.load_arrays(fields)
        self.tensors = {k: torch.from_numpy(np.ascontiguousarray(v)) for k, v in arrays.items()}
        self.image_dtype = image_dtype
        self._len = len(arrays["index"])

    def __len__(self) -> int:
        return self._len

    def __getitem__(self, i: int) -> dict[str, torch.Tensor]:
        item = {}
        for k, t in self.tensors.items():
            v = t[i]
            if k in IMAGE_FIELDS and k != "contact":
                v = v.to(self.image_dtype)
            elif k in ("gender", "partition", "index"):
                v = v.to(torch.int64)
            item[k] = v
        return item
