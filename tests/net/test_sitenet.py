"""The site network: inputs, mirror, loss, training (overfits, resumes), saving and loading."""

import json

import numpy as np
import pytest
import torch

from pressurepose.body.sites import NO_SITE, SITES
from pressurepose.errors import BadInput
from pressurepose.mat import custom_mat
from pressurepose.net import sitenet_train
from pressurepose.net.sitenet import (
    N_INPUTS,
    SiteNet,
    SiteNetConfig,
    load_site_net,
    mirrored_sites,
    read_taxel_sites,
    save_site_net,
    site_inputs,
)
from pressurepose.net.sitenet_train import SiteData, SiteTrainConfig, flipped, site_loss, train_site_net

GRID = custom_mat(12, 7, 0.05)


def _toy_data(n=16, seed=0):
    """Images whose true site is head in the upper half and sacrum below; the body route says 'other'."""
    rng = np.random.default_rng(seed)
    p = (rng.uniform(5, 60, (n, *GRID.shape)) * (rng.random((n, *GRID.shape)) < 0.7)).astype(np.float32)
    rows = np.arange(GRID.rows)[None, :, None]
    truth = np.where(p > 0, np.where(rows < GRID.rows // 2, SITES.index("head"), SITES.index("sacrum")), NO_SITE)
    body = np.where(p > 0, SITES.index("other"), NO_SITE)
    return SiteData(p, body.astype(np.int8), truth.astype(np.int8), GRID)


def test_mirror_swaps_left_and_right_sites_and_is_its_own_inverse():
    m = mirrored_sites()
    assert m[SITES.index("left_elbow")] == SITES.index("right_elbow")
    assert m[SITES.index("right_trochanter")] == SITES.index("left_trochanter")
    assert m[SITES.index("head")] == SITES.index("head") and m[SITES.index("other")] == SITES.index("other")
    np.testing.assert_array_equal(m[m], np.arange(len(SITES)))
    s = np.array([[[SITES.index("left_heel"), NO_SITE, SITES.index("sacrum")]]], np.int8)
    np.testing.assert_array_equal(flipped(s), [[[SITES.index("sacrum"), NO_SITE, SITES.index("right_heel")]]])
    np.testing.assert_array_equal(flipped(flipped(s)), s)


def test_inputs_one_hot_the_body_sites_and_scale_the_pressure():
    p = np.zeros((1, *GRID.shape), np.float32)
    p[0, 2, 3] = 50.0
    body = np.full(p.shape, NO_SITE, np.int8)
    body[0, 2, 3] = SITES.index("sacrum")
    x = site_inputs(p, body, SiteNetConfig(GRID)).numpy()
    assert x.shape == (1, N_INPUTS, *GRID.shape)
    assert x[0, 0, 2, 3] == pytest.approx(0.5) and x[0, 1].sum() == 1
    np.testing.assert_allclose(x[0, 4:].sum(0), 1.0)
    assert x[0, 4 + SITES.index("sacrum"), 2, 3] == 1 and x[0, 4 + len(SITES), 0, 0] == 1
    assert x[0, 2, -1, 0] == 1 and x[0, 3, 0, -1] == 1
    with pytest.raises(BadInput, match=r"\(B, 12, 7\)"):
        site_inputs(p[:, :5], body[:, :5], SiteNetConfig(GRID))
    with pytest.raises(BadInput, match="indices into SITES"):
        site_inputs(p, np.full(p.shape, len(SITES), np.int8), SiteNetConfig(GRID))
    with pytest.raises(BadInput, match="integers"):
        site_inputs(p, body.astype(np.float32), SiteNetConfig(GRID))


def test_loss_is_the_weighted_cross_entropy_over_loaded_taxels():
    torch.manual_seed(0)
    logits = torch.randn(2, len(SITES), 3, 2)
    pressure = torch.tensor([[[10.0, 0.0], [30.0, 0.0], [0.0, 0.0]], [[0.0] * 2] * 3])
    truth = torch.tensor([[[1, -1], [4, -1], [-1, -1]], [[-1] * 2] * 3])
    logp = torch.log_softmax(logits, 1)
    first = -(0.5 * (10 / 40) + 0.25) * logp[0, 1, 0, 0] - (0.5 * (30 / 40) + 0.25) * logp[0, 4, 1, 0]
    assert float(site_loss(logits, truth, pressure)) == pytest.approx(float(first) / 2, rel=1e-5)


def test_training_overfits_a_small_set_and_reads_the_true_sites():
    data = _toy_data()
    net = train_site_net(data, SiteTrainConfig(epochs=30, batch_size=8, lr=5e-3, width=8), progress=False)
    read = read_taxel_sites(net, data.pressure, data.body_sites)
    on = data.pressure > 0
    assert (read[on] == data.truth[on]).mean() > 0.97
    assert (read[~on] == NO_SITE).all()


def test_training_resumes_where_it_stopped(tmp_path, monkeypatch):
    data, config = _toy_data(8), SiteTrainConfig(epochs=2, batch_size=4, width=4)
    whole = train_site_net(data, config, out=tmp_path / "whole", progress=False)
    real_write = sitenet_train.atomic_write

    def stop_after_first_epoch(path, write):
        real_write(path, write)
        raise KeyboardInterrupt

    monkeypatch.setattr(sitenet_train, "atomic_write", stop_after_first_epoch)
    with pytest.raises(KeyboardInterrupt):
        train_site_net(data, config, out=tmp_path / "cut", progress=False)
    monkeypatch.setattr(sitenet_train, "atomic_write", real_write)
    assert torch.load(tmp_path / "cut" / "state.pt", weights_only=True)["epoch"] == 1
    resumed = train_site_net(data, config, out=tmp_path / "cut", progress=False)
    for (k, a), b in zip(whole.state_dict().items(), resumed.state_dict().values()):
        torch.testing.assert_close(a, b, msg=k)
    with pytest.raises(BadInput, match="other settings"):
        train_site_net(data, SiteTrainConfig(epochs=3, batch_size=4, width=4), out=tmp_path / "cut", progress=False)


def test_a_saved_network_loads_and_reads_the_same(tmp_path):
    torch.manual_seed(1)
    net = SiteNet(SiteNetConfig(GRID, width=4)).eval()
    data = _toy_data(3)
    path = save_site_net(tmp_path / "s.json", net, {"samples": 3})
    loaded = load_site_net(path)
    np.testing.assert_array_equal(read_taxel_sites(net, data.pressure, data.body_sites),
                                  read_taxel_sites(loaded, data.pressure, data.body_sites))
    assert loaded.config == net.config and loaded.meta["samples"] == 3


def test_loading_refuses_what_is_not_a_site_network(tmp_path):
    with pytest.raises(BadInput, match="does not exist"):
        load_site_net(tmp_path / "absent.json")
    (tmp_path / "x.json").write_text(json.dumps({"format": "something else"}))
    with pytest.raises(BadInput, match="not a site network"):
        load_site_net(tmp_path / "x.json")
    (tmp_path / "y.json").write_text("{not json")
    with pytest.raises(BadInput, match="not JSON"):
        load_site_net(tmp_path / "y.json")
    path = save_site_net(tmp_path / "z.json", SiteNet(SiteNetConfig(GRID, width=4)))
    record = json.loads(path.read_text())
    (tmp_path / "old.json").write_text(json.dumps({**record, "sites": ["head", "other"]}))
    with pytest.raises(BadInput, match="train it again"):
        load_site_net(tmp_path / "old.json")
    path.with_suffix(".safetensors").write_bytes(b"truncated")
    with pytest.raises(BadInput, match="do not load"):
        load_site_net(path)
    path.with_suffix(".safetensors").unlink()
    with pytest.raises(BadInput, match="missing"):
        load_site_net(path)


def test_bad_settings_are_refused():
    with pytest.raises(BadInput, match="width"):
        SiteNetConfig(GRID, width=0)
    with pytest.raises(BadInput, match="epochs"):
        SiteTrainConfig(epochs=0)
    with pytest.raises(BadInput, match="lr"):
        SiteTrainConfig(lr=float("nan"))
    with pytest.raises(BadInput, match=r"\(N, 12, 7\)"):
        SiteData(np.zeros((2, 12, 7), np.float32), np.zeros((2, 12, 6), np.int8), np.zeros((2, 12, 7), np.int8), GRID)


def _says_head_everywhere(grid):
    net = SiteNet(SiteNetConfig(grid, width=4)).eval()
    with torch.no_grad():
        net.head.bias[SITES.index("head")] = 1e3
    return net


def test_estimate_reads_each_loaded_taxels_site_with_the_site_network_for_its_mat(monkeypatch, tmp_path):
    from pressurepose.body.model import BodyModel  # noqa: F401  (the toy model below builds one)
    from pressurepose.net import infer
    from pressurepose.net.checkpoint import gendered_body, save_model
    from pressurepose.net.model import NetConfig, PressureNet
    from pressurepose.net.outputs import OutputConfig
    from tests.net.synth import toy_body, toy_dataset

    grid = custom_mat(rows=16, cols=16, pitch_row_m=0.125, pitch_col_m=0.0625)
    torch.manual_seed(0)
    body = toy_body()
    model = save_model(tmp_path / "m.safetensors", PressureNet(NetConfig(
        grid=grid, outputs=OutputConfig.default((0.5, 1.0, 0.2), (0.3, 0.3, 0.1))), gendered_body(body, body)),
        (body, body))
    p = toy_dataset(2, grid=grid)["pressure"].numpy()
    plain = infer.estimate(p, "f", model=model)
    assert plain.site_net is None and plain.sites_read_by == "estimated body"  # no site network for this mat
    monkeypatch.setattr(infer, "site_net_for", lambda g: _says_head_everywhere(g) if g.same_grid(grid) else None)
    est = infer.estimate(p, "f", model=model)
    assert est.sites_read_by == "site network"
    np.testing.assert_array_equal(est.sites.taxel_site, np.where(p > 0, SITES.index("head"), NO_SITE))
    np.testing.assert_allclose(est.sites.share[:, SITES.index("head")], 1.0)
    np.testing.assert_allclose(est.vertex_pressure, plain.vertex_pressure)  # the body's surface reads as before
    est.save(tmp_path / "out")
    rec = json.loads((tmp_path / "out" / "sites.json").read_text())
    assert rec["sites_read_by"] == "site network" and rec["images"][0]["most_loaded"] == "head"
