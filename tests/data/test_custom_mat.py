"""Datasets on a mat that is no preset: its grid travels in the dataset's bed record, and every
reader (generate's resume, info, load_dataset, pack, train, infer) takes it from there."""

import json

import numpy as np
import pytest

from pressurepose.cli import main
from pressurepose.data.readers.labelled import mat_of_record
from pressurepose.data.schema import GenerationConfig
from pressurepose.errors import BadInput
from pressurepose.mat import custom_mat, get_mat
from pressurepose.sim.bed import BedSpec

MAT = custom_mat(48, 24, 0.04, 0.035, name="ward_mat")


def _config(**kw):
    base = dict(partition="general_supine", gender="f", count=4, seed=1, producer="synthetic", shard_size=2,
                mat="ward_mat", bed=BedSpec(mat=MAT).to_dict())
    base.update(kw)
    return GenerationConfig(**base)


def test_a_config_on_a_mat_of_any_grid_carries_it_in_its_bed_and_round_trips():
    c = _config()
    assert c.mat == "ward_mat" and c.grid == MAT
    again = GenerationConfig.from_dict(json.loads(c.to_json()))
    assert again.grid == MAT and again.digest == c.digest
    assert GenerationConfig("general", "f", count=1).grid == get_mat("boditrak_bt3510")  # presets as before


def test_a_mat_that_is_no_preset_needs_its_bed_and_its_name():
    with pytest.raises(BadInput, match="mat preset 'ward_mat' is not known"):
        GenerationConfig("general", "f", count=1, mat="ward_mat")  # no bed carries its grid
    with pytest.raises(BadInput, match="'other' is neither a preset .* nor the name of the bed's mat \\('ward_mat'\\)"):
        _config(mat="other")
    with pytest.raises(BadInput, match="is not the preset 'boditrak_bt3510'"):
        _config(mat="boditrak_bt3510")
    fake = custom_mat(48, 24, 0.04, name="tip")  # a preset's name on another grid
    with pytest.raises(BadInput, match="named 'tip' but is not that preset"):
        _config(mat="other", bed=BedSpec(mat=fake).to_dict())


def test_mat_json_names_a_grid_its_range_and_its_name(tmp_path):
    m = mat_of_record({"rows": 48, "cols": 24, "pitch_m": 0.04, "pitch_col_m": 0.035, "max_mmhg": 200,
                       "name": "ward_mat"}, "mat.json")
    assert m == custom_mat(48, 24, 0.04, 0.035, 200.0, name="ward_mat")
    assert mat_of_record({"rows": 48, "cols": 24, "pitch_m": 0.04}, "mat.json").name == "custom"
    with pytest.raises(BadInput, match="mat.json: unknown mat: name is 3"):
        mat_of_record({"rows": 48, "cols": 24, "pitch_m": 0.04, "name": 3}, "mat.json")


def test_generate_on_a_mat_json_then_info_load_pack_and_a_rerun(tmp_path, capsys):
    from pressurepose.net.data import load_dataset

    (tmp_path / "mat.json").write_text(json.dumps({"rows": 48, "cols": 24, "pitch_m": 0.04, "pitch_col_m": 0.035,
                                                   "name": "ward_mat"}))
    args = ["generate", "--mat", str(tmp_path / "mat.json"), "--partition", "general_supine", "--gender", "f",
            "--count", "4", "--producer", "synthetic", "--workers", "1", "--out", str(tmp_path / "d"), "--no-progress"]
    assert main(args) == 0
    assert main(args) == 0  # a rerun finds the dataset done
    assert "made 0 shard(s), kept 1" in capsys.readouterr().out
    data = load_dataset(tmp_path / "d")
    assert data.grid == MAT and data.mat == "ward_mat" and tuple(data.tensors["pressure"].shape) == (4, 48, 24)
    assert main(["info", str(tmp_path / "d")]) == 0
    assert "mat ward_mat (48 x 24)" in capsys.readouterr().out
    assert main(["pack", str(tmp_path / "d"), "--out", str(tmp_path / "d.npz")]) == 0
    packed = load_dataset(tmp_path / "d.npz")
    assert packed.grid.same_grid(MAT) and packed.mat == "ward_mat"
    # a bed of another grid with the same --mat is refused, naming both
    (tmp_path / "bed.json").write_text(json.dumps(BedSpec(mat=get_mat("tip")).to_dict()))
    assert main([*args[:-3], "--bed", str(tmp_path / "bed.json"), "--out", str(tmp_path / "e")]) == 2
    assert "(48 x 24) but the bed in" in capsys.readouterr().err


def test_datasets_of_two_grids_of_one_name_do_not_mix(tmp_path):
    from pressurepose.data.dataset import DatasetReader
    from pressurepose.data.generate import generate

    generate(_config(), tmp_path / "all" / "a", workers=1, progress=False)
    other = custom_mat(40, 24, 0.04, 0.035, name="ward_mat")
    generate(_config(bed=BedSpec(mat=other).to_dict()), tmp_path / "all" / "b", workers=1, progress=False)
    with pytest.raises(BadInput, match="another grid"):
        DatasetReader(tmp_path / "all").load_arrays(("pressure",))


def test_physics_settles_and_presses_a_body_on_a_mat_of_any_grid(tmp_path):
    """One simulated body on a 48 x 24 mat of 4 x 3.5 cm taxels: an image of that grid that carries
    the body's weight over the sensing area."""
    from pressurepose.data.dataset import DatasetReader
    from pressurepose.data.generate import generate

    c = _config(producer="physics", count=1, shard_size=1)
    generate(c, tmp_path / "d", workers=1, progress=False)
    (s,) = list(DatasetReader(tmp_path / "d"))
    assert s.pressure.shape == (48, 24) and s.sites.shape == (48, 24)
    load_n = float((s.pressure * 133.322).sum() * MAT.taxel_area_m2)
    assert 0.5 * s.mass * 9.81 < load_n < 1.05 * s.mass * 9.81  # most of the body on the mat, never more


def test_a_model_trained_on_a_mat_of_any_grid_reads_images_of_that_grid(tmp_path, capsys):
    from pressurepose.data.generate import generate
    from pressurepose.net.infer import estimate

    generate(_config(count=4), tmp_path / "d", workers=1, progress=False)
    assert main(["train", "--data", str(tmp_path / "d"), "--out", str(tmp_path / "m"), "--epochs-mod1", "1",
                 "--epochs-mod2", "1", "--batch-size", "2", "--cnn", "half", "--val-fraction", "0",
                 "--no-progress"]) == 0
    est = estimate(np.full((1, 48, 24), 20.0, np.float32), "f", model=tmp_path / "m")
    assert est.grid == MAT and est.sites_read_by == "estimated body"  # no site network ships for this grid
    capsys.readouterr()
    assert main(["infer", str(tmp_path / "d" / "shard-00000.h5"), "--model", str(tmp_path / "m"), "--out",
                 str(tmp_path / "est"), "--max-figures", "0", "--no-progress"]) == 0
    assert "2 estimate(s) written" in capsys.readouterr().out


def test_a_bed_calibrated_on_a_mat_json_makes_data_on_that_mat(tmp_path, capsys):
    """calibrate --mat mat.json writes a bed that carries the mat's grid; generate --bed takes it."""
    from pressurepose.net.data import load_dataset

    (tmp_path / "mat.json").write_text(json.dumps({"rows": 48, "cols": 24, "pitch_m": 0.04, "pitch_col_m": 0.035,
                                                   "name": "ward_mat"}))
    assert main(["calibrate", "--targets", "default", "--mat", str(tmp_path / "mat.json"), "--max-evals", "6",
                 "--popsize", "6", "--out", str(tmp_path / "bed.json")]) == 0
    assert BedSpec.from_dict(json.loads((tmp_path / "bed.json").read_text())["bed"]).mat == MAT
    assert main(["generate", "--bed", str(tmp_path / "bed.json"), "--partition", "general", "--gender", "m",
                 "--count", "2", "--producer", "synthetic", "--workers", "1", "--out", str(tmp_path / "d"),
                 "--no-progress"]) == 0
    assert load_dataset(tmp_path / "d").grid == MAT
