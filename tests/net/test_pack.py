"""Training packs (`pressurepose pack`): one .npz of the arrays training reads, read back as the dataset."""

import subprocess
import sys

import numpy as np
import pytest
import torch

from pressurepose.cli import main
from pressurepose.errors import BadInput
from pressurepose.net.data import load_dataset
from tests.net.synth import write_toy_dataset

torch.set_num_threads(1)


@pytest.fixture(scope="module")
def packed(tmp_path_factory):
    root = tmp_path_factory.mktemp("pack")
    write_toy_dataset(root / "data", n=4)
    assert main(["pack", str(root / "data"), "--out", str(root / "train.npz")]) == 0
    return root


def test_pack_reads_back_as_the_dataset(packed):
    a, b = load_dataset(packed / "train.npz"), load_dataset(packed / "data")
    assert a.tensors.keys() == b.tensors.keys()
    for k in b.tensors:
        assert a.tensors[k].dtype == b.tensors[k].dtype and torch.equal(a.tensors[k], b.tensors[k]), k
    assert (a.grid, a.mat, a.partition_names) == (b.grid, b.mat, b.partition_names)
    assert len(load_dataset(packed / "train.npz", limit=3)) == 3


def test_training_on_a_pack_is_training_on_its_dataset(packed):
    """The same command on the pack and on the dataset makes the same model, bit for bit."""
    common = ["--epochs-mod1", "1", "--epochs-mod2", "1", "--batch-size", "2", "--val-fraction", "0.25",
              "--female", "toy", "--male", "toy", "--seed", "3"]
    for src, run in (("data", "run_data"), ("train.npz", "run_pack")):
        assert main(["train", "--data", str(packed / src), "--out", str(packed / run), *common]) == 0
    from safetensors.torch import load_file

    wa, wb = load_file(packed / "run_data" / "model.safetensors"), load_file(packed / "run_pack" / "model.safetensors")
    assert wa.keys() == wb.keys() and all(torch.equal(wa[k], wb[k]) for k in wa)


def test_training_on_a_pack_needs_no_simulator(packed, tmp_path):
    """A GPU machine may lack MuJoCo, h5py, trimesh and SciPy: `train` on a pack imports none of them."""
    code = ("import sys\n"
            "for m in ('mujoco', 'h5py', 'trimesh', 'cma', 'scipy', 'matplotlib'): sys.modules[m] = None\n"
            "from pressurepose.cli import main\n"
            f"sys.exit(main(['train', '--data', {str(packed / 'train.npz')!r}, '--out', {str(tmp_path / 'run')!r}, "
            "'--epochs-mod1', '1', '--epochs-mod2', '1', '--batch-size', '2', '--val-fraction', '0.25', "
            "'--female', 'toy', '--male', 'toy']))\n")
    done = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True)
    assert done.returncode == 0, done.stderr[-2000:]
    assert (tmp_path / "run" / "model.safetensors").exists()


def _rewrite(src, dst, **change):
    with np.load(src, allow_pickle=False) as z:
        arrays = {k: z[k] for k in z.files}
    arrays.update(change)
    for k in [k for k, v in change.items() if v is None]:
        del arrays[k]
    np.savez(dst, **arrays)
    return dst


@pytest.mark.parametrize("change, words", [
    ({"pressure": None}, "lacks pressure"),
    ({"format": np.array("something-else")}, "format is something-else"),
    ({"joints": np.zeros((4, 23, 3), np.float32)}, "joints has shape"),
    ({"pressure": np.full((4, 64, 27), np.nan, np.float32)}, "NaN"),
    ({"pressure": -np.ones((4, 64, 27), np.float32)}, "negative"),
    ({"gender": np.array([0, 1, 2, 0])}, "gender must be 0 or 1"),
])
def test_a_bad_pack_is_named(packed, tmp_path, change, words):
    bad = _rewrite(packed / "train.npz", tmp_path / "bad.npz", **change)
    with pytest.raises(BadInput, match=words) as e:
        load_dataset(bad)
    assert "bad.npz" in str(e.value)


def test_truncated_missing_and_foreign_packs(packed, tmp_path):
    data = (packed / "train.npz").read_bytes()
    (tmp_path / "cut.npz").write_bytes(data[: len(data) // 2])
    (tmp_path / "text.npz").write_text("not a pack")
    for name, words in (("cut.npz", "cut.npz"), ("text.npz", "no .npy / .npz header"), ("none.npz", "does not exist")):
        with pytest.raises(BadInput, match=words):
            load_dataset(tmp_path / name)


def test_pack_verb_checks_its_arguments(packed, tmp_path, capsys):
    assert main(["pack", str(packed / "data"), "--out", str(tmp_path / "p.h5")]) == 2
    assert "expected a file ending in .npz" in capsys.readouterr().err
    assert main(["pack", str(tmp_path / "nothing"), "--out", str(tmp_path / "p.npz")]) == 2
    assert not (tmp_path / "p.npz").exists()


def test_a_dataset_that_is_not_a_path_is_refused_by_name():
    """load_dataset (and evaluate, which calls it for anything but a LoadedData) with None, a number,
    a list or an array was a TypeError from pathlib."""
    from pressurepose.eval.report import evaluate

    for data in (None, 3, ["data"], np.zeros((2, 64, 27))):
        with pytest.raises(BadInput, match=r"^dataset \(a folder made by `generate`, or a training pack .npz\) is .*; "
                                           r"expected a path"):
            load_dataset(data)
    with pytest.raises(BadInput, match=r"^dataset .* is array\(\[\[\[0\., 0\."):  # one line, whatever the array
        evaluate(np.zeros((2, 64, 27)))
