"""`pressurepose repress`: a dataset's resting bodies pressed again on another bed."""

import dataclasses
import json

import numpy as np
import pytest

from pressurepose.data.dataset import DatasetReader
from pressurepose.data.repress import PRESS_ONLY, repress, repress_config
from pressurepose.data.schema import GenerationConfig
from pressurepose.data.store import MANIFEST, Manifest
from pressurepose.errors import BadInput
from pressurepose.sim.bed import get_bed
from pressurepose.sim.randomize import draw_conditions

FIELDS = ("pressure", "force", "betas", "joints", "mass")


@pytest.fixture(scope="module")
def source(tmp_path_factory):
    """A small randomised physics dataset in two shards."""
    from pressurepose.data.generate import generate

    out = tmp_path_factory.mktemp("repress") / "src"
    config = GenerationConfig(partition="supine_straight_limbs", gender="m", count=3, seed=5, shard_size=2,
                              randomize=True)
    generate(config, out, progress=False)
    return out


def _conditions(root):
    return np.concatenate([np.asarray(s.conditions) for s in DatasetReader(root)])


def test_conditions_rebased_are_the_same_draws_about_the_new_bed():
    old = get_bed()
    new = get_bed(stiffness_n_m3=5e4, tissue_modulus_pa=900.0, sensor_threshold_mmhg=2.0)
    a = draw_conditions(np.random.default_rng(4), old)
    b = draw_conditions(np.random.default_rng(4), new)
    np.testing.assert_allclose(a.rebased(old, new).as_array(), b.as_array(), rtol=1e-12)
    assert a.rebased(old, old) == a


def test_repressed_on_its_own_bed_the_images_come_back(source, tmp_path):
    """The press from the labelled pose is a fixed point up to its first-order tilt solve: the
    images agree with the stored ones (correlation >= 0.995) and the joints within 3 mm."""
    repress(source, tmp_path / "same", Manifest.load(source).config.bed_spec(), progress=False)
    a = DatasetReader(source).load_arrays(FIELDS, image_dtype=np.float64, label_dtype=np.float64)
    b = DatasetReader(tmp_path / "same").load_arrays(FIELDS, image_dtype=np.float64, label_dtype=np.float64)
    assert len(b["mass"]) == len(a["mass"]) == 3
    np.testing.assert_array_equal(a["betas"], b["betas"])
    for pa, pb in zip(a["pressure"], b["pressure"]):
        assert np.corrcoef(pa.ravel(), pb.ravel())[0, 1] >= 0.995
    np.testing.assert_allclose(a["force"].sum((1, 2)), b["force"].sum((1, 2)), rtol=0.01)
    assert np.abs(a["joints"] - b["joints"]).max() < 0.003
    np.testing.assert_allclose(_conditions(tmp_path / "same"), _conditions(source), rtol=1e-6)


def test_softer_tissue_spreads_the_same_bodies(source, tmp_path):
    """On tissue three times softer the same bodies sink further and spread the same weight over
    more taxels; the output says where it came from and what bed it is on."""
    from pressurepose.data.info import format_summary, summarize

    bed = get_bed(tissue_modulus_pa=1000.0)
    repress(source, tmp_path / "soft", bed, progress=False)
    a = DatasetReader(source).load_arrays(FIELDS)
    b = DatasetReader(tmp_path / "soft").load_arrays(FIELDS)
    assert ((b["force"] > 0).sum((1, 2)) > (a["force"] > 0).sum((1, 2))).all()
    fa, fb = (x["force"].astype(float).sum((1, 2)) for x in (a, b))
    assert (fb <= 1.001 * b["mass"].astype(float) * 9.81).all()  # the sensing area carries at most the body
    np.testing.assert_allclose(fb, fa, rtol=0.05)  # a spread imprint may put a little off its edge
    m = json.loads((tmp_path / "soft" / MANIFEST).read_text())
    assert m["config"]["bed"]["tissue_modulus_pa"] == 1000.0 and m["complete"]
    assert m["provenance"]["repressed_from"]["config_digest"] == Manifest.load(source).config.digest
    src = Manifest.load(source).provenance  # the rests' sampler and settle constants stay on record
    assert m["provenance"]["settle"] == src["settle"] and m["provenance"]["sampler"] == src["sampler"]
    assert m["provenance"]["bed"]["tissue_modulus_pa"] == 1000.0
    # the draws are re-based: tissue modulus a third of the source's, the rest as drawn
    np.testing.assert_allclose(_conditions(tmp_path / "soft")[1::7], _conditions(source)[1::7] / 3, rtol=1e-5)
    assert "re-pressed (pressurepose repress) from" in format_summary(summarize(tmp_path / "soft", examples=0))


def test_an_interrupted_repress_resumes_to_the_same_bytes(source, tmp_path, monkeypatch):
    from pressurepose.data import repress as R

    bed = get_bed(sensor_threshold_mmhg=3.0)
    repress(source, tmp_path / "whole", bed, progress=False)
    calls = {"n": 0}
    real = R.repress_sample

    def dies_on_the_third(*args):
        calls["n"] += 1
        if calls["n"] == 3:
            raise KeyboardInterrupt
        return real(*args)

    monkeypatch.setattr(R, "repress_sample", dies_on_the_third)
    with pytest.raises(KeyboardInterrupt):
        repress(source, tmp_path / "cut", bed, progress=False)
    assert len(Manifest.load(tmp_path / "cut").shards) == 1  # the first shard was committed
    monkeypatch.setattr(R, "repress_sample", real)
    repress(source, tmp_path / "cut", bed, progress=False)
    whole, cut = Manifest.load(tmp_path / "whole"), Manifest.load(tmp_path / "cut")
    assert cut.complete and {k: r.sha256 for k, r in cut.shards.items()} == {k: r.sha256 for k, r in whole.shards.items()}
    # a different bed into the same output is refused, and nothing changes
    with pytest.raises(BadInput, match="another dataset"):
        repress(source, tmp_path / "cut", get_bed(sensor_threshold_mmhg=1.0), progress=False)


def test_what_cannot_be_re_pressed_is_refused(source, tmp_path):
    config = Manifest.load(source).config
    with pytest.raises(BadInput, match="stiffness_n_m3"):
        repress_config(config, get_bed(stiffness_n_m3=5e4))
    with pytest.raises(BadInput, match="wedge"):
        repress_config(dataclasses.replace(config, partition="propped_lateral"), get_bed())
    with pytest.raises(BadInput, match="producer 'synthetic'"):
        repress_config(dataclasses.replace(config, producer="synthetic"), get_bed())
    assert set(PRESS_ONLY) <= {f.name for f in dataclasses.fields(type(get_bed()))}
    (tmp_path / "full").mkdir()
    (tmp_path / "full" / "notes.txt").write_text("mine")
    with pytest.raises(BadInput, match="not empty"):
        repress(source, tmp_path / "full", get_bed(), progress=False)
    with pytest.raises(BadInput, match="holds no pressurepose dataset"):
        repress(tmp_path / "full", tmp_path / "x", get_bed(), progress=False)


def test_a_corrupt_source_shard_is_named(source, tmp_path):
    import shutil

    copy = tmp_path / "src"
    shutil.copytree(source, copy)
    shard = sorted(copy.glob("shard-*.h5"))[1]
    shard.write_bytes(shard.read_bytes()[:100])
    with pytest.raises(BadInput, match="corrupt or truncated"):
        repress(copy, tmp_path / "out", get_bed(), progress=False)
    assert len(Manifest.load(tmp_path / "out").shards) == 1  # what was made before it is kept


def test_the_repress_command(source, tmp_path, capsys):
    from pressurepose.cli import main

    (tmp_path / "bed.json").write_text(json.dumps({"bed": get_bed(tissue_modulus_pa=2000.0).to_dict()}))
    assert main(["repress", str(source), "--bed", str(tmp_path / "bed.json"), "--out", str(tmp_path / "o"),
                 "--no-progress"]) == 0
    assert "re-pressed 3 samples of 1 dataset(s)" in capsys.readouterr().out
    assert main(["repress", str(source), "--bed", str(tmp_path / "bed.json"), "--out", str(source / "o"),
                 "--no-progress"]) == 2
    assert "inside the source" in capsys.readouterr().err


def test_a_recipe_folder_with_a_wedge_partition(source, tmp_path):
    """A folder holding a wedge partition's dataset is refused as a whole, naming it, unless
    --skip-wedge leaves that dataset out."""
    import shutil

    from pressurepose.data.store import write_dataset

    root = tmp_path / "recipe"
    shutil.copytree(source, root / "plain")
    samples = list(DatasetReader(source))[:1]
    write_dataset(root / "propped", GenerationConfig(partition="propped_lateral", gender="m", count=1, seed=1),
                  samples)
    with pytest.raises(BadInput, match="propped.*--skip-wedge"):
        repress(root, tmp_path / "out", get_bed(), progress=False)
    assert not (tmp_path / "out").exists()  # refused before anything was written
    made = repress(root, tmp_path / "out", get_bed(), progress=False, skip_wedge=True)
    assert len(made) == 1 and (tmp_path / "out" / "plain" / MANIFEST).exists()
    assert not (tmp_path / "out" / "propped").exists()
