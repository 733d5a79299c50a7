"""The paper's ablations (Table 2: no PMR, no noise, no edges and contact) train and evaluate
through the verbs, and the report keeps its partition and gender rows."""

import json

import pytest
import torch

from pressurepose.cli import main
from pressurepose.net.checkpoint import load_model
from tests.net.synth import write_toy_dataset

torch.set_num_threads(1)


@pytest.fixture(scope="module")
def data_dir(tmp_path_factory):
    root = tmp_path_factory.mktemp("ablations")
    write_toy_dataset(root / "data", n=4)
    return root / "data"


@pytest.mark.parametrize("flag", ["--no-pmr", "--no-noise", "--no-edges-contact"])
def test_ablation_trains_and_evaluates_by_partition_and_gender(tmp_path, data_dir, flag):
    run = tmp_path / "run"
    assert main(["train", "--data", str(data_dir), "--out", str(run), "--epochs-mod1", "1", "--epochs-mod2", "1",
                 "--batch-size", "4", "--female", "toy", "--male", "toy", "--cnn", "half", flag]) == 0
    net, meta = load_model(run)
    channels = {"--no-pmr": (3, 3), "--no-noise": (3, 5), "--no-edges-contact": (1, 3)}[flag]
    assert (net.mod1.cnn.convs[0].in_channels, net.mod2.cnn.convs[0].in_channels) == channels
    assert meta["train"]["noise"] is (flag != "--no-noise") and meta["train"]["use_pmr"] is (flag != "--no-pmr")
    assert main(["evaluate", "--model", str(run), "--data", str(data_dir), "--out", str(tmp_path / "rep")]) == 0
    summary = json.loads((tmp_path / "rep" / "report.json").read_text())["summary"]
    assert summary["all"]["count"] == 4
    for group in ("partition:general_supine", "partition:supine_straight_limbs", "gender:f", "gender:m"):
        assert summary[group]["count"] == 2 and summary[group]["mod2"]["mpjpe_cm"] > 0
