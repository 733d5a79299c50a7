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


def _toy_model(tmp_path, grid):
    """A toy PressureNet on ``grid``, saved under ``tmp_path`` (its path)."""
    from pressurepose.body.model import BodyModel  # noqa: F401  (the toy model below builds one)
    from pressurepose.net.checkpoint import gendered_body, save_model
    from pressurepose.net.model import NetConfig, PressureNet
    from pressurepose.net.outputs import OutputConfig
    from tests.net.synth import toy_body

    torch.manual_seed(0)
    body = toy_body()
    return save_model(tmp_path / "m.safetensors", PressureNet(NetConfig(
        grid=grid, outputs=OutputConfig.default((0.5, 1.0, 0.2), (0.3, 0.3, 0.1))), gendered_body(body, body)),
        (body, body))


def test_estimate_reads_each_loaded_taxels_site_with_the_site_network_it_is_given(monkeypatch, tmp_path):
    from pressurepose.net import infer, sitenet
    from tests.net.synth import toy_dataset

    grid = custom_mat(rows=16, cols=16, pitch_row_m=0.125, pitch_col_m=0.0625)
    model = _toy_model(tmp_path, grid)
    p = toy_dataset(2, grid=grid)["pressure"].numpy()
    plain = infer.estimate(p, "f", model=model)
    assert plain.site_net is None and plain.sites_read_by == "estimated body"  # none ships for this mat
    head = save_site_net(tmp_path / "head.json", _says_head_everywhere(grid))
    est = infer.estimate(p, "f", model=model, site_net=head)
    assert est.sites_read_by == "site network"
    np.testing.assert_array_equal(est.sites.taxel_site, np.where(p > 0, SITES.index("head"), NO_SITE))
    np.testing.assert_allclose(est.sites.share[:, SITES.index("head")], 1.0)
    np.testing.assert_allclose(est.vertex_pressure, plain.vertex_pressure)  # the body's surface reads as before
    est.save(tmp_path / "out")
    rec = json.loads((tmp_path / "out" / "sites.json").read_text())
    assert rec["sites_read_by"] == "site network" and rec["images"][0]["most_loaded"] == "head"
    assert rec["site_network"] == str(head)  # which network, so that the figures can be made again
    plain.save(tmp_path / "plain")
    assert json.loads((tmp_path / "plain" / "sites.json").read_text())["site_network"] is None
    # 'auto' takes the shipped network when it reads the model's mat; None the body alone
    monkeypatch.setattr(sitenet, "shipped_site_net", lambda: _says_head_everywhere(grid))
    assert infer.estimate(p, "f", model=model).sites_read_by == "site network"
    assert infer.estimate(p, "f", model=model, site_net=None).sites_read_by == "estimated body"


def test_a_site_network_for_another_mat_or_of_another_kind_is_refused(tmp_path):
    from pressurepose.net.infer import estimate
    from pressurepose.net.sitenet import resolve_site_net

    grid = custom_mat(rows=16, cols=16, pitch_row_m=0.125, pitch_col_m=0.0625)
    other = save_site_net(tmp_path / "other.json", SiteNet(SiteNetConfig(GRID, width=4)))
    with pytest.raises(BadInput, match=r"other.json.*12 x 7 mat; the model reads 16 x 16.*train-sites"):
        estimate(np.zeros((1, 16, 16), np.float32) + 1, "f", model=_toy_model(tmp_path, grid), site_net=other)
    with pytest.raises(BadInput, match="site_net is int"):
        resolve_site_net(3, grid)
    with pytest.raises(BadInput, match="does not exist"):
        resolve_site_net(tmp_path / "missing.json", grid)
    assert resolve_site_net(None, grid) is None


def test_most_loaded_right_scores_the_top_site_against_the_simulators():
    from pressurepose.net.sitenet_train import most_loaded_right

    data = _toy_data(8)  # truth: head above, sacrum below; the body route says other
    assert most_loaded_right(data, None) == 0.0
    top = np.array([np.bincount(np.where(t >= 0, t, len(SITES)).ravel(), weights=p.ravel(),
                                minlength=len(SITES) + 1)[:-1].argmax() for p, t in zip(data.pressure, data.truth)])
    expected = np.mean(top == SITES.index("head"))
    assert 0 < expected < 1  # some images carry more on the upper half, some on the lower
    assert most_loaded_right(data, _says_head_everywhere(GRID)) == pytest.approx(expected)


def test_held_out_split_is_seeded_and_disjoint():
    from pressurepose.net.sitenet_train import held_out_split

    data = _toy_data(20)
    train, held = held_out_split(data, seed=3)
    assert (len(train), len(held)) == (18, 2)
    again = held_out_split(data, seed=3)[1]
    np.testing.assert_array_equal(held.pressure, again.pressure)
    key = {p.tobytes() for p in train.pressure}
    assert not any(p.tobytes() in key for p in held.pressure)
    assert len(held_out_split(data, seed=3, fraction=0.0)[1]) == 0
    with pytest.raises(BadInput, match="fraction"):
        held_out_split(data, seed=3, fraction=1.0)


def _sited_dataset(out, mat: str, n: int):
    """n synthetic samples on ``mat`` whose loaded taxels record the head in the upper half of the
    mat and the sacrum in the lower."""
    import dataclasses

    from pressurepose.data.schema import GenerationConfig
    from pressurepose.data.store import write_dataset
    from pressurepose.data.synthetic import synthetic_producer

    config = GenerationConfig("general", "f", count=n, producer="synthetic", mat=mat, seed=3, shard_size=n)
    rng = np.random.default_rng(3)
    samples = []
    while len(samples) < n:
        s = synthetic_producer(config, rng)
        if not hasattr(s, "pressure"):
            continue  # rejected
        rows = np.arange(s.pressure.shape[0])[:, None]
        sites = np.where(s.force > 0, np.where(rows < len(rows) // 2, SITES.index("head"), SITES.index("sacrum")),
                         NO_SITE)
        samples.append(dataclasses.replace(s, sites=sites.astype(np.int8), index=len(samples)))
    write_dataset(out, config, samples)
    return out, np.stack([s.pressure for s in samples])


def test_train_sites_verb_trains_reports_and_its_network_reads_in_infer(tmp_path, capsys, monkeypatch):
    from pressurepose.cli import main
    from pressurepose.mat import get_mat

    model = _toy_model(tmp_path, get_mat("tip"))
    data, pressure = _sited_dataset(tmp_path / "ds", "tip", 20)
    args = ["train-sites", "--data", str(data), "--model", str(model), "--out", str(tmp_path / "sites"),
            "--epochs", "2", "--no-progress"]
    assert main(args) == 0
    said = capsys.readouterr().out
    assert "on 18 samples, holding out 2" in said and "held-out images" in said and "estimated body alone" in said
    net = load_site_net(tmp_path / "sites" / "sitenet.json")
    assert net.config.grid.same_grid(get_mat("tip"))
    assert net.meta["model"] == str(model) and net.meta["data"] == str(data) and net.meta["held_out"] == 2
    monkeypatch.setattr(sitenet_train, "most_loaded_right", lambda held, site_net: 0.5 if site_net else 0.9)
    assert main(args) == 0  # a rerun finds its last epoch done and writes the same network again
    torch.testing.assert_close(load_site_net(tmp_path / "sites" / "sitenet.json").head.weight, net.head.weight)
    said = capsys.readouterr()
    assert "50.0 % with it, 90.0 % from the estimated body alone\n" in said.out  # none ships for this mat
    assert "names the most loaded site less often than the estimated body alone" in said.err
    np.save(tmp_path / "p.npy", pressure[:2])
    for choice, read_by in ((str(tmp_path / "sites" / "sitenet.json"), "site network"), ("none", "estimated body"),
                            ("auto", "estimated body")):  # no site network ships for this mat
        out = tmp_path / f"infer-{read_by[:4]}-{choice[-4:]}"
        assert main(["infer", str(tmp_path / "p.npy"), "--gender", "f", "--model", str(model), "--out", str(out),
                     "--site-net", choice, "--max-figures", "0", "--no-progress"]) == 0
        assert json.loads((out / "sites.json").read_text())["sites_read_by"] == read_by
    from pressurepose.net import sitenet

    capsys.readouterr()
    monkeypatch.setattr(sitenet, "shipped_site_net", lambda: _says_head_everywhere(get_mat("tip")))
    assert main(args) == 0  # where a site network ships for the mat, the report scores it too
    assert "90.0 % from the estimated body alone, 50.0 % with the shipped site network" in capsys.readouterr().out


def test_train_sites_refuses_data_on_another_mat_or_without_sites(tmp_path, capsys):
    import dataclasses

    from pressurepose.cli import main
    from pressurepose.data.schema import GenerationConfig
    from pressurepose.data.store import write_dataset
    from pressurepose.data.synthetic import synthetic_producer
    from pressurepose.mat import get_mat

    model = _toy_model(tmp_path, get_mat("tip"))
    data, _ = _sited_dataset(tmp_path / "ds", "boditrak_bt3510", 3)
    assert main(["train-sites", "--data", str(data), "--model", str(model), "--out", str(tmp_path / "o"),
                 "--no-progress"]) == 2
    assert "are on a 64 x 27 mat; the model reads 56 x 40" in capsys.readouterr().err
    config = GenerationConfig("general", "f", count=2, producer="synthetic", mat="tip", seed=1)
    made = (synthetic_producer(config, np.random.default_rng(k)) for k in range(20))
    plain = [s for s in made if hasattr(s, "pressure")][:2]  # the rest were rejected
    write_dataset(tmp_path / "plain", config, [dataclasses.replace(s, index=i) for i, s in enumerate(plain)])
    assert main(["train-sites", "--data", str(tmp_path / "plain"), "--model", str(model), "--out", str(tmp_path / "o"),
                 "--no-progress"]) == 2
    assert "2 of 2 samples under" in capsys.readouterr().err
