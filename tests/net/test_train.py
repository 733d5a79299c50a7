import csv
import json
import re

import numpy as np
import pytest
import torch

import pressurepose.net.train as train_mod
from pressurepose.errors import BadInput
from pressurepose.mat import custom_mat
from pressurepose.net.checkpoint import load_model
from pressurepose.net.losses import joint_error, loss_l1
from pressurepose.net.train import as_training_data, train
from pressurepose.net.train_config import TrainConfig
from tests.net.synth import toy_body, toy_dataset

torch.set_num_threads(1)
GRID = custom_mat(rows=16, cols=16, pitch_row_m=0.125, pitch_col_m=0.0625)  # 2 x 1 m; CNN input 32 x 32


def test_overfits_a_tiny_dataset(tmp_path):
    data = toy_dataset(8, seed=0, grid=GRID)
    body = toy_body()
    cfg = TrainConfig(epochs_mod1=160, epochs_mod2=12, batch_size=8, lr=1e-3, lr_mod2=1e-4, weight_decay=0.0, noise=False,
                      dropout=0.0, save_every=10 ** 6)
    result = train(data, tmp_path, cfg, bodies=(body, body), grid=GRID)
    h1 = [r for r in result.history if r["stage"] == 1]
    h2 = [r for r in result.history if r["stage"] == 2]
    assert h1[0]["train_loss"] > 1.0
    net, meta = load_model(result.model_path)
    d = as_training_data(data, GRID)
    with torch.no_grad():
        out1, out2 = net(d["pressure"], d["gender"])
        l1, _ = loss_l1(out1, d["joints"], d["betas"])
    assert float(l1) < 0.07  # from > 1 (seeds 0-2 reach 0.028-0.042 here)
    assert float(joint_error(out1.joints, d["joints"]).max()) < 0.015  # every sample within 1.5 cm
    assert h2[-1]["train_loss"] < h2[0]["train_loss"]  # Mod2 (L2) improves on Mod1's estimate
    assert float(joint_error(out2.joints, d["joints"]).mean()) < 0.01
    rows = list(csv.DictReader(open(tmp_path / "log.csv")))
    assert len(rows) == 172 and rows[0]["stage"] == "1" and rows[-1]["stage"] == "2"
    assert meta["loss_scales"]["joints_m"] == 0.17528 and meta["train"]["lr"] == 1e-3


def test_interrupted_run_resumes_to_the_same_result(tmp_path, monkeypatch):
    data = toy_dataset(6, seed=1, grid=GRID)
    body = toy_body()
    cfg = TrainConfig(epochs_mod1=2, epochs_mod2=2, batch_size=4, lr=1e-4, val_fraction=0.34)
    full = train(data, tmp_path / "full", cfg, bodies=(body, body), grid=GRID)

    real_save, calls = train_mod._save_state, []

    def save_then_die(*args, **kwargs):
        real_save(*args, **kwargs)
        calls.append(1)
        if len(calls) == 3:  # after Mod2's first epoch
            raise KeyboardInterrupt

    monkeypatch.setattr(train_mod, "_save_state", save_then_die)
    with pytest.raises(KeyboardInterrupt):
        train(data, tmp_path / "cut", cfg, bodies=(body, body), grid=GRID)
    monkeypatch.setattr(train_mod, "_save_state", real_save)
    resumed = train(data, tmp_path / "cut", cfg, bodies=(body, body), grid=GRID)
    a, _ = load_model(full.model_path)
    b, _ = load_model(resumed.model_path)
    for (ka, va), (kb, vb) in zip(a.state_dict().items(), b.state_dict().items()):
        assert ka == kb and torch.equal(va, vb), ka
    assert [r["train_loss"] for r in resumed.history] == [r["train_loss"] for r in full.history]
    assert len(list(csv.DictReader(open(tmp_path / "cut" / "log.csv")))) == 4
    # a different config in the same folder is refused, nothing overwritten
    before = (tmp_path / "cut" / "state.json").read_text()
    with pytest.raises(BadInput, match=r"different config.*train\.lr 0\.0001 -> 0\.0002"):
        train(data, tmp_path / "cut", TrainConfig(epochs_mod1=2, epochs_mod2=2, batch_size=4, lr=2e-4),
              bodies=(body, body), grid=GRID)
    assert (tmp_path / "cut" / "state.json").read_text() == before
    assert json.loads(before)["stage"] == 2


def test_bad_training_data_is_refused(tmp_path):
    data = toy_dataset(2, grid=GRID)
    body = toy_body()
    for key, value, match in [("pressure", torch.zeros(2, 15, 16), "shape"),
                              ("pressure", torch.full((2, 16, 16), -1.0), "negative"),
                              ("joints", torch.full((2, 24, 3), float("nan")), "NaN"),
                              ("gender", ["f", "x"], "gender"),
                              ("gender", torch.tensor([0, 2]), r"gender must be 0 or 1.*\[2\]"),
                              ("betas", torch.zeros(2, 9), r"training data: betas has shape \(2, 9\); expected \(2, 10\)"),
                              ("transl", np.array([["a"] * 3] * 2), "transl holds <U1 values; expected numbers")]:
        bad = dict(data, **{key: value})
        with pytest.raises(BadInput, match=match):
            train(bad, tmp_path, TrainConfig(epochs_mod1=0, epochs_mod2=0), bodies=(body, body), grid=GRID)
    with pytest.raises(BadInput, match="lacks"):
        train({k: v for k, v in data.items() if k != "betas"}, tmp_path, bodies=(body, body), grid=GRID)
    with pytest.raises(BadInput, match="empty"):
        train({k: v[:0] for k, v in data.items()}, tmp_path, bodies=(body, body), grid=GRID)
    d = as_training_data(dict(data, gender=["m", "f"]), GRID)  # the one check, no partition needed
    assert d["gender"].tolist() == [1, 0] and d["pressure"].dtype == torch.float32 and "partition" not in d
    with pytest.raises(BadInput):
        TrainConfig(loss_sigmas="other")


def test_trains_on_what_load_dataset_returns_on_its_own_mat(tmp_path):
    """train() takes the LoadedData of load_dataset as it is and trains on its mat, not the default one."""
    from pressurepose.net.data import LoadedData

    tensors = dict(toy_dataset(4, seed=2, grid=GRID), partition=torch.zeros(4, dtype=torch.long))
    loaded = LoadedData(tensors, GRID, "custom", ("general",))
    body = toy_body()
    cfg = TrainConfig(epochs_mod1=1, epochs_mod2=0, batch_size=4)
    result = train(loaded, tmp_path / "run", cfg, bodies=(body, body))
    net, _ = load_model(result.model_path, bodies=(body, body))
    assert net.config.grid.shape == GRID.shape
    with pytest.raises(BadInput, match="data's mat"):
        train(loaded, tmp_path / "other", cfg, bodies=(body, body), grid=custom_mat(rows=8, cols=8, pitch_row_m=0.1))
    with pytest.raises(BadInput, match="LoadedData of load_dataset"):  # images of another mat, default grid
        train(tensors, tmp_path / "plain", cfg, bodies=(body, body))


def test_tensorboard_log_matches_the_csv(tmp_path):
    pytest.importorskip("tensorboard")
    from tensorboard.backend.event_processing.event_accumulator import EventAccumulator

    data = toy_dataset(6, seed=2, grid=GRID)
    body = toy_body()
    cfg = TrainConfig(epochs_mod1=2, epochs_mod2=1, batch_size=4, lr=1e-4, val_fraction=0.34)
    train(data, tmp_path, cfg, bodies=(body, body), grid=GRID)
    events = EventAccumulator(str(tmp_path / "tb"))
    events.Reload()
    rows = list(csv.DictReader(open(tmp_path / "log.csv")))
    for stage, key in (("1", "train_loss"), ("1", "val_mpjpe_cm"), ("2", "train_loss")):
        logged = [(e.step, e.value) for e in events.Scalars(f"mod{stage}/{key}")]
        expected = [(int(r["epoch"]), float(r[key])) for r in rows if r["stage"] == stage]
        assert [s for s, _ in logged] == [s for s, _ in expected]
        assert [v for _, v in logged] == pytest.approx([v for _, v in expected], rel=1e-6)


def test_cosine_schedule_sets_each_epochs_rate(tmp_path):
    data = toy_dataset(4, seed=3, grid=GRID)
    body = toy_body()
    cfg = TrainConfig(epochs_mod1=4, epochs_mod2=2, batch_size=4, lr=1e-3, lr_mod2=2e-4, lr_schedule="cosine")
    train(data, tmp_path, cfg, bodies=(body, body), grid=GRID)
    rows = list(csv.DictReader(open(tmp_path / "log.csv")))
    got = [(int(r["stage"]), float(r["lr"])) for r in rows]
    want = [(1, 1e-3), (1, 1e-3 * (1 + 0.5 ** 0.5) / 2), (1, 5e-4), (1, 1e-3 * (1 - 0.5 ** 0.5) / 2), (2, 2e-4), (2, 1e-4)]
    assert [s for s, _ in got] == [s for s, _ in want]
    assert [lr for _, lr in got] == pytest.approx([lr for _, lr in want], rel=1e-9)
    with pytest.raises(BadInput, match="lr_schedule"):
        TrainConfig(lr_schedule="step")


def test_training_set_goes_to_the_gpu_only_when_it_leaves_room(monkeypatch):
    from pressurepose.net.train import _fits_on_gpu

    monkeypatch.setattr(torch.cuda, "mem_get_info", lambda device=None: (4000, 8000))  # bytes free, total
    small, big = torch.zeros(250, dtype=torch.float32), torch.zeros(251, dtype=torch.float32)  # 1,000 / 1,004 B
    assert _fits_on_gpu(torch.device("cuda"), small, None, "not a tensor")
    assert not _fits_on_gpu(torch.device("cuda"), big)
    assert not _fits_on_gpu(torch.device("cuda"), small, torch.zeros(1, dtype=torch.uint8))


@pytest.mark.parametrize("field,value,message", [
    ("noise", "no", "noise = 'no'; expected True or False"),  # a non-empty string was true: noise on
    ("use_pmr", None, "use_pmr = None; expected True or False"),
    ("amp", 1, "amp = 1; expected True or False"),
    ("noise_config", {}, "noise_config is dict; expected a NoiseConfig"),
    ("blur_sigma", float("nan"), r"blur_sigma \(taxels\) is nan"),
    ("dropout", 1.5, "dropout is 1.5; expected a probability from 0 to below 1"),
    ("gain", 0, r"gain \(output gain\) is 0; expected a positive number"),
    ("val_fraction", "0.1", "val_fraction is '0.1'; expected a finite number"),  # was a TypeError
    ("val_fraction", None, "val_fraction is None"),
    ("device", None, "device = None; expected a device name"),
])
def test_train_config_checks_every_field_by_name(field, value, message):
    with pytest.raises(BadInput, match=message):
        TrainConfig(**{field: value})


def test_noise_config_values_are_checked():
    from pressurepose.net.train_config import NoiseConfig

    with pytest.raises(BadInput, match=r"noise_config.add_std is -1"):
        NoiseConfig(add_std=-1)
    with pytest.raises(BadInput, match=r"noise_config.clip_max is 0"):
        NoiseConfig(clip_max=0)


def test_train_refuses_arguments_of_the_wrong_kind_and_writes_nothing(tmp_path):
    """train(None, ...), a dict config, bodies given by name, a mat name as the grid and a file as the
    run folder were AttributeErrors, TypeErrors or FileExistsError; a config no network can be built
    from left an empty run folder behind."""
    data = toy_dataset(2, grid=GRID)
    body = toy_body()
    cfg = TrainConfig(epochs_mod1=0, epochs_mod2=0)
    (tmp_path / "afile").write_text("x")
    for args, kwargs, message in (((None, tmp_path / "a"), {}, "data is NoneType; expected a LoadedData"),
                                  ((data, tmp_path / "b", {}), {}, "config is dict; expected a TrainConfig"),
                                  ((data, tmp_path / "c", cfg), {"bodies": ("female", "male")},
                                   r"bodies is \('female', 'male'\); expected \(female, male\) BodyModels"),
                                  ((data, tmp_path / "d", cfg), {"bodies": (body, body), "grid": "boditrak_bt3510"},
                                   "grid is str; expected a MatSpec"),
                                  ((data, tmp_path / "afile", cfg), {"bodies": (body, body), "grid": GRID},
                                   "out_dir .*afile is a file; expected a folder"),
                                  ((data, None, cfg), {"bodies": (body, body), "grid": GRID},
                                   "out_dir is None; expected a path"),
                                  ((data, tmp_path / "e", TrainConfig(epochs_mod1=0, epochs_mod2=0, upsample=64)),
                                   {"bodies": (body, body), "grid": GRID}, "inputs.upsample is 64")):  # when the net is built
        with pytest.raises(BadInput, match=message):
            train(*args, **kwargs)
    assert sorted(p.name for p in tmp_path.iterdir()) == ["afile"]


def test_the_train_verb_says_what_it_trains_on_and_how_far_a_resumed_run_had_gone(tmp_path, capsys, monkeypatch):
    from pressurepose.cli import main
    from tests.net.synth import write_toy_dataset

    write_toy_dataset(tmp_path / "data", n=4)
    args = ["train", "--data", str(tmp_path / "data"), "--out", str(tmp_path / "run"), "--epochs-mod1", "2",
            "--epochs-mod2", "1", "--batch-size", "2", "--val-fraction", "0.25", "--female", "toy", "--male", "toy"]
    real_save = train_mod._save_state

    def save_then_die(*a, **kw):
        real_save(*a, **kw)
        raise KeyboardInterrupt  # after Mod1's first epoch

    monkeypatch.setattr(train_mod, "_save_state", save_then_die)
    assert main(args) == 130
    out, err = capsys.readouterr()
    assert "training on 3 samples, validating on 1 " in out and "resuming" not in err
    monkeypatch.setattr(train_mod, "_save_state", real_save)
    assert main(args) == 0
    out, err = capsys.readouterr()
    assert f"resuming the run in {tmp_path / 'run'}: Mod1 1 of 2 epochs done, Mod2 0 of 1" in err
    # a line per epoch it trains (not the one done before), each with its validation MPJPE
    epochs = [ln for ln in err.splitlines() if re.match(r"mod\d epoch \d/\d: loss ", ln)]
    assert [ln.split(":")[0] for ln in epochs] == ["mod1 epoch 2/2", "mod2 epoch 1/1"]
    assert all(re.search(r"joints \d+\.\d cm \(validation MPJPE \d+\.\d cm\), \d+ s$", ln) for ln in epochs)
    assert main(args) == 0  # a finished run says so too
    assert "Mod1 2 of 2 epochs done, Mod2 1 of 1" in capsys.readouterr().err
    everything = [a if a != "0.25" else "0" for a in args] + ["--out", str(tmp_path / "all")]  # no validation
    assert main(everything) == 0
    assert "training on 4 samples (" in capsys.readouterr().out


def _cut_after_first_epoch(monkeypatch, data, out, cfg, body):
    """Train ``cfg`` into ``out`` until its first saved state, then stop as an interruption would."""
    real_save = train_mod._save_state

    def save_then_die(*a, **kw):
        real_save(*a, **kw)
        raise KeyboardInterrupt

    monkeypatch.setattr(train_mod, "_save_state", save_then_die)
    with pytest.raises(KeyboardInterrupt):
        train(data, out, cfg, bodies=(body, body), grid=GRID, progress=False)
    monkeypatch.setattr(train_mod, "_save_state", real_save)


@pytest.mark.parametrize("stored", ["the paper's values", "no floor or validation share named"])
def test_a_run_started_with_the_papers_floor_and_share_resumes_with_them(tmp_path, monkeypatch, stored):
    """A run whose state holds the paper's contact floor and validation share (0, 0), or names
    neither (its net config no floor either), resumes with those values and ends as an uninterrupted
    run of them; resuming it with TrainConfig's defaults (5 mmHg, 5 %) is refused by name."""
    from pressurepose.net.train_config import PAPER_TRAINING

    data = toy_dataset(4, seed=5, grid=GRID)
    body = toy_body()
    paper = TrainConfig(**PAPER_TRAINING, epochs_mod1=2, epochs_mod2=0, batch_size=4, lr=1e-4)
    full = train(data, tmp_path / "full", paper, bodies=(body, body), grid=GRID, progress=False)
    _cut_after_first_epoch(monkeypatch, data, tmp_path / "cut", paper, body)
    state = tmp_path / "cut" / "state.json"
    if stored != "the paper's values":
        record = json.loads(state.read_text())
        for name in PAPER_TRAINING:
            del record["identity"]["train"][name]
        del record["identity"]["net"]["inputs"]["contact_floor_mmhg"]
        state.write_text(json.dumps(record))
    before = state.read_text()
    with pytest.raises(BadInput, match=r"different config.*train\.contact_floor_mmhg 0\.0 -> 5\.0.*"
                                       r"train\.val_fraction 0\.0 -> 0\.05"):
        train(data, tmp_path / "cut", TrainConfig(epochs_mod1=2, epochs_mod2=0, batch_size=4, lr=1e-4),
              bodies=(body, body), grid=GRID, progress=False)
    assert state.read_text() == before
    resumed = train(data, tmp_path / "cut", paper, bodies=(body, body), grid=GRID, progress=False)
    assert [r["train_loss"] for r in resumed.history] == [r["train_loss"] for r in full.history]
    net, meta = load_model(resumed.model_path, bodies=(body, body))
    assert net.config.inputs.contact_floor_mmhg == 0.0
    assert (meta["train"]["contact_floor_mmhg"], meta["train"]["val_fraction"]) == (0.0, 0.0)
    assert "val_mpjpe_cm" not in resumed.history[-1]  # trained on every sample, as it started


def test_train_shows_its_progress_by_default_and_not_with_progress_false(tmp_path, capsys):
    data = toy_dataset(4, seed=6, grid=GRID)
    body = toy_body()
    cfg = TrainConfig(epochs_mod1=1, epochs_mod2=0, batch_size=2, lr=1e-4)
    train(data, tmp_path / "shown", cfg, bodies=(body, body), grid=GRID)
    err = capsys.readouterr().err
    assert re.search(r"mod1 epoch 1/1: +\d+%\|", err)  # the epoch's bar (tqdm)
    assert re.search(r"mod1 epoch 1/1: loss \S+, joints", err)  # and its line
    train(data, tmp_path / "quiet", cfg, bodies=(body, body), grid=GRID, progress=False)
    assert capsys.readouterr().err == ""
