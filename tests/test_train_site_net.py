"""tools/train_site_net.py: the data it generates and what it installs."""

import pytest
import torch

from pressurepose.errors import BadInput
from pressurepose.mat import custom_mat
from pressurepose.net.sitenet import SiteNet, SiteNetConfig, load_site_net, save_site_net
from tests.toolscript import load_tool


def _tool():
    return load_tool("train_site_net")


def test_data_covers_every_partition_that_draws_no_real_pose_on_both_genders(monkeypatch, tmp_path):
    from pressurepose.data.schema import PARTITIONS

    tool, calls = _tool(), []
    monkeypatch.setattr(tool, "cli", lambda *args: calls.append(args))
    tool.make_data(tmp_path, count=3)
    assert set(tool.PARTITIONS) == {p for p in PARTITIONS if not p.startswith("natural_")}
    made = {(c[c.index("--partition") + 1], c[c.index("--gender") + 1]) for c in calls}
    assert made == {(p, g) for p in tool.PARTITIONS for g in "fm"}
    assert all(c[c.index("--seed") + 1] == str(tool.SEED) and c[c.index("--count") + 1] == "3" for c in calls)
    assert len({c[c.index("--out") + 1] for c in calls}) == len(calls)


def test_install_copies_a_whole_site_network_and_refuses_anything_else(tmp_path):
    tool = _tool()
    trained = save_site_net(tmp_path / "run" / "sitenet.json", SiteNet(SiteNetConfig(custom_mat(8, 4, 0.05), width=4)))
    assets = tmp_path / "assets"
    assets.mkdir()
    assert sorted(p.name for p in tool.install(trained, assets)) == ["sitenet.json", "sitenet.safetensors"]
    net = load_site_net(assets / "sitenet.json")
    torch.testing.assert_close(net.head.weight, load_site_net(trained).head.weight)
    (tmp_path / "bad.json").write_text("{}")
    with pytest.raises(BadInput, match="not a site network"):
        tool.install(tmp_path / "bad.json", assets)
