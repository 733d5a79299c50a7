"""tools/train_shipped_model.py: the scaled recipe it generates from."""

import json

import pytest

from pressurepose.data.recipes import load_recipe
from tests.toolscript import TOOLS, load_tool

TOOL = TOOLS / "train_shipped_model.py"


def _tool():
    return load_tool("train_shipped_model")


def _recording_tool(monkeypatch):
    """The tool, and the list its ``cli`` calls are recorded in instead of being run."""
    calls = []
    T = _tool()
    monkeypatch.setattr(T, "cli", lambda *args: calls.append(args))
    return T, calls


def test_scaled_recipe_keeps_the_paper_mix_with_unseen_seeds(tmp_path):
    tool = _tool()
    paper = json.loads(tool.PAPER_RECIPE.read_text())
    recipe = tool.scaled_recipe(paper, 1000, 150, 77, 78)
    entries = recipe["entries"]
    assert {e["name"] for e in entries} == {e["name"] for e in paper["entries"]}
    train = [e for e in entries if e["split"] == "train"]
    test = [e for e in entries if e["split"] == "test"]
    assert abs(sum(e["count"] for e in train) - 1000) <= len(train)
    assert abs(sum(e["count"] for e in test) - 150) <= len(test)
    assert {e["seed"] for e in train} == {77} and {e["seed"] for e in test} == {78}
    # every partition, both genders, with and without limbs on the bed
    assert {e["partition"] for e in train} == {e["partition"] for e in paper["entries"]}
    assert {e["gender"] for e in train} == {"f", "m"} and {e["limbs_on_bed"] for e in train} == {True, False}
    # proportions kept: general is 4x the paper's hands_behind_head entries per gender
    count = {e["name"]: e["count"] for e in entries}
    assert count["train/general_f"] > count["train/general_supine_f"] > count["train/supine_crossed_legs_f"]
    # test entries come first, so an interrupted run holds the whole test set
    assert [e["split"] for e in entries[:len(test)]] == ["test"] * len(test)
    # the result is a valid recipe for generate
    path = tmp_path / "r.json"
    path.write_text(json.dumps(recipe))
    assert len(load_recipe(path)) == len(entries)


def test_lateral_entries_are_added_to_the_training_split_only(tmp_path):
    tool = _tool()
    paper = json.loads(tool.PAPER_RECIPE.read_text())
    base = tool.scaled_recipe(paper, 1000, 150, 77, 78)
    assert tool.with_lateral(base, 0) == base
    recipe = tool.with_lateral(base, 200, seed=79)
    extra = [e for e in recipe["entries"] if e["partition"] == "general_lateral"]
    assert len(extra) == 4 and {e["split"] for e in extra} == {"train"} and {e["seed"] for e in extra} == {79}
    assert sum(e["count"] for e in extra) == 200
    assert {(e["gender"], e["limbs_on_bed"]) for e in extra} == {("f", False), ("f", True), ("m", False), ("m", True)}
    path = tmp_path / "r.json"
    path.write_text(json.dumps(recipe))
    assert len(load_recipe(path)) == len(recipe["entries"])


def test_propped_entries_are_training_entries_with_their_own_seed():
    tool = _tool()
    paper = json.loads(tool.PAPER_RECIPE.read_text())
    base = tool.scaled_recipe(paper, 1000, 150, 77, 78)
    recipe = tool.with_extra(base, "propped_lateral", 120, tool.PROPPED_SEED)
    extra = [e for e in recipe["entries"] if e["partition"] == "propped_lateral"]
    assert sum(e["count"] for e in extra) == 120 and {e["seed"] for e in extra} == {tool.PROPPED_SEED}
    assert len({tool.TRAIN_SEED, tool.TEST_SEED, tool.LATERAL_SEED, tool.PROPPED_SEED}) == 4
    assert tool.with_extra(base, "propped_lateral", 0, 1) == base


def test_a_bed_file_goes_to_every_generate_call(tmp_path, monkeypatch):
    """`--bed FILE` makes the data on that bed; without it the default bed (no --bed)."""
    import sys

    T, calls = _recording_tool(monkeypatch)
    bed = tmp_path / "bed.json"
    bed.write_text("{}")
    for extra in ([], ["--bed", str(bed)]):
        calls.clear()
        monkeypatch.setattr(sys, "argv", ["train_shipped_model.py", "--work", str(tmp_path / "w"), "--scale", "0.01",
                                          "--real", str(tmp_path / "none"), *extra])
        assert T.main() == 0
        generate = [c for c in calls if c[0] == "generate"]
        assert len(generate) == 1 and [c[0] for c in calls] == ["generate", "train", "evaluate"]
        assert ("--bed" in generate[0]) == bool(extra) and "--settle" not in generate[0]
        if extra:
            assert generate[0][generate[0].index("--bed") + 1] == str(bed.resolve())


def test_a_settle_goes_to_generate(tmp_path, monkeypatch):
    """`--settle paper` makes the data with that settle; the default passes none (generate's
    default); it cannot go with --repress-from, which keeps an earlier run's rests."""
    import sys

    T, calls = _recording_tool(monkeypatch)
    argv = ["train_shipped_model.py", "--work", str(tmp_path / "w"), "--scale", "0.01", "--real", str(tmp_path / "x")]
    monkeypatch.setattr(sys, "argv", argv + ["--settle", "paper"])
    assert T.main() == 0
    generate = [c for c in calls if c[0] == "generate"][0]
    assert generate[generate.index("--settle") + 1] == "paper"
    bed = tmp_path / "bed.json"
    bed.write_text("{}")
    monkeypatch.setattr(sys, "argv", argv + ["--settle", "paper", "--bed", str(bed), "--repress-from", "old"])
    with pytest.raises(SystemExit):
        T.main()


def test_repress_from_re_presses_both_splits_and_generates_only_the_wedge_entries(tmp_path, monkeypatch):
    import sys

    T, calls = _recording_tool(monkeypatch)
    bed = tmp_path / "bed.json"
    bed.write_text("{}")
    argv = ["train_shipped_model.py", "--work", str(tmp_path / "w"), "--scale", "0.01", "--real", str(tmp_path / "x"),
            "--repress-from", str(tmp_path / "old")]
    monkeypatch.setattr(sys, "argv", argv)
    with pytest.raises(SystemExit):  # --repress-from without --bed
        T.main()
    monkeypatch.setattr(sys, "argv", argv + ["--bed", str(bed)])
    assert T.main() == 0
    assert [c[0] for c in calls] == ["repress", "repress", "generate", "train", "evaluate"]
    assert [c[1] for c in calls[:2]] == [str((tmp_path / "old" / s).resolve()) for s in ("train", "test")]
    assert all("--skip-wedge" in c and str(bed.resolve()) in c for c in calls[:2])
    recipe = json.loads((tmp_path / "w" / "recipe_wedge.json").read_text())
    assert recipe["entries"] and {e["partition"] for e in recipe["entries"]} == {"propped_lateral"}
    assert calls[2][calls[2].index("--recipe") + 1] == str(tmp_path / "w" / "recipe_wedge.json")


def test_train_on_a_pack_made_elsewhere_and_ship_to_a_folder(tmp_path):
    """The GPU half of a split rebuild: --train-data PACK --ship-to DIR trains (1 + 1 epochs here),
    skips the evaluations whose data is absent and writes the float16 shipped form, which loads."""
    import subprocess
    import sys

    from pressurepose.cli import main
    from pressurepose.net.checkpoint import read_model_files
    from tests.net.synth import write_toy_dataset

    write_toy_dataset(tmp_path / "data", n=4)
    assert main(["pack", str(tmp_path / "data"), "--out", str(tmp_path / "train.npz")]) == 0
    cmd = [sys.executable, str(TOOL), "--work", str(tmp_path / "w"), "--train-data", str(tmp_path / "train.npz"),
           "--epochs-mod1", "1", "--epochs-mod2", "1", "--batch-size", "2", "--no-cpu-amp", "--seed", "2",
           "--turn-loss", "0.5", "--real", str(tmp_path / "no_real"), "--ship-to", str(tmp_path / "ship")]
    done = subprocess.run(cmd, capture_output=True, text=True)
    assert done.returncode == 0, done.stderr[-2000:]
    assert not (tmp_path / "w" / "data").exists() and not (tmp_path / "w" / "eval").exists()
    meta = read_model_files(tmp_path / "ship" / "pressurenet.json")[0]
    assert meta["train"]["seed"] == 2 and meta["train"]["epochs_mod1"] == 1 and meta["train"]["turn_loss"] == 0.5
    assert sorted(p.name for p in (tmp_path / "ship").iterdir()) == [
        "pressurenet.json", "pressurenet.mod1.safetensors", "pressurenet.mod2.safetensors"]
    bad = subprocess.run([*cmd[:2], "--train-data", "x.npz", "--data-only"], capture_output=True, text=True)
    assert bad.returncode == 2 and "cannot go with --data-only" in bad.stderr


def test_the_tools_defaults_train_as_the_shipped_model_was_trained(tmp_path, monkeypatch):
    """The shipped model's record (pressurepose/net/assets/pressurenet.json) holds its training options;
    the tool's default train call must pass the same ones, or it would not rebuild that model."""
    import argparse
    import sys

    from pressurepose.cli.net import add_train_arguments

    T, calls = _recording_tool(monkeypatch)
    monkeypatch.setattr(sys, "argv", ["train_shipped_model.py", "--work", str(tmp_path / "w"), "--skip-generate",
                                      "--real", str(tmp_path / "none")])
    assert T.main() == 0
    parser = argparse.ArgumentParser()
    add_train_arguments(parser)
    got = vars(parser.parse_args(next(c for c in calls if c[0] == "train")[1:]))
    got["contact_floor_mmhg"] = got.pop("contact_floor")  # the record's name for --contact-floor
    shipped = json.loads((TOOL.parents[1] / "pressurepose" / "net" / "assets" / "pressurenet.json").read_text())["train"]
    for key in ("epochs_mod1", "epochs_mod2", "lr", "lr_mod2", "lr_schedule", "batch_size", "cnn", "cpu_amp",
                "contact_floor_mmhg", "gender_input", "seed", "turn_loss"):
        assert got[key] == shipped[key], key
