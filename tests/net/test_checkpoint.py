import dataclasses
import json
import os
import pickle

import pytest
import torch

from pressurepose.body.model import BodyModel
from pressurepose.body.toy import toy_body_arrays
from pressurepose.errors import BadInput
from pressurepose.mat import custom_mat
from pressurepose.net.checkpoint import gendered_body, load_model, save_model
from pressurepose.net.model import NetConfig, PressureNet
from pressurepose.net.outputs import OutputConfig
from tests.net.synth import toy_dataset

torch.set_num_threads(1)
GRID = custom_mat(rows=16, cols=16, pitch_row_m=0.125, pitch_col_m=0.0625)


def _net():
    torch.manual_seed(0)
    body = BodyModel(toy_body_arrays())
    cfg = NetConfig(grid=GRID, outputs=OutputConfig.default((0.5, 1.0, 0.2), (0.3, 0.3, 0.1)))
    net = PressureNet(cfg, gendered_body(body, body)).eval()
    torch.nn.init.normal_(net.mod2.cnn.fc.weight, std=1e-3)  # not the zero init, to see it restored
    return net, body


@pytest.mark.parametrize("suffix", [".safetensors", ".pt"])
def test_round_trip(tmp_path, suffix):
    net, body = _net()
    path = save_model(tmp_path / f"m{suffix}", net, (body, body), {"note": "x"})
    loaded, meta = load_model(path)
    assert meta["note"] == "x" and meta["bodies"]["female"]["spec"] == "toy"
    assert loaded.config == net.config
    data = toy_dataset(3, grid=GRID)
    with torch.no_grad():
        a = net(data["pressure"], data["gender"])[1]
        b = loaded(data["pressure"], data["gender"])[1]
    assert torch.equal(a.vertices, b.vertices) and torch.equal(a.maps.q, b.maps.q)
    if suffix == ".safetensors":
        assert json.loads((tmp_path / "m.json").read_text())["format"].startswith("pressurepose")
        save_model(tmp_path / "run" / "model.safetensors", net, (body, body))
        assert load_model(tmp_path / "run")[0].config == net.config  # a training folder loads too


def test_split_float16_round_trip(tmp_path):
    net, body = _net()
    path = save_model(tmp_path / "m.json", net, (body, body), {"note": "x"}, split_modules=True, dtype=torch.float16)
    files = sorted(p.name for p in tmp_path.iterdir())
    assert files == ["m.json", "m.mod1.safetensors", "m.mod2.safetensors"]
    sizes = [(tmp_path / f).stat().st_size for f in files[1:]]
    assert max(sizes) < 0.6 * sum(sizes)  # the weights really are divided between the files
    loaded, meta = load_model(path)
    assert meta["note"] == "x" and meta["weight_files"] == files[1:]
    assert all(p.dtype == torch.float32 for p in loaded.parameters())
    for (k, a), b in zip(net.state_dict().items(), loaded.state_dict().values()):
        assert torch.equal(a.half().float(), b), k  # exactly the float16 rounding, nothing else
    assert load_model(tmp_path / "m.safetensors")[0].config == net.config  # the usual name finds it too
    # re-saving a split model's metadata as one file does not keep the old file list
    one = save_model(tmp_path / "one" / "m.safetensors", net, (body, body), meta)
    assert "weight_files" not in json.loads(one.with_suffix(".json").read_text())
    assert load_model(one)[1]["note"] == "x"
    (tmp_path / "m.mod2.safetensors").unlink()
    with pytest.raises(BadInput, match="m.mod2.safetensors.*do not exist"):
        load_model(path)


class _Exploit:
    def __reduce__(self):
        return (os.system, (f"touch {self.marker}",))


def test_crafted_pickle_checkpoint_cannot_run_code(tmp_path):
    marker = tmp_path / "pwned"
    _Exploit.marker = str(marker)
    bad = tmp_path / "evil.pt"
    with open(bad, "wb") as f:
        pickle.dump({"meta": "{}", "state_dict": {"w": _Exploit()}}, f, protocol=2)
    with pytest.raises(BadInput, match="safely"):
        load_model(bad)
    assert not marker.exists()
    # a zip-format torch file carrying the object is refused the same way
    bad2 = tmp_path / "evil2.pt"
    torch.save({"meta": "{}", "state_dict": {"w": _Exploit()}}, bad2)
    with pytest.raises(BadInput, match="safely") as refused:
        load_model(bad2)
    assert not marker.exists()
    assert f"{os.system.__module__}.system" in str(refused.value)  # the blocked global, named in full


def test_bad_model_files(tmp_path):
    net, body = _net()
    with pytest.raises(BadInput, match="does not exist"):
        load_model(tmp_path / "nothing.safetensors")
    path = save_model(tmp_path / "m.safetensors", net, (body, body))
    # another body model than the one trained with
    other = BodyModel(dataclasses.replace(toy_body_arrays(), v_template=toy_body_arrays().v_template * 1.1))
    with pytest.raises(BadInput, match="not the one this model was trained with"):
        load_model(path, bodies=(other, other))
    # truncated weights
    blob = path.read_bytes()
    (tmp_path / "t.safetensors").write_bytes(blob[: len(blob) // 2])
    (tmp_path / "t.json").write_text((tmp_path / "m.json").read_text())
    with pytest.raises(BadInput, match="safetensors"):
        load_model(tmp_path / "t.safetensors")
    # metadata of another kind of file
    (tmp_path / "m.json").write_text(json.dumps({"format": "something else"}))
    with pytest.raises(BadInput, match="not a"):
        load_model(path)
    (tmp_path / "m.json").write_text("{not json")
    with pytest.raises(BadInput, match="JSON"):
        load_model(path)
    (tmp_path / "x.npy").write_bytes(b"")
    with pytest.raises(BadInput, match="expected"):
        load_model(tmp_path / "x.npy")


def test_one_modules_weights_point_to_the_models_json():
    from pathlib import Path

    from pressurepose.net.checkpoint import read_model_files
    from pressurepose.net.infer import DEFAULT_MODEL

    shipped = Path(DEFAULT_MODEL)
    with pytest.raises(BadInput, match=f"pass .*{shipped.name}"):
        read_model_files(shipped.with_name(shipped.stem + ".mod1.safetensors"))


def _set(*keys, value):
    def edit(config):
        for k in keys[:-1]:
            config = config[k]
        config[keys[-1]] = value
    return edit


# (case, an edit of the saved config, what the refusal must name); each names the model file too
BAD_CONFIG = [
    ("dropout-above-one", _set("dropout", value=2.0), "config: dropout is 2.0; expected a probability"),
    ("negative-channels", _set("cnn_channels", value=[-4, 4, 4, 4]), r"cnn_channels\[0\] is -4"),
    ("huge-channels", _set("cnn_channels", value=[10 ** 5, 4, 4, 4]), r"cnn_channels\[0\] is 100000"),
    ("upsample-zero", _set("inputs", "upsample", value=0), "inputs.upsample is 0"),
    ("upsample-huge", _set("inputs", "upsample", value=100), "inputs.upsample is 100"),
    ("upsample-float", _set("inputs", "upsample", value=2.5), "inputs.upsample is 2.5"),
    ("blur-huge", _set("inputs", "blur_sigma", value=1e6), "inputs.blur_sigma is 1000000.0"),
    ("gain-text", _set("outputs", "gain", value="x"), "outputs.gain is 'x'"),
    ("gain-zero", _set("outputs", "gain", value=0), "outputs.gain is 0"),
    ("transl-offset-nan", _set("outputs", "transl_offset", value=[float("nan")] * 3),
     r"outputs.transl_offset\[0\] is nan"),
    ("transl-scale-two", _set("outputs", "transl_scale", value=[1.0, 1.0]), "outputs.transl_scale is .*expected 3"),
    ("angle-limits-crossed", _set("outputs", "angle_lower", value=[1.0] * 69), r"outputs.angle_lower\[0\] = 1.0 is not"),
    ("grid-rows-million", _set("grid", "rows", value=10 ** 6), "grid: mat of 1000000 x 16 taxels"),
    ("grid-rows-huge-input", _set("grid", "rows", value=30000), "linear layer of 5.07e\\+08 weights"),
    ("grid-too-small", _set("grid", "rows", value=4), "the CNN needs at least 31 x 31"),
    ("use-pmr-number", _set("use_pmr", value=1), "use_pmr is 1; expected true or false"),
    ("pmr-passes-negative", _set("pmr", "fill_passes", value=-1), "pmr.fill_passes is -1"),
    ("no-cnn-channels", lambda config: config.pop("cnn_channels"), "lacks 'cnn_channels'"),
    ("no-inputs", lambda config: config.pop("inputs"), "lacks 'inputs'"),
    ("unknown-field", _set("inputs", "colour", value=1), "inputs: .*unexpected keyword argument 'colour'"),
    # valid on its own but not the stored weights' network: refused before a larger one is built
    ("grid-other-size", _set("grid", "rows", value=100),
     r"makes mod1.cnn.fc.weight of shape \(88, 16512\) but the stored weights are \(88, 384\)"),
    ("wider-channels", _set("cnn_channels", value=[4096] * 4), r"mod1.cnn.features.0.weight of shape \(4096, 3, 7, 7\)"),
]


@pytest.mark.parametrize("case,edit,message", BAD_CONFIG, ids=[c[0] for c in BAD_CONFIG])
def test_model_config_values_are_checked_by_name(tmp_path, case, edit, message):
    net, body = _net()
    path = save_model(tmp_path / "m.safetensors", net, (body, body))
    record = json.loads((tmp_path / "m.json").read_text())
    edit(record["config"])
    (tmp_path / "m.json").write_text(json.dumps(record))
    with pytest.raises(BadInput, match=rf"model file '.*m.json': .*{message}"):
        load_model(tmp_path / "m.json")
    assert path.exists()


def test_the_shipped_model_passes_the_config_checks():
    from pressurepose.net.checkpoint import read_model_files
    from pressurepose.net.infer import DEFAULT_MODEL

    config = NetConfig.from_dict(read_model_files(DEFAULT_MODEL)[0]["config"])
    assert config.inputs.upsample == 2 and config.grid.shape == (64, 27) and len(config.outputs.angle_lower) == 69
    assert NetConfig.from_dict(json.loads(json.dumps(config.to_dict()))) == config


def test_the_shipped_models_training_record_names_only_settings_training_knows():
    """The shipped model's ``train`` record is the TrainConfig it was trained with: every field it names
    is one TrainConfig (and its NoiseConfig) has, and the record builds that config back unchanged."""
    from pressurepose.net.checkpoint import read_model_files
    from pressurepose.net.infer import DEFAULT_MODEL
    from pressurepose.net.train_config import NoiseConfig, TrainConfig

    record = read_model_files(DEFAULT_MODEL)[0]["train"]
    known = {f.name for f in dataclasses.fields(TrainConfig)}
    assert set(record) <= known, sorted(set(record) - known)
    noise = record["noise_config"]
    assert set(noise) <= {f.name for f in dataclasses.fields(NoiseConfig)}, sorted(noise)
    config = TrainConfig(**{**record, "noise_config": NoiseConfig(**noise)})
    assert {k: v for k, v in json.loads(json.dumps(config.to_dict())).items() if k in record} == record


def test_a_model_path_bodies_or_device_of_the_wrong_kind_is_refused_by_name(tmp_path):
    """load_model(None) or (3) was a TypeError from pathlib, bodies=('x', 'y') an AttributeError, and a
    device torch does not know (or CUDA on a machine without it) torch's RuntimeError or AssertionError."""
    net, body = _net()
    path = save_model(tmp_path / "m.safetensors", net, (body, body))
    for bad in (None, 3, ["m.json"]):
        with pytest.raises(BadInput, match=r"^model file is .*; expected a path"):
            load_model(bad)
    for bodies in (("x", "y"), (body,), body):
        with pytest.raises(BadInput, match=r"^bodies is .*; expected \(female, male\) BodyModels"):
            load_model(path, bodies=bodies)
    with pytest.raises(BadInput, match="device 'tpu' is not a torch device"):
        load_model(path, device="tpu")
    if not torch.cuda.is_available():
        with pytest.raises(BadInput, match="CUDA is not available"):
            load_model(path, device="cuda")
    assert next(load_model(path, device="cpu")[0].parameters()).device.type == "cpu"


def test_loading_the_shipped_model_leaves_pytorchs_compiler_unimported():
    """Loading checks the stored shapes on the meta device; no step of it (nor one estimate) may pull
    in torch._dynamo, over a second of every command's start-up."""
    import subprocess
    import sys

    code = ("import sys, numpy as np\n"
            "from pressurepose.net.infer import estimate, resolve_model\n"
            "estimate(np.full((1, 64, 27), 10, np.float32), 'f', model=resolve_model(None))\n"
            "print('torch._dynamo' in sys.modules)\n")
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True)
    assert out.stdout.strip() == "False"


def test_a_model_file_that_names_no_contact_floor_applies_none(tmp_path):
    """A model's floor is its own (its config's inputs.contact_floor_mmhg), whatever TrainConfig's
    default: one whose config does not name it loads with 0, the paper's, and reads as saved."""
    net, body = _net()
    path = save_model(tmp_path / "m.safetensors", net, (body, body))
    record = json.loads((tmp_path / "m.json").read_text())
    del record["config"]["inputs"]["contact_floor_mmhg"]
    (tmp_path / "m.json").write_text(json.dumps(record))
    loaded, _ = load_model(path)
    assert loaded.config.inputs.contact_floor_mmhg == 0.0 and loaded.config == net.config
