"""Config and sample validation, atomic writes, checksums, refusing foreign or corrupt data."""

import errno
import json
import os

import numpy as np
import pytest

from pressurepose.data.generate import generate
from pressurepose.data.schema import PAPER_SAMPLING, GenerationConfig, Sample
from pressurepose.data.store import MANIFEST, Manifest, sha256_file, shard_name
from pressurepose.errors import BadInput
from pressurepose.files import write_bytes_atomic
from tests.data.helpers import small_config


def _listing(path):
    return {p.name: p.read_bytes() for p in sorted(path.iterdir())}


def test_config_rejects_unknown_partition_gender_mat_and_counts():
    with pytest.raises(BadInput, match="partition 'sideways' is not known"):
        GenerationConfig(partition="sideways", gender="f")
    with pytest.raises(BadInput, match="gender"):
        GenerationConfig(partition="general", gender="x")
    with pytest.raises(BadInput, match="mat preset 'nope'"):
        GenerationConfig(partition="general", gender="f", mat="nope")
    with pytest.raises(BadInput, match="count"):
        GenerationConfig(partition="general", gender="f", count=0)
    with pytest.raises(BadInput, match="seed"):
        GenerationConfig(partition="general", gender="f", seed=-1)


def test_config_json_round_trip_and_digest():
    c = small_config(options={"reject_rate": 0.2, "cost_ms": 1}, gender="female", mat="SLP")
    assert c.gender == "f" and c.mat == "slp"
    back = GenerationConfig.from_json(c.to_json())
    assert back == c and back.digest == c.digest
    assert small_config(seed=8).digest != c.digest
    with pytest.raises(BadInput, match="unknown keys"):
        GenerationConfig.from_dict({**c.to_dict(), "colour": "red"})


def test_shard_ranges_cover_every_index_once():
    c = small_config(count=20, shard_size=6)
    assert c.num_shards == 4
    seen = [i for k in range(c.num_shards) for i in c.shard_range(k)]
    assert seen == list(range(20))


def test_sample_validate_names_the_bad_field():
    z = np.zeros((64, 27), np.float32)
    good = dict(pressure=z, force=z, depth=z, contact=z > 0, betas=np.zeros(10), pose=np.zeros(72),
                transl=np.zeros(3), joints=np.zeros((24, 3)), gender="f", mass=60.0, height=1.6,
                partition="general")
    Sample(**good).validate((64, 27))
    with pytest.raises(BadInput, match=r"pressure has shape \(60, 27\); the mat is 64 x 27"):
        Sample(**{**good, "pressure": np.zeros((60, 27))}).validate((64, 27))
    with pytest.raises(BadInput, match="joints has shape"):
        Sample(**{**good, "joints": np.zeros((23, 3))}).validate((64, 27))
    with pytest.raises(BadInput, match="betas contains NaN"):
        Sample(**{**good, "betas": np.full(10, np.nan)}).validate((64, 27))
    with pytest.raises(BadInput, match=">= 0"):
        Sample(**{**good, "pressure": -np.ones((64, 27))}).validate((64, 27))


def test_taxel_sites_round_trip_and_a_shard_without_them_still_reads(tmp_path):
    import h5py

    from pressurepose.body.sites import SITES
    from pressurepose.data.store import encode_shard, read_shard_arrays, samples_from_arrays

    z = np.zeros((64, 27), np.float32)
    sites = np.full((64, 27), -1, np.int8)
    sites[3:6, 10:14] = SITES.index("head")
    sites[30:36, 8:18] = SITES.index("sacrum")
    good = dict(pressure=z, force=z, depth=z, contact=z > 0, betas=np.zeros(10), pose=np.zeros(72),
                transl=np.zeros(3), joints=np.zeros((24, 3)), gender="f", mass=60.0, height=1.6,
                partition="general")
    config = small_config()
    for with_sites in (True, False):
        sample = Sample(**good, index=0, sites=sites if with_sites else None).validate((64, 27))
        path = tmp_path / f"shard-{with_sites}.h5"
        path.write_bytes(encode_shard(config, 0, [sample], [1], {}))
        back = samples_from_arrays(read_shard_arrays(path))[0]
        if with_sites:
            np.testing.assert_array_equal(back.sites, sites)
        else:
            assert back.sites is None  # made before sites were recorded: the field is absent
    with pytest.raises(BadInput, match="sites has shape"):
        Sample(**good, sites=np.full((64, 27), len(SITES), np.int8)).validate((64, 27))
    with pytest.raises(BadInput, match="sites has shape"):
        Sample(**good, sites=sites[:10]).validate((64, 27))
    with h5py.File(tmp_path / "shard-True.h5", "a") as f:  # numbered by another list of sites
        f.attrs["site_names"] = json.dumps(list(reversed(SITES)))
    with pytest.raises(BadInput, match="numbers its body sites"):
        read_shard_arrays(tmp_path / "shard-True.h5")


def test_partial_temp_file_is_never_taken_for_a_shard(tmp_path):
    c = small_config(count=12, shard_size=6)
    out = tmp_path / "d"
    generate(c, out, progress=False, only_shards=[0])
    # an interrupted write of shard 1 leaves a hidden temp file with part of a shard in it
    partial = out / f".{shard_name(1)}.tmp-999-abcd"
    partial.write_bytes((out / shard_name(0)).read_bytes()[:1000])
    from pressurepose.data.dataset import DatasetReader
    with pytest.raises(BadInput, match="incomplete"):
        DatasetReader(out)
    assert len(DatasetReader(out, allow_incomplete=True)) == 6  # the temp file is not a shard
    generate(c, out, progress=False)
    assert not partial.exists()
    assert sorted(p.name for p in out.iterdir()) == [MANIFEST, shard_name(0), shard_name(1)]
    assert len(DatasetReader(out)) == 12


def test_full_disk_leaves_no_temp_file_and_keeps_the_target(tmp_path, monkeypatch):
    target = tmp_path / "x.bin"
    target.write_bytes(b"old")

    def no_space(fd):
        raise OSError(errno.ENOSPC, "No space left on device")

    monkeypatch.setattr(os, "fsync", no_space)
    with pytest.raises(BadInput, match="no space left"):
        write_bytes_atomic(target, b"new content")
    assert target.read_bytes() == b"old"
    assert [p.name for p in tmp_path.iterdir()] == ["x.bin"]


@pytest.mark.parametrize("damage", ["truncate", "flip"])
def test_corrupt_or_truncated_shard_is_named_and_not_overwritten(tmp_path, damage):
    c = small_config(count=12, shard_size=6)
    out = tmp_path / "d"
    generate(c, out, progress=False)
    path = out / shard_name(1)
    data = bytearray(path.read_bytes())
    if damage == "truncate":
        data = data[: len(data) // 2]
    else:
        data[len(data) // 2] ^= 0xFF
    path.write_bytes(bytes(data))
    before = _listing(out)
    with pytest.raises(BadInput, match=r"shard-00001\.h5 is corrupt or truncated"):
        generate(c, out, progress=False)
    assert _listing(out) == before
    from pressurepose.data.dataset import DatasetReader
    with pytest.raises(BadInput, match=r"shard-00001\.h5 is corrupt"):
        DatasetReader(out)
    # --repair sets the bad shard aside and makes it again, identical to the original
    report = generate(c, out, progress=False, repair=True)
    assert report.made == 1
    assert sha256_file(path) == Manifest.load(out).shards[1].sha256
    assert len(list(out.glob("shard-00001.h5.corrupt-*"))) == 1


def test_manifest_of_another_config_is_refused_and_nothing_changes(tmp_path):
    out = tmp_path / "d"
    generate(small_config(count=12, shard_size=6), out, progress=False)
    before = _listing(out)
    with pytest.raises(BadInput, match=r"different config \(seed: 7 on disk vs 8 now\)"):
        generate(small_config(count=12, shard_size=6, seed=8), out, progress=False)
    with pytest.raises(BadInput, match="count: 12 on disk vs 13 now"):
        generate(small_config(count=13, shard_size=6), out, progress=False)
    # a setting the record leaves out at its default is named by that default
    with pytest.raises(BadInput, match="settle: 'relaxed' on disk vs 'paper' now"):
        generate(small_config(count=12, shard_size=6, settle="paper"), out, progress=False)
    assert _listing(out) == before


def test_other_package_version_and_stray_shards_are_refused(tmp_path):
    out = tmp_path / "d"
    c = small_config(count=6, shard_size=6)
    generate(c, out, progress=False)
    raw = json.loads((out / MANIFEST).read_text())
    raw["package_version"] = "0.0.1"
    (out / MANIFEST).write_text(json.dumps(raw))
    with pytest.raises(BadInput, match="made by pressurepose 0.0.1"):
        generate(c, out, progress=False)
    stray = tmp_path / "stray"
    stray.mkdir()
    (stray / shard_name(0)).write_bytes(b"not ours")
    with pytest.raises(BadInput, match="no manifest.json"):
        generate(c, stray, progress=False)
    assert (stray / shard_name(0)).read_bytes() == b"not ours"


def test_corrupt_manifest_is_reported(tmp_path):
    out = tmp_path / "d"
    generate(small_config(count=6, shard_size=6), out, progress=False)
    (out / MANIFEST).write_text("{ not json")
    with pytest.raises(BadInput, match="manifest .* is corrupt"):
        generate(small_config(count=6, shard_size=6), out, progress=False)


def test_sampler_settings_are_in_the_config_and_a_record_without_them_is_refused():
    new = GenerationConfig(partition="general", gender="f")
    assert (new.shapes, new.placement, new.hanging_limbs, new.randomize) == ("normal", "centred", False, False)
    assert (new.across_sd_m, new.across_sd_lateral_m) == (0.03, 0.08)
    partial = {k: v for k, v in new.to_dict().items() if k not in ("shapes", "placement")}
    with pytest.raises(BadInput, match="lacks placement, shapes"):
        GenerationConfig.from_dict(partial)
    # the spread does not touch the paper's uniform placement, nor its seed stream
    old = GenerationConfig(partition="general", gender="f", **PAPER_SAMPLING)
    paper = dict(shapes="uniform", placement="uniform", hanging_limbs=True)
    assert (GenerationConfig(partition="general", gender="f", **paper).stream_key
            == GenerationConfig(partition="general", gender="f", across_sd_lateral_m=0.03, **paper).stream_key
            == old.stream_key)
    # the paper's sampler keeps the seed key it always had; every other setting gets its own stream
    assert old.stream_key == int.from_bytes(__import__("hashlib").sha256(b"general|f|0").digest()[:4], "little")
    keys = {old.stream_key, new.stream_key,
            GenerationConfig(partition="general", gender="f", randomize=True).stream_key,
            GenerationConfig(partition="general", gender="f", placement="uniform").stream_key}
    assert len(keys) == 4
    assert GenerationConfig.from_json(new.to_json()) == new
    with pytest.raises(BadInput, match="placement"):
        GenerationConfig(partition="general", gender="f", placement="edge")
    with pytest.raises(BadInput, match="randomize"):
        GenerationConfig(partition="general", gender="f", randomize="yes")
    with pytest.raises(BadInput, match="across_sd_m"):
        GenerationConfig(partition="general", gender="f", across_sd_m=float("nan"))


def test_a_folder_of_other_files_is_refused_and_left_as_it_was(tmp_path):
    """--out pointed at a folder of the user's own files (a home or project folder) writes nothing there."""
    out = tmp_path / "notes"
    out.mkdir()
    (out / "thesis.tex").write_text("mine")
    (out / "figures").mkdir()
    before = sorted(p.name for p in out.iterdir())
    with pytest.raises(BadInput, match=r"not empty and holds no dataset \(figures, thesis.tex\)"):
        generate(small_config(count=6, shard_size=6), out, progress=False)
    assert sorted(p.name for p in out.iterdir()) == before and (out / "thesis.tex").read_text() == "mine"
    empty = tmp_path / "empty"
    empty.mkdir()
    assert generate(small_config(count=6, shard_size=6), empty, progress=False).made == 1


def test_a_shard_field_reaching_into_another_file_is_refused(tmp_path):
    """A shard's fields are read only from the shard: an external link (into any file the reader can
    open) is refused by name."""
    import h5py

    from pressurepose.data.store import read_shard_arrays

    with h5py.File(tmp_path / "other.h5", "w") as f:
        f["pressure"] = np.ones((1, 64, 27), np.float32)
    with h5py.File(tmp_path / "shard-00000.h5", "w") as f:
        f["pressure"] = h5py.ExternalLink(str(tmp_path / "other.h5"), "/pressure")
    with pytest.raises(BadInput, match=r"shard .*shard-00000.h5: 'pressure' is an external link"):
        read_shard_arrays(tmp_path / "shard-00000.h5", ["pressure"])


def test_options_that_are_not_a_mapping_of_settings_are_refused_by_name():
    """options='x' or [('a',)] were a ValueError from unpacking."""
    for options in ("x", [("a",)], 3):
        with pytest.raises(BadInput, match=r"^options = .*; expected a dict of producer settings"):
            small_config(options=options)
    assert small_config(options=[("reject_rate", 0.5)]).option("reject_rate") == 0.5
