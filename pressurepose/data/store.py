"""On-disk format: HDF5 shards of a fixed number of samples, plus a JSON manifest, written atomically.

A dataset directory holds ``manifest.json`` and ``shard-00000.h5``, ``shard-00001.h5``, ... Shard
``k`` holds samples ``k * shard_size`` up to the next shard's first (see
:meth:`GenerationConfig.shard_range`). Every file is first written under a hidden temporary name
(``.shard-00003.h5.tmp-<pid>-<random>``), flushed to disk, and only then renamed to its final name,
so a final name always means a complete file; leftovers with temporary names are partial writes.

A shard's sha256 is recorded in the manifest BEFORE the shard is renamed into place: a shard file
on disk always has a recorded checksum, and a recorded checksum without a file means "regenerate".

Shard layout (N samples, mat R x C): datasets ``pressure``, ``force``, ``depth`` (N, R, C) float32,
``contact`` (N, R, C) bool, ``betas`` (N, 10), ``pose`` (N, 72), ``transl`` (N, 3), ``joints``
(N, 24, 3), ``mass``, ``height`` (N,) float32, ``index`` (N,) int64, ``attempt`` (N,) int32 (the attempt
that was accepted), ``gender`` (N,) S1, ``partition`` (N,) S32; gzip + shuffle compressed.
Attributes: ``config`` (JSON), ``config_digest``, ``shard``, ``package_version``, ``rejections``
(JSON cause -> count).
"""

from __future__ import annotations

import dataclasses
import hashlib
import io
import json
import time
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, Sequence

import h5py
import numpy as np

from pressurepose import __version__
from pressurepose.data.schema import (
    IMAGE_FIELDS,
    LABEL_FIELDS,
    GenerationConfig,
    Sample,
)
from pressurepose.errors import BadInput
from pressurepose.files import (
    commit,
    json_text,
    stage,
    stored_dataset,
    write_bytes_atomic,
)

MANIFEST = "manifest.json"
FORMAT = "pressurepose-dataset"
FORMAT_VERSION = 1
REPAIR_HINT = ("rerun its generate command with --repair to set the manifest and its shards aside "
               "(renamed *.corrupt-<time>) and make the dataset again")
_F32 = ("pressure", "force", "depth", "betas", "pose", "transl", "joints", "mass", "height")
# settings that some manifests' provenance records (by section) and the configs no longer have, with
# the value that is now the only behaviour: max_limb_sink None (an opt-in limb test, off), cone
# "elliptic" (MuJoCo's friction cones; pyramidal ones were not adopted: docs/not-adopted.md).
# A manifest holding that value reads as if it did not name the setting, so its dataset resumes; any
# other value stays in the record, and a resume is refused as made under other constants.
RETIRED_SETTINGS = {"sampler": {"max_limb_sink": None}, "settle": {"cone": "elliptic"}}


def shard_name(shard: int) -> str:
    return f"shard-{shard:05d}.h5"


def is_temp_name(name: str) -> bool:
    """True for the hidden temporary names used while writing (never a finished file)."""
    return name.startswith(".") and ".tmp-" in name


SET_ASIDE = ".corrupt-"  # a bad file set aside by --repair is renamed NAME.corrupt-<time>


def set_aside_path(path: Path, stamp: str) -> Path:
    """Where ``--repair`` moves a bad file: ``path`` renamed ``NAME.corrupt-<stamp>``."""
    return path.with_name(f"{path.name}{SET_ASIDE}{stamp}")


def is_set_aside_name(name: str) -> bool:
    """True for the names of files ``--repair`` set aside (:func:`set_aside_path`)."""
    return SET_ASIDE in name


# --------------------------------------------------------------------------- atomic files


def stage_bytes(path: Path, data: bytes) -> Path:
    """Write ``data`` to a hidden temporary file next to ``path``, flushed to disk; returns the
    temporary path (rename it with :func:`~pressurepose.files.commit`). See :func:`pressurepose.files.stage`."""
    return stage(path, lambda p: Path(p).write_bytes(data))


def sha256_bytes(data: bytes) -> str:
    return hashlib.sha256(data).hexdigest()


def sha256_file(path: Path) -> str:
    h = hashlib.sha256()
    with open(path, "rb") as fh:
        for block in iter(lambda: fh.read(1 << 20), b""):
            h.update(block)
    return h.hexdigest()


# --------------------------------------------------------------------------- shards


def encode_shard(config: GenerationConfig, shard: int, samples: Sequence[Sample], attempts: Sequence[int],
                 rejections: dict[str, int]) -> bytes:
    """The bytes of an HDF5 shard holding ``samples`` (validated against the mat shape).

    The bytes depend only on the arguments: the same samples always give the same file.
    """
    if not samples:
        raise BadInput(f"shard {shard}: no samples to write")
    buf = io.BytesIO()
    n = len(samples)
    with h5py.File(buf, "w", libver=("earliest", "v110")) as f:
        f.attrs["format"] = FORMAT
        f.attrs["format_version"] = FORMAT_VERSION
        f.attrs["config"] = config.to_json()
        f.attrs["config_digest"] = config.digest
        f.attrs["shard"] = shard
        f.attrs["package_version"] = __version__
        f.attrs["rejections"] = json.dumps(dict(sorted(rejections.items())))
        for name in IMAGE_FIELDS + LABEL_FIELDS:
            dtype = np.float32 if name in _F32 else np.bool_
            arr = np.stack([np.asarray(getattr(s, name), dtype=dtype) for s in samples])
            chunks = (min(n, 64),) + arr.shape[1:] if arr.ndim > 1 else None
            f.create_dataset(name, data=arr, chunks=chunks, compression="gzip", compression_opts=4,
                             shuffle=arr.ndim > 1)
        f.create_dataset("index", data=np.array([s.index for s in samples], dtype=np.int64))
        f.create_dataset("attempt", data=np.asarray(attempts, dtype=np.int32))
        f.create_dataset("gender", data=np.array([s.gender.encode() for s in samples], dtype="S1"))
        f.create_dataset("partition", data=np.array([s.partition.encode() for s in samples], dtype="S32"))
        if samples[0].conditions is not None:  # randomised datasets: each sample's bed
            from pressurepose.sim.randomize import CONDITION_NAMES, RandomizationRanges

            f.create_dataset("conditions", data=np.stack([np.asarray(s.conditions, dtype=np.float32)
                                                          for s in samples]))
            f.attrs["condition_names"] = json.dumps(list(CONDITION_NAMES))
            f.attrs["randomization_ranges"] = json.dumps(dataclasses.asdict(RandomizationRanges()))
        if all(s.sites is not None for s in samples):  # pressed samples: the site under each taxel
            from pressurepose.body.sites import SITES

            f.create_dataset("sites", data=np.stack([np.asarray(s.sites, dtype=np.int8) for s in samples]),
                             chunks=(min(n, 64),) + np.shape(samples[0].sites), compression="gzip",
                             compression_opts=4)
            f.attrs["site_names"] = json.dumps(list(SITES))
    return buf.getvalue()


def _open_shard(path: Path) -> h5py.File:
    try:
        return h5py.File(path, "r")
    except (OSError, ValueError) as exc:
        raise BadInput(f"shard {path} is corrupt or truncated (cannot open as HDF5: {exc})") from None


def read_shard_arrays(path: Path, fields: Sequence[str] | None = None) -> dict[str, np.ndarray]:
    """All (or the named) datasets of a shard as numpy arrays; strings decoded to str arrays."""
    with _open_shard(path) as f:
        names = list(fields) if fields is not None else list(f.keys())
        out = {}
        for name in names:
            if name not in f:
                raise BadInput(f"shard {path} has no field {name!r}; it has {', '.join(f.keys())}")
            try:
                arr = stored_dataset(f, name, f"shard {path}")[()]
            except (OSError, ValueError) as exc:
                raise BadInput(f"shard {path}: field {name!r} is unreadable ({exc})") from None
            out[name] = arr.astype(str) if arr.dtype.kind == "S" else arr
        if "sites" in out:
            from pressurepose.body.sites import SITES

            names = json.loads(f.attrs.get("site_names", "[]"))
            if names != list(SITES):
                raise BadInput(f"shard {path} numbers its body sites {names}; this version's are {list(SITES)}")
        return out


def samples_from_arrays(arrays: dict[str, np.ndarray]) -> list[Sample]:
    """Rebuild :class:`Sample` objects from a shard's arrays."""
    n = len(arrays["index"])
    return [Sample(pressure=arrays["pressure"][i], force=arrays["force"][i], depth=arrays["depth"][i],
                   contact=arrays["contact"][i], betas=arrays["betas"][i], pose=arrays["pose"][i],
                   transl=arrays["transl"][i], joints=arrays["joints"][i], gender=str(arrays["gender"][i]),
                   mass=float(arrays["mass"][i]), height=float(arrays["height"][i]),
                   partition=str(arrays["partition"][i]), index=int(arrays["index"][i]),
                   conditions=arrays["conditions"][i] if "conditions" in arrays else None,
                   sites=arrays["sites"][i] if "sites" in arrays else None)
            for i in range(n)]


# --------------------------------------------------------------------------- manifest


@dataclass
class ShardRecord:
    """What the manifest knows about one finished shard."""

    file: str
    sha256: str
    count: int
    attempts: int
    rejections: dict[str, int] = field(default_factory=dict)


@dataclass
class Manifest:
    """The dataset's manifest (``manifest.json``): config, version, per-shard checksums and stats."""

    config: GenerationConfig
    package_version: str = __version__
    shards: dict[int, ShardRecord] = field(default_factory=dict)
    created: str = ""
    complete: bool = False
    provenance: dict = field(default_factory=dict)

    @property
    def samples_done(self) -> int:
        return sum(r.count for r in self.shards.values())

    @property
    def attempts(self) -> int:
        return sum(r.attempts for r in self.shards.values())

    @property
    def rejections(self) -> dict[str, int]:
        total: dict[str, int] = {}
        for r in self.shards.values():
            for cause, n in r.rejections.items():
                total[cause] = total.get(cause, 0) + n
        return dict(sorted(total.items()))

    def to_dict(self) -> dict[str, Any]:
        attempts = self.attempts
        rejected = sum(self.rejections.values())
        return {
            "format": FORMAT, "format_version": FORMAT_VERSION,
            "package_version": self.package_version, "created": self.created,
            "config": self.config.to_dict(), "config_digest": self.config.digest,
            "complete": self.complete, "num_shards": self.config.num_shards,
            **({"provenance": self.provenance} if self.provenance else {}),
            "counts": {"samples": self.samples_done, "target": self.config.count, "attempts": attempts,
                       "rejected": rejected, "rejection_rate": (rejected / attempts) if attempts else 0.0,
                       "rejections": self.rejections},
            "shards": {shard_name(k): {"sha256": r.sha256, "count": r.count, "attempts": r.attempts,
                                       "rejections": r.rejections}
                       for k, r in sorted(self.shards.items())},
        }

    def save(self, directory: Path) -> None:
        write_bytes_atomic(Path(directory) / MANIFEST, (json_text(self.to_dict()) + "\n").encode())

    @classmethod
    def new(cls, config: GenerationConfig, provenance: dict | None = None) -> "Manifest":
        """A manifest for a dataset about to be made; ``provenance``: the producer's constants
        (:func:`pressurepose.data.physics.provenance`), kept as written."""
        return cls(config=config, created=time.strftime("%Y-%m-%dT%H:%M:%S%z"), provenance=dict(provenance or {}))

    @classmethod
    def load(cls, directory: Path) -> "Manifest":
        path = Path(directory) / MANIFEST
        try:
            raw = json.loads(path.read_text())
        except FileNotFoundError:
            raise BadInput(f"{directory} is not a pressurepose dataset (no {MANIFEST})") from None
        except (json.JSONDecodeError, UnicodeDecodeError) as exc:
            raise BadInput(f"manifest {path} is corrupt ({exc}); {REPAIR_HINT}") from None
        if not isinstance(raw, dict) or raw.get("format") != FORMAT:
            raise BadInput(f"manifest {path} is not a {FORMAT} manifest; {REPAIR_HINT}")
        if raw.get("format_version") != FORMAT_VERSION:
            raise BadInput(f"manifest {path} has format version {raw.get('format_version')}; "
                           f"this pressurepose reads version {FORMAT_VERSION}")
        config = GenerationConfig.from_dict(raw.get("config"), what=f"manifest {path} config")
        shards = {}
        for name, rec in raw.get("shards", {}).items():
            try:
                k = int(name.removeprefix("shard-").removesuffix(".h5"))
                shards[k] = ShardRecord(file=name, sha256=str(rec["sha256"]), count=int(rec["count"]),
                                        attempts=int(rec["attempts"]),
                                        rejections={str(c): int(v) for c, v in rec.get("rejections", {}).items()})
            except (KeyError, TypeError, ValueError) as exc:
                raise BadInput(f"manifest {path}: bad entry for {name!r} ({exc})") from None
        prov = raw.get("provenance", {})
        if not isinstance(prov, dict):
            raise BadInput(f"manifest {path}: 'provenance' is {type(prov).__name__}; expected an object. {REPAIR_HINT}")
        for section, retired in RETIRED_SETTINGS.items():
            record = prov.get(section)
            if isinstance(record, dict):
                prov = {**prov, section: {k: v for k, v in record.items() if not (k in retired and v == retired[k])}}
        return cls(config=config, package_version=str(raw.get("package_version", "")), shards=shards,
                   created=str(raw.get("created", "")), complete=bool(raw.get("complete", False)), provenance=prov)


def verify_shard(directory: Path, record: ShardRecord) -> str | None:
    """None if the shard file's sha256 matches its record, else a sentence saying what is wrong."""
    path = Path(directory) / record.file
    if not path.is_file():
        return f"{path} is missing"
    digest = sha256_file(path)
    if digest != record.sha256:
        return (f"{path} is corrupt or truncated: sha256 {digest[:16]}... does not match the "
                f"manifest's {record.sha256[:16]}...")
    return None


def write_dataset(out: Path, config: GenerationConfig, samples: Sequence[Sample]) -> Manifest:
    """Write already-made samples (e.g. converted from another format) as a complete dataset in a new
    or empty directory ``out``: shards of ``config.shard_size``, checksums, manifest. Sample ``i``
    must have index ``i``; ``config.count`` must equal ``len(samples)``. Refuses a non-empty ``out``."""
    out = Path(out)
    if out.exists() and any(out.iterdir()):
        raise BadInput(f"{out} is not empty; nothing was written (choose a new directory)")
    if len(samples) != config.count:
        raise BadInput(f"{len(samples)} samples for a config of count {config.count}")
    out.mkdir(parents=True, exist_ok=True)
    manifest = Manifest.new(config)
    for k in range(config.num_shards):
        part = [samples[i] for i in config.shard_range(k)]
        for i, s in zip(config.shard_range(k), part):
            if s.index != i:
                raise BadInput(f"sample at position {i} has index {s.index}; expected {i}")
        data = encode_shard(config, k, part, [0] * len(part), {})
        tmp = stage_bytes(out / shard_name(k), data)
        manifest.shards[k] = ShardRecord(shard_name(k), sha256_bytes(data), len(part), len(part), {})
        manifest.save(out)
        commit(tmp, out / shard_name(k))
    manifest.complete = True
    manifest.save(out)
    return manifest
