"""Every verb under bad input and faults: a clear ``error:`` (exit 2) and no traceback, nothing lost,
nothing half-written, no wrong answer. Physics is kept out: the datasets are toy or
synthetic, the model untrained and tiny, and ``simulate`` runs on a stand-in for ``simulate_one``."""

from __future__ import annotations

import errno
import json
import os
from types import SimpleNamespace

import h5py
import numpy as np
import pytest
import torch

from pressurepose.cli import main
from pressurepose.errors import BadInput
from pressurepose.sim.simulate import Rejected
from tests.data.realfolders import body_image, write_labelled
from tests.net.synth import BODITRAK, toy_body, write_toy_dataset

torch.set_num_threads(1)


@pytest.fixture(scope="module")
def world(tmp_path_factory):
    """A toy dataset, a recipe-like folder with train and test splits, an untrained toy model, inputs."""
    from pressurepose.net.checkpoint import gendered_body, save_model
    from pressurepose.net.model import NetConfig, PressureNet
    from pressurepose.net.outputs import OutputConfig

    root = tmp_path_factory.mktemp("robust")
    data = write_toy_dataset(root / "data", n=4)
    write_toy_dataset(root / "recipe" / "train" / "a", n=4)
    write_toy_dataset(root / "recipe" / "test" / "a", n=4, seed=1)
    torch.manual_seed(0)
    body = toy_body()
    net = PressureNet(NetConfig(grid=BODITRAK, outputs=OutputConfig.default((0.4, 0.9, 0.1), (0.3, 0.3, 0.1))),
                      gendered_body(body, body))
    model = save_model(root / "model.safetensors", net, (body, body))
    np.save(root / "good.npy", data["pressure"][:2].numpy())
    np.save(root / "zeros.npy", np.zeros((64, 27), np.float32))
    np.save(root / "huge.npy", np.full((64, 27), 1e9, np.float32))
    np.save(root / "beyond_float32.npy", np.full((64, 27), 1e39))
    np.save(root / "slp.npy", np.ones((192, 84), np.float32))
    (root / "text.npy").write_text("1 2 3\n")
    (root / "night.txt").write_text(("\t".join(["1"] * 2048) + "\n") * 2)
    (root / "empty.npy").write_bytes(b"")
    (root / "afile").write_text("not a folder\n")
    with h5py.File(root / "dangling.h5", "w") as f:
        f["pressure"] = h5py.SoftLink("/nowhere")
    write_toy_dataset(root / "nested", n=4)
    from pressurepose.sim.bed import get_bed

    for name, field, value in (("bed_tiny_cell", "press_cell_m", 1e-9), ("bed_huge", "mattress_length_m", 1e6)):
        (root / f"{name}.json").write_text(json.dumps({**get_bed().to_dict(), field: value}))
    write_labelled(root / "real_raw", np.stack([body_image(64, 27, seed=i) for i in range(2)]), ["supine", "left"],
                   {"preset": "boditrak_bt3510", "units": "raw"})
    write_toy_dataset(root / "nested" / "inner", n=4, seed=2)
    return SimpleNamespace(root=root, data=root / "data", recipe=root / "recipe", model=model)


def run(argv, capsys):
    """(exit code, stderr) of the CLI; argparse's own refusals count as exit 2."""
    try:
        code = main([str(a) for a in argv])
    except SystemExit as exc:
        code = exc.code
    err = capsys.readouterr().err
    return code, err


# (case id, argv given the world, text the error must contain)
REFUSED = [
    # values that would give wrong numbers: batch size <= 0 (0.00 cm), limits <= 0 (nan, or silently fewer)
    ("evaluate-batch-negative", lambda w: ["evaluate", "--model", w.model, "--data", w.data, "--batch-size", -1],
     "--batch-size"),
    ("evaluate-batch-zero", lambda w: ["evaluate", "--model", w.model, "--data", w.data, "--batch-size", 0],
     "--batch-size"),
    ("evaluate-limit-zero", lambda w: ["evaluate", "--model", w.model, "--data", w.data, "--limit", 0], "--limit"),
    ("evaluate-limit-negative", lambda w: ["evaluate", "--model", w.model, "--data", w.data, "--limit", -14],
     "--limit"),
    ("train-limit-negative", lambda w: ["train", "--data", w.data, "--out", w.root / "run_neg", "--limit", -14,
                                        "--female", "toy", "--male", "toy"], "--limit"),
    ("train-contact-floor-negative", lambda w: ["train", "--data", w.data, "--out", w.root / "run_floor",
                                                "--contact-floor", -1, "--female", "toy", "--male", "toy"],
     "contact_floor_mmhg"),
    ("generate-across-sd-negative", lambda w: ["generate", "--partition", "general", "--gender", "f", "--count", 2,
                                               "--producer", "synthetic", "--across-sd", -0.1,
                                               "--out", w.root / "gen_sd"], "across_sd_m"),
    # datasets mixing
    ("generate-recipe-into-dataset", lambda w: ["generate", "--recipe", "paper", "--scale", 0.0001, "--producer",
                                                "synthetic", "--out", w.data], "single dataset"),
    ("generate-dataset-into-recipe", lambda w: ["generate", "--partition", "general", "--gender", "f", "--count", 2,
                                                "--producer", "synthetic", "--out", w.recipe], "sub-folders"),
    ("train-on-train-and-test", lambda w: ["train", "--data", w.recipe, "--out", w.root / "run_mix",
                                           "--female", "toy", "--male", "toy"], "must not be mixed"),
    ("evaluate-on-train-and-test", lambda w: ["evaluate", "--model", w.model, "--data", w.recipe], "must not be mixed"),
    # garbage in
    ("infer-empty-mat", lambda w: ["infer", w.root / "zeros.npy", "--gender", "f", "--model", w.model,
                                   "--out", w.root / "e1"], "empty"),
    ("infer-absurd-pressure", lambda w: ["infer", w.root / "huge.npy", "--gender", "f", "--model", w.model,
                                         "--out", w.root / "e2"], "sensor's range"),
    ("infer-beyond-float32", lambda w: ["infer", w.root / "beyond_float32.npy", "--gender", "f", "--model", w.model,
                                        "--out", w.root / "e7"], "beyond_float32.npy' holds values up to 1e+39, out "
                                                                 "of range: too large for float32"),
    ("infer-other-mat", lambda w: ["infer", w.root / "slp.npy", "--gender", "f", "--model", w.model,
                                   "--out", w.root / "e3"], "goes in with that mat (`infer --mat"),
    ("calibrate-max-evals-zero", lambda w: ["calibrate", "--targets", "default", "--max-evals", 0,
                                            "--out", w.root / "bed.json"], "--max-evals"),
    ("view-body-huge-betas", lambda w: ["view-body", "--betas", 1e6, "--out", w.root / "b.png"], "within"),
    # missing or malformed files and odd values, which must not end in a traceback
    ("view-body-missing-pose", lambda w: ["view-body", "--pose", w.root / "nope.npy", "--out", w.root / "b.png"],
     "does not exist"),
    ("view-body-text-pose", lambda w: ["view-body", "--pose", w.root / "text.npy", "--out", w.root / "b.png"],
     "no .npy / .npz header"),
    ("view-body-unknown-suffix", lambda w: ["view-body", "--out", w.root / "b.bmpx"], "expected a file ending"),
    ("infer-empty-npy", lambda w: ["infer", w.root / "empty.npy", "--gender", "f", "--model", w.model,
                                   "--out", w.root / "e4"], "empty"),
    ("infer-hdf5-dangling-link", lambda w: ["infer", w.root / "dangling.h5", "--gender", "f", "--model", w.model,
                                            "--out", w.root / "e6"], "'pressure' is a soft link to '/nowhere'"),
    ("monitor-negative-threshold", lambda w: ["monitor", w.root / "good.npy", "--mat", "boditrak_bt3510", "--units",
                                              "mmHg", "--gender", "f", "--fps", 1, "--threshold-mmhg", -1,
                                              "--model", w.model, "--out", w.root / "m1"],
     "--threshold-mmhg is -1.0; expected a positive number"),
    ("monitor-negative-relief", lambda w: ["monitor", w.root / "good.npy", "--mat", "boditrak_bt3510", "--units",
                                           "mmHg", "--gender", "f", "--fps", 1, "--relief-s", -5,
                                           "--model", w.model, "--out", w.root / "m2"], "--relief-s is -5.0"),
    ("monitor-gap", lambda w: ["monitor", w.root / "good.npy", "--mat", "boditrak_bt3510", "--units", "mmHg",
                               "--gender", "f", "--fps", 0.001, "--model", w.model, "--out", w.root / "m3"],
     "allow longer gaps (max_gap_s; --max-gap-s)"),
    ("infer-text-recording-without-mat", lambda w: ["infer", w.root / "night.txt", "--gender", "f", "--model",
                                                    w.model, "--out", w.root / "e8"],
     "night.txt: a text recording is read on its own mat: give --mat"),
    ("infer-text-npy", lambda w: ["infer", w.root / "text.npy", "--gender", "f", "--model", w.model,
                                  "--out", w.root / "e5"], "no .npy / .npz header"),
    ("sample-negative-seed", lambda w: ["sample", "--partition", "general", "--gender", "f", "--count", 1,
                                        "--seed", -1, "--out", w.root / "s.npz"], "seeds are whole numbers"),
    ("simulate-negative-seed", lambda w: ["simulate", "--partition", "general", "--gender", "f", "--seed", -1,
                                          "--out", w.root / "s.npz"], "seeds are whole numbers"),
    ("calibrate-negative-seed", lambda w: ["calibrate", "--targets", "default", "--seed", -1], "seeds are whole"),
    ("demo-negative-seed", lambda w: ["demo", "--seed", -1, "--out", w.root / "demo"], "seeds are whole numbers"),
    ("generate-option-not-a-number", lambda w: ["generate", "--partition", "general", "--gender", "f", "--count", 2,
                                                "--producer", "synthetic", "--option", "reject_rate=abc",
                                                "--out", w.root / "g1"], "expected a number"),
    ("train-corrupt-state", lambda w: ["train", "--data", w.data, "--out", w.root / "run_corrupt",
                                       "--epochs-mod1", 0, "--epochs-mod2", 0, "--female", "toy", "--male", "toy"],
     "corrupt"),
    ("info-on-a-file", lambda w: ["info", w.root / "afile"], "is a file"),
    ("info-on-a-dataset-holding-datasets", lambda w: ["info", w.root / "nested"], "counted together"),
    ("train-on-a-file", lambda w: ["train", "--data", w.root / "afile", "--out", w.root / "run_file",
                                   "--female", "toy", "--male", "toy"], "is a file"),
    # bad output paths, found before any work
    ("sample-out-missing-folder", lambda w: ["sample", "--partition", "general", "--gender", "f", "--count", 1,
                                             "--seed", 0, "--out", w.root / "missing" / "s.npz"], "does not exist"),
    ("simulate-out-missing-folder", lambda w: ["simulate", "--partition", "general", "--gender", "f",
                                               "--out", w.root / "missing" / "s.npz"], "does not exist"),
    ("simulate-plot-suffix", lambda w: ["simulate", "--partition", "general", "--gender", "f",
                                        "--out", w.root / "s.npz", "--plot", w.root / "p.bmpx"],
     "expected a file ending"),
    ("calibrate-out-missing-folder", lambda w: ["calibrate", "--targets", "default",
                                                "--out", w.root / "missing" / "bed.json"], "does not exist"),
    ("infer-out-file-in-the-way", lambda w: ["infer", w.root / "good.npy", "--gender", "f", "--model", w.model,
                                             "--out", w.root / "afile"], "is a file"),
    ("evaluate-out-file-in-the-way", lambda w: ["evaluate", "--model", w.model, "--data", w.data,
                                                "--out", w.root / "afile"], "is a file"),
    ("demo-out-file-in-the-way", lambda w: ["demo", "--out", w.root / "afile"], "is a file"),
    ("info-png-missing-folder", lambda w: ["info", w.data, "--png", w.root / "missing" / "i.png"], "does not exist"),
    ("generate-out-file-in-the-way", lambda w: ["generate", "--partition", "general", "--gender", "f", "--count", 2,
                                                "--producer", "synthetic", "--out", w.root / "afile"], "is a file"),
    # absurd values, which must not be accepted silently
    ("sample-absurd-count", lambda w: ["sample", "--partition", "general", "--gender", "f", "--count", 10 ** 12,
                                       "--seed", 0, "--out", w.root / "s.npz"], "--count"),
    ("generate-absurd-count", lambda w: ["generate", "--partition", "general", "--gender", "f", "--count", 10 ** 12,
                                         "--producer", "synthetic", "--out", w.root / "g2"], "at most"),
    ("generate-backward-shards", lambda w: ["generate", "--partition", "general", "--gender", "f", "--count", 2,
                                            "--producer", "synthetic", "--shards", "3-1", "--out", w.root / "g3"],
     "backwards"),
    ("generate-unknown-option", lambda w: ["generate", "--partition", "general", "--gender", "f", "--count", 2,
                                           "--producer", "synthetic", "--option", "rejet_rate=0.5",
                                           "--out", w.root / "g4"], "no such option"),
    ("sample-out-folder", lambda w: ["sample", "--partition", "general", "--gender", "f", "--count", 1, "--seed", 0,
                                     "--out", str(w.root / "o") + "/"], ".npz"),
    ("sample-out-txt", lambda w: ["sample", "--partition", "general", "--gender", "f", "--count", 1, "--seed", 0,
                                  "--out", w.root / "x.txt"], ".npz"),
    ("simulate-out-txt", lambda w: ["simulate", "--partition", "general", "--gender", "f",
                                    "--out", w.root / "x.txt"], ".npz"),
    # refused before any work is done, and without a traceback
    ("evaluate-real-bad-device", lambda w: ["evaluate-real", w.root / "no_real", "--out", w.root / "er",
                                            "--device", "foo"], "not a torch device"),
    ("evaluate-real-gain-tiny", lambda w: ["evaluate-real", w.root / "real_raw", "--model", w.model, "--gain", 1e-300,
                                           "--out", w.root / "er"], "the gain 1e-300 mmHg per raw unit (--gain"),
    ("evaluate-real-contact-negative", lambda w: ["evaluate-real", w.root / "no_real", "--out", w.root / "er",
                                                  "--contact-mmhg", -1], "--contact-mmhg"),
    ("evaluate-real-batch-size-zero", lambda w: ["evaluate-real", w.root / "no_real", "--out", w.root / "er",
                                                 "--batch-size", 0], "--batch-size"),
    ("realism-examples-negative", lambda w: ["realism", "--real", w.root / "no_real", "--synthetic", w.data,
                                             "--out", w.root / "rr", "--examples", -1], "--examples"),
    ("realism-examples-absurd", lambda w: ["realism", "--real", w.root / "no_real", "--synthetic", w.data,
                                           "--out", w.root / "rr", "--examples", 10 ** 9], "--examples is 1000000000"),
    ("info-examples-absurd", lambda w: ["info", w.data, "--examples", 10 ** 9], "--examples is 1000000000"),
    ("realism-wedge-flags-together", lambda w: ["realism", "--real", w.root / "no_real", "--synthetic", w.data,
                                                "--out", w.root / "rr", "--keep-wedge", "--only-wedge"],
     "one at a time"),
    ("realism-mat-of-a-dataset", lambda w: ["realism", "--real", w.root / "no_real", "--synthetic", w.data,
                                            "--out", w.root / "rr", "--mat", "tip"], "leave --mat out"),
    ("train-validation-takes-all", lambda w: ["train", "--data", w.data, "--out", w.root / "run_val", "--limit", 2,
                                              "--val-fraction", 0.9, "--female", "toy", "--male", "toy"],
     "leaves none to train on"),
    ("train-bad-device", lambda w: ["train", "--data", w.data, "--out", w.root / "run_dev", "--device", "foo",
                                    "--female", "toy", "--male", "toy"], "not a torch device"),
    ("train-lr-nan", lambda w: ["train", "--data", w.data, "--out", w.root / "run_lr", "--lr", "nan",
                                "--female", "toy", "--male", "toy"], "learning rate"),
    ("demo-neutral-body", lambda w: ["demo", "--gender", "n", "--out", w.root / "demo_n"], "expected f or m"),
    ("convert-missing-source", lambda w: ["convert", w.root / "no_such.p", "--out", w.root / "cv"],
     "does not exist"),
    ("generate-bed-tiny-cell", lambda w: ["generate", "--partition", "general", "--gender", "f", "--count", 2,
                                          "--bed", w.root / "bed_tiny_cell.json", "--out", w.root / "g6"],
     "bed_tiny_cell.json': bed press_cell_m is 1e-09 m"),
    ("generate-bed-huge-mattress", lambda w: ["generate", "--partition", "general", "--gender", "f", "--count", 2,
                                              "--bed", w.root / "bed_huge.json", "--out", w.root / "g7"],
     "bed_huge.json': bed mattress_length_m is 1000000.0 m"),
    ("generate-shard-out-of-range", lambda w: ["generate", "--partition", "general", "--gender", "f", "--count", 2,
                                               "--producer", "synthetic", "--shards", "3", "--out", w.root / "g5"],
     "do not exist"),
]


@pytest.mark.parametrize("case,argv,message", REFUSED, ids=[c[0] for c in REFUSED])
def test_bad_input_is_refused_clearly(world, capsys, case, argv, message):
    if case == "train-corrupt-state":
        (world.root / "run_corrupt").mkdir(exist_ok=True)
        (world.root / "run_corrupt" / "state.json").write_text('{"identity": ')
    before = sorted(p.name for p in world.root.iterdir())
    code, err = run(argv(world), capsys)
    assert code == 2, err
    assert message in err
    assert "Traceback" not in err
    assert "pickled" not in err  # a text .npy is not pickled data
    if case != "train-corrupt-state":  # the refusal wrote nothing (run folders aside)
        assert sorted(p.name for p in world.root.iterdir()) == before


def test_evaluate_device_cuda_without_cuda(world, capsys):
    if torch.cuda.is_available():
        pytest.skip("this machine has CUDA")
    code, err = run(["evaluate", "--model", world.model, "--data", world.data, "--device", "cuda"], capsys)
    assert code == 2 and "CUDA is not available" in err


def test_recipe_entry_with_negative_count_is_refused(tmp_path):
    from pressurepose.data.recipes import load_recipe

    recipe = tmp_path / "r.json"
    recipe.write_text(json.dumps({"format": "pressurepose-recipe", "entries": [
        {"name": "a", "partition": "general", "gender": "f", "count": -5}]}))
    with pytest.raises(BadInput, match="count -5"):
        load_recipe(recipe, producer="synthetic")


def test_every_verb_takes_every_documented_partition_alias(tmp_path, capsys):
    from pressurepose.data.dataset import DatasetReader
    from pressurepose.data.schema import GenerationConfig
    from pressurepose.pose.partitions import ALIASES

    for alias, name in ALIASES.items():
        assert GenerationConfig(partition=alias, gender="f") == GenerationConfig(partition=name, gender="f")
    out = tmp_path / "g"
    code, err = run(["generate", "--partition", "supine", "--gender", "f", "--count", 2, "--producer", "synthetic",
                     "--out", out, "--no-progress"], capsys)
    assert code == 0, err
    assert DatasetReader(out).datasets[0].config.partition == "general_supine"


def test_attempts_exhausted_is_a_message_not_a_traceback(tmp_path, capsys):
    code, err = run(["generate", "--partition", "general", "--gender", "f", "--count", 2, "--producer", "synthetic",
                     "--option", "reject_rate=1", "--max-attempts", 3, "--out", tmp_path / "g", "--no-progress"],
                    capsys)
    assert code == 1 and "rejected 3 times" in err and "Traceback" not in err


def test_corrupt_manifest_names_the_way_out_and_repair_takes_it(tmp_path, capsys):
    argv = ["generate", "--partition", "general", "--gender", "f", "--count", 4, "--producer", "synthetic",
            "--shard-size", 2, "--out", tmp_path / "g", "--no-progress"]
    assert run(argv, capsys)[0] == 0
    (tmp_path / "g" / "manifest.json").write_text("{broken")
    code, err = run(["info", tmp_path / "g"], capsys)
    assert code == 2 and "--repair" in err
    assert run(argv + ["--repair"], capsys)[0] == 0
    assert run(["info", tmp_path / "g", "--no-verify"], capsys)[0] == 0


def test_info_never_counts_train_and_test_together(world, capsys):
    code = main(["info", str(world.recipe), "--png", str(world.root / "info.png")])
    out = capsys.readouterr().out
    assert code == 0
    assert out.count("4 samples") == 2 and "8 samples" not in out
    assert (world.root / "info_train.png").exists() and (world.root / "info_test.png").exists()


def test_infer_warns_about_empty_images_in_a_batch(world, capsys):
    batch = np.load(world.root / "good.npy")
    batch[1] = 0
    np.save(world.root / "half_empty.npy", batch)
    code = main(["infer", str(world.root / "half_empty.npy"), "--gender", "f", "--model", str(world.model),
                 "--out", str(world.root / "est_half"), "--max-figures", "0"])
    err = capsys.readouterr().err
    assert code == 0 and "warning:" in err and "image(s) 1 are empty" in err


# ------------------------------------------------------------------------------------- data loss


def _no_space(fd):
    raise OSError(errno.ENOSPC, "No space left on device")


WRITERS = [
    ("sample", "s.npz", lambda w, o: ["sample", "--partition", "general", "--gender", "f", "--count", 2, "--seed", 0,
                                      "--out", o]),
    ("infer", "inf/estimate.json", lambda w, o: ["infer", w.root / "good.npy", "--gender", "f", "--model", w.model,
                                                 "--out", o.parent]),
    ("evaluate", "ev/report.json", lambda w, o: ["evaluate", "--model", w.model, "--data", w.data, "--out", o.parent]),
    ("view-body", "b.png", lambda w, o: ["view-body", "--gender", "n", "--out", o]),
    ("convert", "x.p", lambda w, o: ["convert", w.data, "--to-pressurepose", "--out", o]),
]


@pytest.mark.parametrize("verb,name,argv", WRITERS, ids=[c[0] for c in WRITERS])
def test_full_disk_keeps_the_previous_output(world, tmp_path, capsys, monkeypatch, verb, name, argv):
    """Every writer writes a temporary file, flushes it and renames it: on a full disk the previous
    output survives whole, no temporary file is left, and the message says what happened."""
    out = tmp_path / name
    out.parent.mkdir(parents=True, exist_ok=True)
    out.write_bytes(b"previous good output")
    monkeypatch.setattr(os, "fsync", _no_space)
    code, err = run(argv(world, out), capsys)
    assert code == 2 and "no space left" in err, err
    assert out.read_bytes() == b"previous good output"
    assert not [p for p in out.parent.iterdir() if ".tmp-" in p.name]


def test_ctrl_c_exits_130_and_leaves_nothing_half_written(tmp_path, capsys, monkeypatch):
    out = tmp_path / "s.npz"
    out.write_bytes(b"previous good output")

    def interrupted(fh, **arrays):
        fh.write(b"half")
        raise KeyboardInterrupt

    monkeypatch.setattr(np, "savez_compressed", interrupted)
    code, err = run(["sample", "--partition", "general", "--gender", "f", "--count", 2, "--seed", 0, "--out", out],
                    capsys)
    assert code == 130 and "interrupted" in err and "Traceback" not in err
    assert all(verb in err for verb in ("generate", "repress", "train", "simulate"))  # the verbs that resume (README)
    assert out.read_bytes() == b"previous good output"
    assert [p.name for p in tmp_path.iterdir()] == ["s.npz"]


def test_sample_takes_any_seed_numpy_takes_and_blocks_do_not_change_bodies(tmp_path, capsys):
    from pressurepose.pose.sampler import BLOCK, sample_bodies
    from pressurepose.pose.samples import load_samples

    seed = 12345678901234567890123456789
    out = tmp_path / "s.npz"
    assert main(["sample", "--partition", "supine", "--gender", "f", "--count", str(BLOCK + 2), "--seed", str(seed),
                 "--out", str(out)]) == 0
    got = load_samples(out)
    assert got.seed == seed and got.partition == "general_supine"
    whole = sample_bodies("general_supine", "f", BLOCK + 2, seed)
    np.testing.assert_array_equal(got.pose, whole.pose)


# ------------------------------------------------------------------------------------- simulate resumes


class _Image:
    def __init__(self, rng):
        self.pressure = rng.uniform(0, 50, (64, 27)).astype(np.float32)
        self.force, self.depth, self.contact = self.pressure * 0.1, -self.pressure * 1e-3, self.pressure > 25


def _fake_simulate_one(calls):
    """A stand-in for simulate_one: deterministic in its generator, rejects every third attempt 0."""
    def fake(body, bed, partition, gender, rng, limbs_on_bed=False, sampler=None, settle_config=None):
        calls.append(1)
        draw = rng.uniform()
        if draw < 0.3:
            return Rejected("unstable")
        return SimpleNamespace(image=_Image(rng), betas=rng.normal(size=10), pose=rng.normal(size=72),
                               transl=rng.normal(size=3), joints=rng.normal(size=(24, 3)), mass=60 + 10 * draw,
                               height=1.7, wedge=None)
    return fake


def test_simulate_keeps_finished_bodies_when_killed_and_resumes(tmp_path, capsys, monkeypatch):
    import pressurepose.sim.simulate as simulate_module

    calls = []
    monkeypatch.setattr(simulate_module, "simulate_one", _fake_simulate_one(calls))
    argv = ["simulate", "--partition", "general", "--gender", "f", "--count", "5", "--seed", "3"]
    assert main(argv + ["--out", str(tmp_path / "whole.npz")]) == 0

    fake, n_bodies = _fake_simulate_one(calls), []

    def dies_at_body_3(body, bed, partition, gender, rng, *rest, **kw):
        out = fake(body, bed, partition, gender, rng, *rest, **kw)
        if not isinstance(out, Rejected):
            n_bodies.append(1)
            if len(n_bodies) == 4:
                raise KeyboardInterrupt  # as a kill at body 3 would; 0..2 are finished
        return out

    monkeypatch.setattr(simulate_module, "simulate_one", dies_at_body_3)
    out = tmp_path / "run.npz"
    assert main(argv + ["--out", str(out)]) == 130
    with np.load(tmp_path / "run.partial.npz") as z:
        assert len(z["pressure"]) == 3
    assert not out.exists()
    calls.clear()
    monkeypatch.setattr(simulate_module, "simulate_one", _fake_simulate_one(calls))
    assert main(argv + ["--out", str(out)]) == 0
    assert "resuming: 3 bodies" in capsys.readouterr().out
    assert not (tmp_path / "run.partial.npz").exists()
    with np.load(out) as a, np.load(tmp_path / "whole.npz") as b:
        assert sorted(a.files) == sorted(b.files)
        for k in a.files:
            np.testing.assert_array_equal(a[k], b[k])
    # another command's partial file is not mixed in
    np.savez(tmp_path / "other.partial.npz", run_key=np.array("{}"), pressure=np.zeros((1, 64, 27)))
    code, err = run(argv + ["--out", tmp_path / "other.npz"], capsys)
    assert code == 2 and "another simulate command" in err


# ------------------------------------------------------------------------------------- calibrate, body layer


def test_calibrate_refuses_objects_off_the_mat():
    from pressurepose.calibrate.measurements import CapsuleMeasurements
    from pressurepose.mat import get_mat

    mat = get_mat("boditrak_bt3510")
    with pytest.raises(BadInput, match="off the mat"):
        CapsuleMeasurements(mat, radius_m=[0.05], length_m=[0.3], mass_kg=[5.0], center_xy_m=[[5.0, 5.0]],
                            yaw_rad=[0.0], pressure_mmhg=np.zeros((1, 64, 27)), sink_m=[0.01])


def test_calibrate_writes_no_bed_when_the_fit_is_at_the_penalty(tmp_path, capsys, monkeypatch):
    import pressurepose.calibrate.objects as cal
    from pressurepose.sim.bed import get_bed

    failed = SimpleNamespace(bed=get_bed(), loss=cal.PENALTY, fitted={}, evaluations=10, generations=1, stop={},
                             history=[cal.PENALTY])
    monkeypatch.setattr(cal, "calibrate_targets", lambda *a, **k: failed)
    monkeypatch.setattr(cal, "supine_body_mesh", lambda body, bed: (None, None, None))
    out = tmp_path / "bed.json"
    code, err = run(["calibrate", "--targets", "default", "--max-evals", 10, "--out", out], capsys)
    assert code == 2 and "penalty" in err and not out.exists()


def test_torch_body_layer_refuses_nan_like_numpy():
    layer = toy_body().torch_layer()
    pose = torch.zeros(1, 69)
    pose[0, 5] = float("nan")
    with pytest.raises(BadInput, match="NaN"):
        layer(body_pose=pose)
    with pytest.raises(BadInput, match="NaN"):
        toy_body().forward(np.zeros(10), np.r_[np.zeros(3), pose[0].numpy()])
