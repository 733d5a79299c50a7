"""``--no-progress``: every verb that draws a progress bar takes it, and with it writes no bar to stderr."""

import argparse
import importlib

import numpy as np
import pytest

from pressurepose.cli import VERBS, main

WITH_BARS = ("generate", "repress", "simulate", "sample", "train", "infer", "evaluate", "evaluate-real", "monitor")


@pytest.mark.parametrize("verb", WITH_BARS)
def test_every_verb_with_a_bar_takes_no_progress(verb):
    module, stem, _ = VERBS[verb]
    p = argparse.ArgumentParser()
    getattr(importlib.import_module(module), f"add_{stem}_arguments")(p)
    flag = {o: a for a in p._actions for o in a.option_strings}.get("--no-progress")
    assert flag is not None and flag.default is False and "progress bar" in flag.help


def test_sample_draws_no_bar_with_no_progress(tmp_path, capsys):
    from pressurepose.pose.sampler import BLOCK

    args = ["sample", "--partition", "supine", "--gender", "f", "--count", str(BLOCK + 1), "--seed", "1"]
    assert main([*args, "--out", str(tmp_path / "a.npz")]) == 0
    assert "sample: 100%" in capsys.readouterr().err  # more than a block: a bar
    assert main([*args, "--out", str(tmp_path / "b.npz"), "--no-progress"]) == 0
    assert capsys.readouterr().err == ""


def test_simulate_resumes_an_interrupted_run_whatever_its_progress_flag():
    """--no-progress changes no body: it is not part of the key that ties a partial file to its command."""
    from pressurepose.cli.sim import add_simulate_arguments, simulate_key
    from pressurepose.sim.bed import bed_for

    p = argparse.ArgumentParser()
    add_simulate_arguments(p)
    bed = bed_for(None, None)

    def key(*extra):
        args = p.parse_args(["--partition", "supine", "--gender", "f", "--out", "x.npz", *extra])
        return simulate_key(args, "general_supine", "f", bed)

    assert key() == key("--no-progress") != key("--seed", "2")


def test_monitor_draws_no_bar_with_no_progress(tmp_path, capsys):
    from pressurepose.net.infer import DEFAULT_MODEL

    if not DEFAULT_MODEL.is_file():
        pytest.skip("no shipped model")
    frames = np.zeros((2001, 64, 27), np.float32)  # a long recording: monitor draws a bar over it by default
    frames[:, 20:40, 10:17] = 20.0
    np.save(tmp_path / "night.npy", frames)
    assert main(["monitor", str(tmp_path / "night.npy"), "--mat", "boditrak_bt3510", "--units", "mmHg", "--gender",
                 "f", "--fps", "1", "--out", str(tmp_path / "out"), "--no-progress"]) == 0
    err = capsys.readouterr().err
    assert "do not look like a person" in err and "monitor:" not in err and "chunk" not in err


def test_evaluate_real_draws_no_bar_with_no_progress(tmp_path, capsys):
    from pressurepose.net.infer import DEFAULT_MODEL
    from tests.data.realfolders import body_image, write_labelled

    if not DEFAULT_MODEL.is_file():
        pytest.skip("no shipped model")
    imgs = np.stack([body_image(64, 27, seed=i, scale=20) for i in range(2)])
    folder = write_labelled(tmp_path / "lab", imgs, ["supine", "left"], {"preset": "boditrak_bt3510", "units": "mmHg"},
                            heights=[1.6, 1.7], weights=[60, 70], genders=["f", "m"])
    assert main(["evaluate-real", str(folder), "--out", str(tmp_path / "out"), "--no-progress"]) == 0
    err = capsys.readouterr().err
    assert "drawing" in err and "batch" not in err and "%|" not in err
