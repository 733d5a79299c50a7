"""Sampler API: determinism by seed, independence of batching, bad input, the file and the CLI."""

import numpy as np
import pytest

from pressurepose.body import BodyModel
from pressurepose.body.toy import toy_body_arrays
from pressurepose.cli import main
from pressurepose.errors import BadInput
from pressurepose.pose import (
    COUNTERS,
    SamplerConfig,
    body_rng,
    get_partition,
    load_samples,
    sample_bodies,
    sample_one,
)

FIELDS = ("betas", "pose", "transl", "joints", "bins", "roll", "yaw", "counts")


@pytest.fixture(scope="module")
def toy():
    return BodyModel(toy_body_arrays())


def same(a, b):
    return all(np.array_equal(getattr(a, f), getattr(b, f)) for f in FIELDS)


def test_same_seed_same_bodies_and_batching_does_not_matter(toy):
    a = sample_bodies("general", "f", 4, seed=7, body=toy)
    b = sample_bodies("general", "f", 4, seed=7, body=toy)
    assert same(a, b)
    c = sample_bodies("general", "f", 4, seed=8, body=toy)
    assert not np.allclose(a.pose, c.pose)
    head = sample_bodies("general", "f", 2, seed=7, body=toy)
    tail = sample_bodies("general", "f", 2, seed=7, body=toy, start=2)
    for i in range(4):
        part = head if i < 2 else tail
        np.testing.assert_array_equal(part.pose[i % 2], a.pose[i])
    one = sample_one("general", "f", body_rng(7, 3), body=toy)
    np.testing.assert_array_equal(one.pose, a.pose[3])
    np.testing.assert_array_equal(one.joints, a.joints[3])
    assert one.counts == a[3].counts and set(one.counts) == set(COUNTERS)


def test_blocks_do_not_change_the_bodies(toy, monkeypatch):
    from pressurepose.pose import sampler

    whole = sample_bodies("general_supine", "f", 5, seed=3, body=toy)
    monkeypatch.setattr(sampler, "BLOCK", 2)
    assert same(sample_bodies("general_supine", "f", 5, seed=3, body=toy), whole)


def test_default_mattress_is_the_default_beds():
    bed = pytest.importorskip("pressurepose.sim.bed")
    from pressurepose.pose import mattress_outline

    np.testing.assert_allclose(SamplerConfig().mattress, mattress_outline(bed.BedSpec()), atol=1e-12)


def test_aliases_and_genders(toy):
    assert get_partition("supine").name == "general_supine"
    b = sample_bodies("straight_limbs", "male", 2, 0, body=toy)
    assert b.partition == "supine_straight_limbs" and b.gender == "m"


@pytest.mark.parametrize("kwargs,words", [
    (dict(partition="sitting"), ["sitting", "general", "hands_behind_head", "supine_crossed_legs"]),
    (dict(gender="x"), ["gender", "f or m"]),
    (dict(gender="n"), ["gender"]),
    (dict(count=0), ["count", ">= 1"]),
    (dict(count=-3), ["count"]),
    (dict(count=2.5), ["count"]),
    (dict(count=True), ["count"]),
    (dict(seed=-1), ["seed"]),
    (dict(seed="1"), ["seed"]),
])
def test_bad_input_names_what_is_expected(toy, kwargs, words):
    args = dict(partition="general", gender="f", count=2, seed=0) | kwargs
    with pytest.raises(BadInput) as e:
        sample_bodies(args["partition"], args["gender"], args["count"], args["seed"], body=toy)
    for w in words:
        assert w in str(e.value)


@pytest.mark.parametrize("kwargs", [dict(yaw_max=-1.0), dict(height_band=float("nan")), dict(bin_patience=0),
                                    dict(mattress=(1.0, 0.0, 0.0, 2.0)), dict(candidates_per_round=True),
                                    dict(height_reference="floor"), dict(bed_height_band=(0.3, -0.1)),
                                    dict(bed_height_band=(0.0, float("inf")))])
def test_bad_config(kwargs):
    with pytest.raises(BadInput):
        SamplerConfig(**kwargs)


def test_sample_one_wants_a_generator(toy):
    with pytest.raises(BadInput, match="Generator"):
        sample_one("general", "f", 3, body=toy)


def test_file_round_trip_and_corrupt_file(toy, tmp_path):
    b = sample_bodies("prone_hands_up", "m", 3, 5, limbs_on_bed=True, body=toy)
    path = tmp_path / "s.npz"
    b.save(path)
    c = load_samples(path)
    assert same(b, c) and (c.gender, c.partition, c.limbs_on_bed, c.seed) == ("m", "prone_hands_up", True, 5)
    with np.load(path) as z:
        assert dict(zip(z["rejection_causes"], z["rejection_counts"])) == b.rejections
    (tmp_path / "bad.npz").write_bytes(b"not a zip")
    with pytest.raises(BadInput, match="bad.npz"):
        load_samples(tmp_path / "bad.npz")
    np.savez(tmp_path / "other.npz", betas=np.zeros((1, 10)))
    with pytest.raises(BadInput, match="lacks"):
        load_samples(tmp_path / "other.npz")


def test_a_sample_file_with_the_retired_into_bed_counter_reads(toy, tmp_path):
    """A sample file holding a counter column for the opt-in into_bed limb test (after "bin";
    docs/not-adopted.md) reads: the column is dropped and every other counter keeps its value."""
    from pressurepose.pose.samples import COUNTERS

    b = sample_bodies("general", "f", 3, 4, body=toy)
    path = tmp_path / "new.npz"
    b.save(path)
    with np.load(path) as z:
        d = dict(z)
    at = COUNTERS.index("bin") + 1
    d["counters"] = np.array([*COUNTERS[:at], "into_bed", *COUNTERS[at:]])
    d["counts"] = np.insert(b.counts, at, 7, axis=1)
    np.savez(tmp_path / "old.npz", **d)
    old = load_samples(tmp_path / "old.npz")
    np.testing.assert_array_equal(old.counts, b.counts)
    assert old.rejections == b.rejections and same(old, b)
    d["counters"] = np.array([*COUNTERS[:at], "mystery", *COUNTERS[at:]])
    np.savez(tmp_path / "odd.npz", **d)
    with pytest.raises(BadInput, match="mystery"):
        load_samples(tmp_path / "odd.npz")


def test_cli_writes_samples_and_a_plot(female, tmp_path, capsys):
    out, png = tmp_path / "s.npz", tmp_path / "s.png"
    rc = main(["sample", "--partition", "supine", "--gender", "f", "--limbs-on-bed", "--count", "3", "--seed", "2",
               "--out", str(out), "--plot", str(png)])
    assert rc == 0
    b = load_samples(out)
    assert b.pose.shape == (3, 72) and b.joints.shape == (3, 24, 3) and b.betas.shape == (3, 10)
    assert b.partition == "general_supine" and b.limbs_on_bed
    assert png.stat().st_size > 10_000
    assert "rejected" in capsys.readouterr().out


def test_cli_bad_partition_is_a_clear_error(tmp_path, capsys):
    rc = main(["sample", "--partition", "nope", "--gender", "f", "--count", "1", "--seed", "0",
               "--out", str(tmp_path / "x.npz")])
    assert rc == 2
    err = capsys.readouterr().err
    assert "nope" in err and "general_supine" in err




def test_a_body_or_limbs_on_bed_of_the_wrong_kind_is_refused(toy):
    """body='female' or 3 was an AttributeError deep in the sampler; limbs_on_bed='no' was true."""
    for body in ("female", 3):
        with pytest.raises(BadInput, match=r"^body is \w+; expected a BodyModel"):
            sample_bodies("general", "f", 1, seed=0, body=body)
    for flag in ("no", None, 1):
        with pytest.raises(BadInput, match=r"^limbs_on_bed is .*; expected True or False"):
            sample_bodies("general", "f", 1, seed=0, limbs_on_bed=flag, body=toy)
        with pytest.raises(BadInput, match=r"^limbs_on_bed is .*; expected True or False"):
            sample_one("general", "f", body_rng(0, 0), limbs_on_bed=flag, body=toy)
    assert sample_bodies("general", "f", 1, seed=0, limbs_on_bed=np.bool_(True), body=toy).limbs_on_bed is True
