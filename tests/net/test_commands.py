import csv
import json

import numpy as np
import torch

from pressurepose.cli import main
from tests.net.synth import write_toy_dataset

torch.set_num_threads(1)


def test_train_then_infer_verbs(tmp_path, capsys):
    data = write_toy_dataset(tmp_path / "data", n=4)
    run = tmp_path / "run"
    args = ["train", "--data", str(tmp_path / "data"), "--out", str(run), "--epochs-mod1", "1", "--epochs-mod2", "1",
            "--batch-size", "4", "--val-fraction", "0.25", "--female", "toy", "--male", "toy", "--no-noise"]
    assert main(args) == 0
    assert (run / "model.safetensors").exists() and (run / "state.json").exists()
    meta = json.loads((run / "model.json").read_text())
    assert meta["bodies"]["male"]["spec"] == "toy" and meta["train"]["noise"] is False
    rows = list(csv.DictReader(open(run / "log.csv")))
    assert [r["stage"] for r in rows] == ["1", "2"] and float(rows[0]["val_mpjpe_cm"]) > 0
    # the same command again finds the finished run and only rewrites the model
    assert main(args) == 0
    assert len(list(csv.DictReader(open(run / "log.csv")))) == 2
    np.save(tmp_path / "p.npy", data["pressure"][:2].numpy())
    assert main(["infer", str(tmp_path / "p.npy"), "--gender", "f", "--model", str(run), "--out",
                 str(tmp_path / "est")]) == 0
    assert (tmp_path / "est" / "mesh_001.ply").exists()
    assert "model:" in capsys.readouterr().out


def test_train_warns_when_cpu_amp_meets_a_cpu_without_bf16(tmp_path, capsys, monkeypatch):
    import pressurepose.net.train as train_module

    write_toy_dataset(tmp_path / "data", n=4)
    args = ["train", "--data", str(tmp_path / "data"), "--epochs-mod1", "0", "--epochs-mod2", "0", "--device", "cpu",
            "--female", "toy", "--male", "toy", "--no-noise", "--cpu-amp"]
    for has, warned in ((False, True), (True, False), (None, False)):
        monkeypatch.setattr(train_module, "cpu_bf16", lambda has=has: has)
        assert main(args + ["--out", str(tmp_path / f"run_{has}")]) == 0
        assert ("without bf16 instructions" in capsys.readouterr().err) is warned


def test_infer_names_one_frame_of_a_recording_in_the_singular(tmp_path, capsys):
    import pytest

    from pressurepose.net.infer import DEFAULT_MODEL
    from tests.data.realfolders import body_image

    if not DEFAULT_MODEL.is_file():
        pytest.skip("no shipped model")
    np.save(tmp_path / "one.npy", body_image(64, 32))
    np.save(tmp_path / "two.npy", np.stack([body_image(64, 32, seed=s) for s in (1, 2)]))
    for name, said in (("one.npy", "  frame 0 of "), ("two.npy", "  frames 0-1 of ")):
        assert main(["infer", str(tmp_path / name), "--mat", "fsa_softflex_2048", "--units", "raw", "--weight-kg", "70",
                     "--gender", "f", "--out", str(tmp_path / name[:3]), "--max-figures", "0"]) == 0
        assert said + str(tmp_path / name) in capsys.readouterr().out
