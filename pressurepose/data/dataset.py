"""Reading datasets: :class:`DatasetReader` over one dataset directory or a folder of them (the torch
``Dataset`` is in ``torch_dataset.py``).

A "folder of datasets" is any directory whose sub-directories (at any depth) hold ``manifest.json``
files, e.g. the output of a recipe. Samples are numbered across datasets in sorted path order, shard
by shard. Shards are checked against their manifest checksums when the reader opens (``verify``).
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path
from typing import Iterator, Sequence

import numpy as np

from pressurepose.data.schema import (
    GENDERS,
    IMAGE_FIELDS,
    LABEL_FIELDS,
    PARTITIONS,
    GenerationConfig,
    Sample,
)
from pressurepose.data.store import (
    MANIFEST,
    Manifest,
    ShardRecord,
    read_shard_arrays,
    samples_from_arrays,
    verify_shard,
)
from pressurepose.errors import BadInput


@dataclass(frozen=True)
class ShardRef:
    path: Path
    dataset: int   # position in DatasetReader.datasets
    start: int     # global index of its first sample
    count: int


@dataclass(frozen=True)
class DatasetPart:
    path: Path
    manifest: Manifest

    @property
    def config(self) -> GenerationConfig:
        return self.manifest.config


SPLITS = ("train", "val", "validation", "test")  # folder names that hold one split of a recipe's output


def find_datasets(root: str | Path) -> list[Path]:
    """Directories under ``root`` (``root`` included) that hold a manifest, sorted. BadInput for a
    file, and for a dataset with other datasets inside it (they would be counted together)."""
    root = Path(root)
    if root.is_file():
        raise BadInput(f"{root} is a file; expected a dataset folder (made by `generate`) or a folder of them")
    if not root.is_dir():
        raise BadInput(f"dataset directory {root} does not exist")
    found = sorted(p.parent for p in root.rglob(MANIFEST))
    if not found:
        raise BadInput(f"{root} holds no pressurepose dataset (no {MANIFEST} in it or below it)")
    if root in found and len(found) > 1:
        inner = ", ".join(str(p) for p in found if p != root)
        raise BadInput(f"{root} is a dataset and also holds other datasets ({inner[:300]}); they would be "
                       f"counted together. Move them apart")
    return found


def split_folders(root: str | Path) -> dict[str, Path]:
    """Split name -> folder for the splits (train, val, test) of a recipe's output found directly in
    ``root``; empty when ``root`` holds no such folders."""
    root = Path(root)
    return {name: root / name for name in SPLITS if (root / name).is_dir() and any((root / name).rglob(MANIFEST))}


def check_one_split(root: str | Path) -> None:
    """BadInput when ``root`` holds more than one split (e.g. a recipe's train and test folders), which
    must not be read together."""
    splits = split_folders(root)
    if len(splits) > 1:
        raise BadInput(f"{root} holds the {' and '.join(splits)} splits; they must not be mixed. Pass one of "
                       f"{', '.join(str(p) for p in splits.values())}")


class DatasetReader:
    """Samples of one dataset directory or of every dataset below a folder.

    verify: check every shard's sha256 against its manifest on opening (BadInput naming a bad one).
    allow_incomplete: read datasets whose generation has not finished (only their finished shards).
    """

    def __init__(self, root: str | Path, *, verify: bool = True, allow_incomplete: bool = False):
        self.root = Path(root)
        self.datasets: list[DatasetPart] = []
        self.shards: list[ShardRef] = []
        start = 0
        for d, path in enumerate(find_datasets(self.root)):
            manifest = Manifest.load(path)
            if not manifest.complete and not allow_incomplete:
                raise BadInput(f"dataset {path} is incomplete ({len(manifest.shards)} of "
                               f"{manifest.config.num_shards} shards); rerun its generate command to finish it")
            self.datasets.append(DatasetPart(path, manifest))
            for k in sorted(manifest.shards):
                record: ShardRecord = manifest.shards[k]
                if verify:
                    problem = verify_shard(path, record)
                    if problem:
                        raise BadInput(problem)
                self.shards.append(ShardRef(path / record.file, d, start, record.count))
                start += record.count
        self._starts = np.array([s.start for s in self.shards], dtype=np.int64)
        self._cache: tuple[int, list[Sample]] | None = None

    def __len__(self) -> int:
        return int(sum(s.count for s in self.shards))

    def __repr__(self) -> str:
        return f"DatasetReader({str(self.root)!r}, {len(self.datasets)} datasets, {len(self)} samples)"

    def _shard_samples(self, k: int) -> list[Sample]:
        if self._cache is None or self._cache[0] != k:
            self._cache = (k, samples_from_arrays(read_shard_arrays(self.shards[k].path)))
        return self._cache[1]

    def __getitem__(self, i: int) -> Sample:
        n = len(self)
        if not -n <= i < n:
            raise IndexError(f"sample {i} out of range for {n} samples")
        i %= n
        k = int(np.searchsorted(self._starts, i, side="right") - 1)
        return self._shard_samples(k)[i - self.shards[k].start]

    def __iter__(self) -> Iterator[Sample]:
        for k in range(len(self.shards)):
            yield from self._shard_samples(k)

    def load_arrays(self, fields: Sequence[str] = IMAGE_FIELDS + LABEL_FIELDS, *,
                    image_dtype=np.float16, label_dtype=np.float32) -> dict[str, np.ndarray]:
        """Every sample's ``fields`` stacked into arrays, read shard by shard into preallocated memory.

        Images (pressure, force, depth) become ``image_dtype`` (float16 by default: a 64 x 27 image
        is 3.5 kB), ``contact`` stays bool, labels become ``label_dtype``. Always included:
        ``gender`` (uint8, index into GENDERS), ``partition`` (uint8, index into PARTITIONS) and
        ``index`` (int64, the sample's index within its dataset).
        """
        unknown = [f for f in fields if f not in IMAGE_FIELDS + LABEL_FIELDS]
        if unknown:
            raise BadInput(f"unknown fields {unknown}; expected some of {', '.join(IMAGE_FIELDS + LABEL_FIELDS)}")
        n = len(self)
        if n == 0:
            raise BadInput(f"{self.root} holds no samples")
        for part in self.datasets[1:]:
            if part.config.grid != self.datasets[0].config.grid:
                raise BadInput(f"{part.path} uses mat {part.config.mat!r} but {self.datasets[0].path} uses "
                               f"{self.datasets[0].config.mat!r} (another grid); resample one of them first")
        first = read_shard_arrays(self.shards[0].path, fields)
        shapes = {f: first[f].shape[1:] for f in fields}
        out = {f: np.empty((n,) + shapes[f], dtype=np.bool_ if f == "contact" else
                           image_dtype if f in IMAGE_FIELDS else label_dtype) for f in fields}
        out["gender"] = np.empty(n, np.uint8)
        out["partition"] = np.empty(n, np.uint8)
        out["index"] = np.empty(n, np.int64)
        for ref in self.shards:
            arrays = read_shard_arrays(ref.path, list(fields) + ["index", "gender", "partition"])
            sl = slice(ref.start, ref.start + ref.count)
            for f in fields:
                out[f][sl] = arrays[f]
            out["index"][sl] = arrays["index"]
            out["gender"][sl] = [GENDERS.index(g) for g in arrays["gender"]]
            out["partition"][sl] = [PARTITIONS.index(p) for p in arrays["partition"]]
        return out
