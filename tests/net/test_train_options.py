"""The training speed options: each still overfits a tiny set, the skeleton-only body pass gives
the same gradients, variants save and load safely, and a run resumes only under its own config."""

import pytest
import torch

from pressurepose.errors import BadInput
from pressurepose.net.checkpoint import gendered_body, load_model, save_model
from pressurepose.net.losses import joint_error, loss_l1
from pressurepose.net.model import PressureNet
from pressurepose.net.train import (
    _forward,
    as_training_data,
    net_config_for,
    train,
)
from pressurepose.net.train_config import CNN_VARIANTS, TrainConfig
from tests.net.synth import toy_body, toy_dataset
from tests.net.test_train import GRID

torch.set_num_threads(1)


@pytest.mark.parametrize("option", [{"cnn": "half"}, {"cpu_amp": True}])
def test_each_speed_option_still_overfits_a_tiny_dataset(tmp_path, option):
    data = toy_dataset(8, seed=0, grid=GRID)
    body = toy_body()
    cfg = TrainConfig(epochs_mod1=160, epochs_mod2=0, batch_size=8, lr=1e-3, weight_decay=0.0, noise=False,
                      dropout=0.0, save_every=10 ** 6, **option)
    result = train(data, tmp_path, cfg, bodies=(body, body), grid=GRID)
    net, meta = load_model(result.model_path)
    assert list(net.config.cnn_channels) == list(CNN_VARIANTS[cfg.cnn]) and meta["train"]["cpu_amp"] == cfg.cpu_amp
    d = as_training_data(data, GRID)
    with torch.no_grad():
        out1, _ = net(d["pressure"], d["gender"])
        l1, _ = loss_l1(out1, d["joints"], d["betas"])
    assert result.history[0]["train_loss"] > 1.0
    assert float(l1) < 0.15  # paper CNN, float32: 0.03; half 0.02, bf16 0.05
    assert float(joint_error(out1.joints, d["joints"]).max()) < 0.03


@pytest.mark.parametrize("stage", [1, 2])
def test_skeleton_only_body_pass_gives_the_same_loss_and_gradients(stage):
    data = as_training_data(toy_dataset(4, seed=5, grid=GRID), GRID)
    body = toy_body()
    cfg = TrainConfig(noise=False, dropout=0.0, use_pmr=False)
    torch.manual_seed(0)
    net = PressureNet(net_config_for(cfg, GRID, data["transl"]), gendered_body(body, body)).train()
    torch.nn.init.normal_(net.mod2.cnn.fc.weight, std=1e-3)
    module = net.mod1 if stage == 1 else net.mod2
    grads = []
    for vertices in (False, True):
        net.zero_grad()
        if vertices:  # the former path: the full mesh posed
            x1 = net.inputs(data["pressure"])
            out = net.run_mod1(x1, data["gender"], maps=False)
            if stage == 2:
                out = net.run_mod2(x1, data["gender"], out, maps=False)
            assert out.vertices is not None
        else:
            out = _forward(net, stage, data["pressure"], data["gender"], None, cfg, maps=False)
            assert out.vertices is None
        loss, _ = loss_l1(out, data["joints"], data["betas"])
        loss.backward()
        grads.append([p.grad.clone() for p in module.parameters()])
    for a, b in zip(*grads):
        torch.testing.assert_close(a, b, rtol=1e-5, atol=1e-8)


def test_a_variant_saves_and_loads_with_weights_only(tmp_path):
    data = toy_dataset(4, seed=6, grid=GRID)
    body = toy_body()
    cfg = TrainConfig(cnn="half")
    net = PressureNet(net_config_for(cfg, GRID, as_training_data(data, GRID)["transl"]), gendered_body(body, body))
    for name in ("m.pt", "m.safetensors"):
        path = save_model(tmp_path / name, net, (body, body))
        loaded, _ = load_model(path)  # .pt files are read with torch.load(weights_only=True)
        assert loaded.config == net.config and loaded.mod1.cnn.convs[-1].out_channels == 192
        for (k, a), (_, b) in zip(net.state_dict().items(), loaded.state_dict().items()):
            assert torch.equal(a, b), k
    with pytest.raises(BadInput, match="cnn"):
        TrainConfig(cnn="tiny")


def test_a_run_resumes_under_its_own_config_only(tmp_path):
    data = toy_dataset(4, seed=7, grid=GRID)
    body = toy_body()
    cfg = TrainConfig(epochs_mod1=1, epochs_mod2=0, batch_size=4, lr=1e-4)
    train(data, tmp_path, cfg, bodies=(body, body), grid=GRID)
    more = train(data, tmp_path, TrainConfig(epochs_mod1=2, epochs_mod2=0, batch_size=4, lr=1e-4),
                 bodies=(body, body), grid=GRID)
    assert [r["epoch"] for r in more.history] == [0, 1]
    with pytest.raises(BadInput, match="different config"):  # another CNN is another run
        train(data, tmp_path, TrainConfig(epochs_mod1=3, epochs_mod2=0, batch_size=4, lr=1e-4, cnn="half"),
              bodies=(body, body), grid=GRID)


def test_a_finished_mod1_cannot_be_extended_once_mod2_has_trained(tmp_path):
    data = toy_dataset(4, seed=9, grid=GRID)
    body = toy_body()
    train(data, tmp_path, TrainConfig(epochs_mod1=1, epochs_mod2=1, batch_size=4, lr=1e-4, cnn="half"),
          bodies=(body, body), grid=GRID)
    with pytest.raises(BadInput, match="Mod1 finished after 1 epoch"):
        train(data, tmp_path, TrainConfig(epochs_mod1=3, epochs_mod2=1, batch_size=4, lr=1e-4, cnn="half"),
              bodies=(body, body), grid=GRID)
    more = train(data, tmp_path, TrainConfig(epochs_mod1=1, epochs_mod2=2, batch_size=4, lr=1e-4, cnn="half"),
                 bodies=(body, body), grid=GRID)  # more Mod2 epochs are fine
    assert [(r["stage"], r["epoch"]) for r in more.history] == [(1, 0), (2, 0), (2, 1)]


def test_options_train_deterministically(tmp_path):
    data = toy_dataset(4, seed=8, grid=GRID)
    body = toy_body()
    cfg = TrainConfig(epochs_mod1=2, epochs_mod2=1, batch_size=2, lr=1e-3, cnn="half", cpu_amp=True)
    a = train(data, tmp_path / "a", cfg, bodies=(body, body), grid=GRID)
    b = train(data, tmp_path / "b", cfg, bodies=(body, body), grid=GRID)
    assert [r["train_loss"] for r in a.history] == [r["train_loss"] for r in b.history]
    for (k, va), (_, vb) in zip(load_model(a.model_path)[0].state_dict().items(),
                                load_model(b.model_path)[0].state_dict().items()):
        assert torch.equal(va, vb), k


def test_the_contact_floor_applies_in_training_and_is_kept_by_the_model(tmp_path):
    """Faint readings at or below the floor change neither a training step's (noisy) forward pass
    nor a saved model's estimate: training and inference see the same input."""
    data = as_training_data(toy_dataset(4, seed=9, grid=GRID), GRID)
    body = toy_body()
    cfg = TrainConfig(dropout=0.0, contact_floor_mmhg=5.0)
    torch.manual_seed(0)
    net = PressureNet(net_config_for(cfg, GRID, data["transl"]), gendered_body(body, body)).eval()
    p = torch.where(data["pressure"] > 5.0, data["pressure"], torch.zeros_like(data["pressure"]))
    faint = p + (p == 0) * 4.9
    outs = [_forward(net, 1, x, data["gender"], torch.Generator().manual_seed(3), cfg, maps=False).joints
            for x in (p, faint)]
    torch.testing.assert_close(outs[0], outs[1], rtol=0, atol=0)
    loaded, _ = load_model(save_model(tmp_path / "m.pt", net, (body, body)))
    assert loaded.config.inputs.contact_floor_mmhg == 5.0
    with torch.no_grad():
        torch.testing.assert_close(loaded(faint, data["gender"])[1].joints, loaded(p, data["gender"])[1].joints,
                                   rtol=0, atol=0)
    with pytest.raises(BadInput, match="contact_floor_mmhg"):
        TrainConfig(contact_floor_mmhg=-2.0)
