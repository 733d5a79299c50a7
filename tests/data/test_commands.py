"""The generate and info verbs, and the paper recipe."""

import json
from pathlib import Path

import pytest

from pressurepose.cli import main
from pressurepose.data.dataset import DatasetReader
from pressurepose.data.recipes import load_recipe
from pressurepose.errors import BadInput


def test_generate_then_info(tmp_path, capsys):
    out = tmp_path / "d"
    rc = main(["generate", "--partition", "general_supine", "--gender", "m", "--limbs-on-bed", "--count", "10",
               "--shard-size", "4", "--seed", "3", "--producer", "synthetic", "--option", "reject_rate=0.3", "--out", str(out), "--no-progress"])
    assert rc == 0
    assert "10/10 samples, made 3 shard(s)" in capsys.readouterr().out
    rc = main(["generate", "--partition", "general_supine", "--gender", "m", "--limbs-on-bed", "--count", "10",
               "--shard-size", "4", "--seed", "3", "--producer", "synthetic", "--option", "reject_rate=0.3", "--out", str(out), "--no-progress"])
    assert "made 0 shard(s), kept 3" in capsys.readouterr().out
    assert main(["info", str(out), "--png", str(tmp_path / "i.png")]) == 0
    text = capsys.readouterr().out
    assert "general_supine" in text and "yes" in text and "rejected" in text and "pressure (mmHg)" in text
    assert (tmp_path / "i.png").stat().st_size > 10_000
    from pressurepose.data.info import summarize

    # 3 shards: 6 examples come 2 from each, 2 examples from the first two shards, 20 are all 10 samples
    for asked, got in ((6, 6), (2, 2), (20, 10), (0, 0)):
        assert len(summarize(out, examples=asked).examples) == got


def test_bad_input_is_reported_not_raised(tmp_path, capsys):
    rc = main(["generate", "--partition", "sideways", "--gender", "f", "--count", "3", "--out", str(tmp_path / "x")])
    assert rc == 2 and "partition 'sideways' is not known" in capsys.readouterr().err
    assert not (tmp_path / "x").exists()
    rc = main(["generate", "--partition", "general", "--out", str(tmp_path / "y")])
    assert rc == 2 and "give --gender, --count" in capsys.readouterr().err


def test_help_says_the_synthetic_producer_is_not_physics(capsys):
    with pytest.raises(SystemExit):
        main(["generate", "--help"])
    assert "NOT physics" in " ".join(capsys.readouterr().out.split())


def test_recipe_file_runs_every_entry(tmp_path, capsys):
    recipe = tmp_path / "r.json"
    recipe.write_text(json.dumps({"format": "pressurepose-recipe", "entries": [
        {"name": "train/a", "split": "train", "partition": "general", "gender": "f", "count": 6, "seed": 1},
        {"name": "test/a", "split": "test", "partition": "general", "gender": "f", "count": 4, "seed": 2}]}))
    assert main(["generate", "--recipe", str(recipe), "--producer", "synthetic", "--out", str(tmp_path / "o"),
                 "--no-progress"]) == 0
    assert len(DatasetReader(tmp_path / "o")) == 10 and len(DatasetReader(tmp_path / "o" / "test")) == 4


def test_paper_recipe_matches_the_paper_table():
    entries = load_recipe("paper")
    train = {(e.config.partition, e.config.gender, e.config.limbs_on_bed): e.config.count
             for e in entries if e.split == "train"}
    test = {(e.config.partition, e.config.gender, e.config.limbs_on_bed): e.config.count
            for e in entries if e.split == "test"}
    assert sum(train.values()) == 184_000 and sum(test.values()) == 22_000
    by_partition = {}
    for (p, _, _), n in [*train.items(), *test.items()]:
        by_partition[p] = by_partition.get(p, 0) + n
    # paper section 5.1: general 116K, supine 58K, hands behind head 5K, prone hands up 9K, crossed 9K, straight 9K
    assert by_partition == {"general": 116_000, "general_supine": 58_000, "hands_behind_head": 5_000,
                            "prone_hands_up": 9_000, "supine_crossed_legs": 9_000, "supine_straight_limbs": 9_000}
    assert train[("supine_crossed_legs", "m", False)] == 2000 and ("supine_crossed_legs", "m", False) not in test
    assert {e.config.seed for e in entries if e.split == "train"} != {e.config.seed for e in entries if e.split == "test"}
    small = load_recipe("paper", scale=0.001)
    assert [e.config.count for e in small] == [max(1, round(e.config.count / 1000)) for e in entries]


def test_recipe_entries_that_would_share_bodies_are_refused(tmp_path):
    recipe = tmp_path / "r.json"
    recipe.write_text(json.dumps({"format": "pressurepose-recipe", "entries": [
        {"name": "a", "partition": "general", "gender": "f", "count": 6, "seed": 1},
        {"name": "b", "partition": "general", "gender": "f", "count": 4, "seed": 1}]}))
    with pytest.raises(BadInput, match="same partition, gender, limbs_on_bed and seed"):
        load_recipe(recipe)


def test_info_refuses_to_pool_datasets_of_different_mats(tmp_path, capsys):
    for name, mat in (("a", "boditrak_bt3510"), ("b", "tip")):
        assert main(["generate", "--partition", "general", "--gender", "f", "--count", "2", "--producer", "synthetic",
                     "--mat", mat, "--out", str(tmp_path / "mix" / name), "--no-progress"]) == 0
    capsys.readouterr()
    assert main(["info", str(tmp_path / "mix")]) == 2
    assert "2 mats (boditrak_bt3510 (64 x 27), tip (56 x 40))" in capsys.readouterr().err
    assert main(["info", str(tmp_path / "mix" / "b")]) == 0


def test_repair_sets_an_unreadable_manifest_aside_and_makes_the_dataset_in_the_same_folder(tmp_path, capsys):
    """The folder then holds only set-aside files: --repair makes the dataset there, not the refusal of a
    folder of other files."""
    args = ["generate", "--partition", "general_supine", "--gender", "f", "--count", "4", "--seed", "3",
            "--producer", "synthetic", "--out", str(tmp_path / "d"), "--no-progress"]
    assert main(args) == 0
    (tmp_path / "d" / "manifest.json").write_text("{not json")
    assert main(args) == 2 and "--repair" in capsys.readouterr().err
    assert main(args + ["--repair"]) == 0
    assert len(DatasetReader(tmp_path / "d")) == 4
    assert len(list((tmp_path / "d").glob("manifest.json.corrupt-*"))) == 1


def test_an_interrupted_generate_says_how_many_samples_it_keeps(tmp_path, capsys, monkeypatch):
    """Ctrl-C during generate: the message counts the samples kept in finished shards and says that an
    unfinished shard is made again, so a rerun that starts from 0 of a one-shard dataset is no surprise."""
    import pressurepose.data.generate as gen

    real = gen.generate

    def first_shard_then_ctrl_c(config, out, **kw):
        real(config, out, **{**kw, "only_shards": [0]})
        raise KeyboardInterrupt

    monkeypatch.setattr(gen, "generate", first_shard_then_ctrl_c)
    args = ["generate", "--partition", "general", "--gender", "f", "--count", "10", "--shard-size", "4",
            "--producer", "synthetic", "--out", str(tmp_path / "d"), "--no-progress"]
    assert main(args) == 130
    err = " ".join(capsys.readouterr().err.split())
    assert "4 of the 10 samples" in err and "kept" in err and "4 samples here; --shard-size" in err
    monkeypatch.setattr(gen, "generate", real)
    assert main(args) == 0 and "made 2 shard(s), kept 1" in capsys.readouterr().out

    recipe = tmp_path / "r.json"
    recipe.write_text(json.dumps({"format": "pressurepose-recipe", "entries": [
        {"name": "train/a", "partition": "general", "gender": "f", "count": 3, "seed": 1},
        {"name": "test/a", "partition": "general", "gender": "f", "count": 2, "seed": 2}]}))
    calls = []

    def second_dataset_interrupted(config, out, **kw):
        calls.append(out)
        if len(calls) == 2:
            raise KeyboardInterrupt
        return real(config, out, **kw)

    monkeypatch.setattr(gen, "generate", second_dataset_interrupted)
    assert main(["generate", "--recipe", str(recipe), "--producer", "synthetic", "--out", str(tmp_path / "o"),
                 "--no-progress"]) == 130
    err = " ".join(capsys.readouterr().err.split())
    assert "1 of the recipe's 2 datasets are complete; 0 of the 2 samples" in err


def test_info_on_a_recipe_folder_writes_one_picture_per_split_as_its_help_says(tmp_path, capsys):
    recipe = tmp_path / "r.json"
    recipe.write_text(json.dumps({"format": "pressurepose-recipe", "entries": [
        {"name": "train/a", "split": "train", "partition": "general", "gender": "f", "count": 2, "seed": 1},
        {"name": "test/a", "split": "test", "partition": "general", "gender": "f", "count": 2, "seed": 2}]}))
    assert main(["generate", "--recipe", str(recipe), "--producer", "synthetic", "--out", str(tmp_path / "o"),
                 "--no-progress"]) == 0
    assert main(["info", str(tmp_path / "o"), "--png", str(tmp_path / "info.png")]) == 0
    written = sorted(p.name for p in tmp_path.glob("*.png"))
    assert written == ["info_test.png", "info_train.png"]
    with pytest.raises(SystemExit):
        main(["info", "--help"])
    help_text = " ".join(capsys.readouterr().out.split())
    assert all(name in help_text for name in written)
    readme = (Path(__file__).resolve().parents[2] / "README.md").read_text()
    line = next(ln for ln in readme.splitlines() if "$pp info data/paper_small" in ln)
    assert all(name in line for name in written)


def test_generate_workers_take_a_number_or_auto_and_the_summary_says_how_many_ran(tmp_path, capsys, monkeypatch):
    from pressurepose.data import executors

    args = ["generate", "--partition", "general", "--gender", "f", "--count", "20", "--producer", "synthetic",
            "--no-progress"]
    for bad in ("0", "-2", "many", "1.5"):
        with pytest.raises(SystemExit) as exc:
            main([*args, "--out", str(tmp_path / "bad"), "--workers", bad])
        assert exc.value.code == 2
        err = " ".join(capsys.readouterr().err.split())
        assert f"argument --workers: '{bad}': expected a number of worker processes (1 or more) or 'auto'" in err
    assert not (tmp_path / "bad").exists()
    monkeypatch.setattr(executors.os, "sched_getaffinity", lambda pid: set(range(8)), raising=False)
    assert main([*args, "--out", str(tmp_path / "one"), "--workers", "1"]) == 0
    assert "(this process)" in capsys.readouterr().out
    assert main([*args, "--out", str(tmp_path / "auto")]) == 0  # 8 cores, 20 samples: 3 workers
    out = capsys.readouterr().out
    assert "20/20 samples, made 1 shard(s)" in out and "(3 worker processes)" in out
    assert (tmp_path / "one" / "shard-00000.h5").read_bytes() == (tmp_path / "auto" / "shard-00000.h5").read_bytes()


def test_a_dataset_of_256_sample_shards_resumes_without_shard_size(tmp_path, capsys):
    """Shard size is layout, not content: a dataset in --out keeps its own when --shard-size is left
    out (its config, and so its identity, unchanged); a new one gets 64-sample shards; a different
    --shard-size on an existing dataset is refused by name before anything is written."""
    from pressurepose.data.store import Manifest

    out = tmp_path / "d"
    args = ["generate", "--partition", "general", "--gender", "f", "--count", "300", "--seed", "4",
            "--producer", "synthetic", "--workers", "1", "--no-progress", "--out", str(out)]
    assert main([*args, "--shard-size", "256", "--shards", "0"]) == 0
    identity = Manifest.load(out).config.digest
    capsys.readouterr()
    assert main([*args, "--shard-size", "64"]) == 2
    err = " ".join(capsys.readouterr().err.split())
    assert f"{out} holds a dataset of 256-sample shards; --shard-size 64" in err and "Leave --shard-size out" in err
    assert sorted(p.name for p in out.glob("shard-*")) == ["shard-00000.h5"]
    assert main(args) == 0
    assert "300/300 samples, made 1 shard(s), kept 1" in capsys.readouterr().out
    m = Manifest.load(out)
    assert (m.config.shard_size, m.config.digest, m.complete) == (256, identity, True)
    assert main([*args[:-1], str(tmp_path / "new")]) == 0
    assert Manifest.load(tmp_path / "new").config.shard_size == 64
    assert len(list((tmp_path / "new").glob("shard-*.h5"))) == 5
