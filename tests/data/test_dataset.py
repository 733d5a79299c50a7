"""Reading datasets back: indexing, iteration, concatenation, float16 loading, the torch Dataset."""

import numpy as np
import pytest
import torch

from pressurepose.data.dataset import DatasetReader
from pressurepose.data.generate import generate
from pressurepose.data.store import read_shard_arrays, shard_name
from pressurepose.data.torch_dataset import PressureDataset
from pressurepose.errors import BadInput
from tests.data.helpers import small_config


@pytest.fixture(scope="module")
def two_datasets(tmp_path_factory):
    root = tmp_path_factory.mktemp("mix")
    generate(small_config(count=9, shard_size=4), root / "a", progress=False)
    generate(small_config(count=5, shard_size=4, gender="m", partition="prone_hands_up", limbs_on_bed=True),
             root / "b", progress=False)
    return root


def test_reader_indexes_and_iterates_across_shards_and_datasets(two_datasets):
    r = DatasetReader(two_datasets)
    assert len(r) == 14 and len(r.datasets) == 2 and len(r.shards) == 5
    items = list(r)
    assert [s.index for s in items] == list(range(9)) + list(range(5))
    assert [s.gender for s in items] == ["f"] * 9 + ["m"] * 5
    assert r[10].partition == "prone_hands_up" and r[10].index == 1 and r[-1].index == 4
    direct = read_shard_arrays(two_datasets / "a" / shard_name(1))
    assert np.array_equal(r[5].pressure, direct["pressure"][1])
    with pytest.raises(IndexError):
        r[14]


def test_load_arrays_float16_images_match_the_shards(two_datasets):
    a = DatasetReader(two_datasets).load_arrays()
    assert a["pressure"].dtype == np.float16 and a["pressure"].shape == (14, 64, 27)
    assert a["joints"].dtype == np.float32 and a["joints"].shape == (14, 24, 3)
    assert a["contact"].dtype == np.bool_
    ref = np.concatenate([read_shard_arrays(two_datasets / d / shard_name(k))["pressure"]
                          for d, n in (("a", 3), ("b", 2)) for k in range(n)])
    np.testing.assert_allclose(a["pressure"], ref, rtol=1e-3, atol=1e-3)
    assert list(a["gender"]) == [0] * 9 + [1] * 5
    with pytest.raises(BadInput, match="unknown fields"):
        DatasetReader(two_datasets).load_arrays(["pressure", "colour"])


def test_torch_dataset_yields_tensors_of_the_right_shapes(two_datasets):
    ds = PressureDataset(two_datasets)
    assert isinstance(ds, torch.utils.data.Dataset) and len(ds) == 14
    item = ds[3]
    shapes = {k: tuple(v.shape) for k, v in item.items()}
    assert shapes == {"pressure": (64, 27), "contact": (64, 27), "betas": (10,), "pose": (72,), "transl": (3,),
                      "joints": (24, 3), "mass": (), "height": (), "gender": (), "partition": (), "index": ()}
    assert item["pressure"].dtype == torch.float32 and item["contact"].dtype == torch.bool
    assert item["index"].dtype == torch.int64
    batch = next(iter(torch.utils.data.DataLoader(ds, batch_size=8)))
    assert batch["pressure"].shape == (8, 64, 27) and batch["joints"].shape == (8, 24, 3)
    assert ds.tensors["pressure"].dtype == torch.float16
    half = PressureDataset(two_datasets, image_dtype=torch.float16)
    assert half[0]["pressure"].dtype == torch.float16


def test_incomplete_dataset_is_refused_unless_allowed(tmp_path):
    generate(small_config(count=12, shard_size=6), tmp_path / "d", progress=False, only_shards=[1])
    with pytest.raises(BadInput, match=r"incomplete \(1 of 2 shards\)"):
        DatasetReader(tmp_path / "d")
    r = DatasetReader(tmp_path / "d", allow_incomplete=True)
    assert [s.index for s in r] == list(range(6, 12))


def test_missing_dataset_is_bad_input(tmp_path):
    with pytest.raises(BadInput, match="does not exist"):
        DatasetReader(tmp_path / "nothing")
    with pytest.raises(BadInput, match="no pressurepose dataset"):
        DatasetReader(tmp_path)
