"""Bed and mat specs: presets, grids and frames, validation, records."""

import math

import numpy as np
import pytest

from pressurepose.errors import BadInput
from pressurepose.mat import MATS, custom_mat, get_mat
from pressurepose.sim.bed import INCH, BedSpec, get_bed


def test_presets_match_the_published_grids():
    bt = get_mat("boditrak_bt3510")
    assert bt.shape == (64, 27) and bt.pitch_row_m == bt.pitch_col_m == 0.0286 and bt.max_mmhg == 100
    assert get_mat("SLP").shape == (192, 84)
    tip = get_mat("tip")
    assert tip.shape == (56, 40) and (tip.pitch_row_m, tip.pitch_col_m) == (0.0311, 0.0195)
    assert get_bed().mat == bt  # the default
    assert set(MATS) == {"boditrak_bt3510", "fsa_softflex_2048", "slp", "tip"}


def test_unknown_preset_lists_the_valid_names():
    with pytest.raises(BadInput, match="boditrak_bt3510, fsa_softflex_2048, slp, tip"):
        get_mat("xsensor")
    with pytest.raises(BadInput, match="slp"):
        get_bed("nope")


@pytest.mark.parametrize("name", sorted(MATS))
def test_full_grid_covers_the_mattress_with_whole_taxels(name):
    bed = get_bed(name)
    full, m = bed.full_grid, bed.mat
    x0, x1, y0, y1 = bed.mattress_bounds
    gx0, gy0 = full.origin_xy
    # within half a taxel of every mattress edge, sensing area inside it
    assert abs(gx0 - x0) <= m.pitch_col_m / 2 + 1e-12 and abs(gy0 - y0) <= m.pitch_row_m / 2 + 1e-12
    assert abs(gx0 + full.cols * m.pitch_col_m - x1) <= m.pitch_col_m / 2 + 1e-12
    assert abs(gy0 + full.rows * m.pitch_row_m - y1) <= m.pitch_row_m / 2 + 1e-12
    assert full.rows >= m.rows and full.cols >= m.cols
    sl = full.sensing_slice
    assert np.zeros((full.rows, full.cols))[sl].shape == m.shape


def test_boditrak_on_twin_xl_is_the_72_by_35_grid_measured_here():
    bed = get_bed()
    assert (bed.mattress_width_m, bed.mattress_length_m) == pytest.approx((39 * INCH, 80 * INCH))
    assert (bed.full_grid.rows, bed.full_grid.cols) == (72, 35)
    # centred sensing area
    ox, oy = bed.mat_offset_m
    assert ox == pytest.approx((39 * INCH - 27 * 0.0286) / 2) and oy == pytest.approx((80 * INCH - 64 * 0.0286) / 2)


def test_taxel_centres_and_xy_to_taxel_agree():
    for name in MATS:
        bed = get_bed(name)
        c = bed.taxel_centers()
        assert c.shape == bed.mat.shape + (2,)
        row, col = bed.xy_to_taxel(c)
        np.testing.assert_array_equal(row, np.arange(bed.mat.rows)[:, None] * np.ones(bed.mat.cols, int))
        np.testing.assert_array_equal(col, np.arange(bed.mat.cols)[None, :] * np.ones((bed.mat.rows, 1), int))
    bed = get_bed()
    assert bed.xy_to_taxel([0.0001, 0.0001]) == (0, 0)  # the origin is the sensing area's head-left corner
    r, c = bed.xy_to_taxel([[-0.01, 0.5], [0.5, 1.9]])
    assert c[0] < 0 and r[1] >= bed.mat.rows  # outside the sensing area -> outside the index range
    with pytest.raises(BadInput, match="xy"):
        bed.xy_to_taxel([1.0, 2.0, 3.0])


@pytest.mark.parametrize("kwargs, match", [
    (dict(stiffness_n_m3=-1.0), "stiffness"),
    (dict(stiffness_n_m3=float("nan")), "stiffness"),
    (dict(coupling_n_m=-5.0), "coupling"),
    (dict(friction=-0.1), "friction"),
    (dict(mattress_width_m=0.5), "larger than the mattress"),
    (dict(mattress_length_m=1.5), "larger than the mattress"),
    (dict(mat_offset_m=(0.3, 0.0)), "off the"),
    (dict(mat_offset_m=(0.1,)), "two finite"),
    (dict(press_cell_m=0.0), "press_cell_m"),
    (dict(press_cell_m=1e-7), "press_cell_m"),
    (dict(mattress_length_m=1e6), "mattress_length_m"),
    (dict(sensor_c1=float("inf")), "sensor_c1"),
])
def test_nonsense_beds_are_refused(kwargs, match):
    with pytest.raises(BadInput, match=match):
        get_bed(**kwargs)


@pytest.mark.parametrize("args, match", [
    ((0, 27, 0.0286), "rows"),
    ((64, 27, 0.0), "pitch_row_m"),
    ((64, 27, -0.01), "pitch_row_m"),
    ((64, 27, 28.6), "metres"),
    ((64, 27, 1e-300), "pitch_row_m"),
    ((10**6, 27, 0.0286), "taxels"),
    ((64.5, 27, 0.0286), "rows"),
])
def test_nonsense_mats_are_refused(args, match):
    with pytest.raises(BadInput, match=match):
        custom_mat(*args)


def test_custom_mat_on_a_bed():
    mat = custom_mat(40, 20, 0.03, 0.02, max_mmhg=200)
    bed = BedSpec(mat=mat)
    assert bed.mat.width_m == pytest.approx(0.4) and bed.mat.length_m == pytest.approx(1.2)
    assert bed.full_grid.cols == 20 + 2 * round((39 * INCH - 0.4) / 2 / 0.02)


def test_cell_springs_are_the_discrete_pasternak_foundation():
    bed = get_bed("tip", stiffness_n_m3=5e4, coupling_n_m=80.0, damping_s=0.2)
    s = bed.cell_springs()
    dx, dy = 0.0195, 0.0311
    assert s["vertical"] == pytest.approx(5e4 * dx * dy)
    assert s["damping"] == pytest.approx(0.2 * 5e4 * dx * dy)
    assert s["coupling_x"] == pytest.approx(80.0 * dy / dx) and s["coupling_y"] == pytest.approx(80.0 * dx / dy)
    assert bed.spread_length_m == pytest.approx(math.sqrt(80.0 / 5e4))


def test_record_round_trip_and_bad_records():
    bed = get_bed("tip", stiffness_n_m3=1.2e5, sensor_c2=0.003, mat_offset_m=(0.05, 0.1))
    again = BedSpec.from_dict(bed.to_dict())
    assert again == bed
    d = bed.to_dict()
    d["spring"] = 3
    with pytest.raises(BadInput, match="unknown fields"):
        BedSpec.from_dict(d)
    with pytest.raises(BadInput):
        BedSpec.from_dict({"mat": {"name": "x"}})
    with pytest.raises(BadInput):
        BedSpec.from_dict([1, 2])


def test_bone_fractions_by_part():
    """A dict names some parts (the rest keep their defaults); records keep them by name; a record
    without them is refused, as a record without any other field."""
    from pressurepose.sim.bed import BONE_PARTS, TISSUE_BONE_FRACTION

    bed = get_bed(tissue_bone_fraction={"pelvis": 0.8, "calf": 0.2})
    f = dict(zip(BONE_PARTS, bed.tissue_bone_fraction))
    assert f["pelvis"] == 0.8 and f["calf"] == 0.2 and f["head"] == TISSUE_BONE_FRACTION[BONE_PARTS.index("head")]
    d = bed.to_dict()
    assert d["tissue_bone_fraction"]["pelvis"] == 0.8
    assert BedSpec.from_dict(d) == bed
    del d["tissue_bone_fraction"]
    with pytest.raises(BadInput, match="bed record lacks tissue_bone_fraction"):
        BedSpec.from_dict(d)
    for bad, match in [({"femur": 0.5}, "unknown parts"), ({"pelvis": 0.0}, r"\(0, 1\]"), ((0.5,) * 3, "11"),
                       ({"pelvis": float("nan")}, "pelvis"), (5, "expected 11")]:
        with pytest.raises(BadInput, match=match):
            get_bed(tissue_bone_fraction=bad)


def test_a_bed_file_and_the_mat(tmp_path):
    import json

    from pressurepose.sim.bed import bed_for, load_bed

    bed = get_bed("tip", stiffness_n_m3=2e5)
    (tmp_path / "fit.json").write_text(json.dumps({"bed": bed.to_dict(), "loss": 0.1}))
    (tmp_path / "bare.json").write_text(json.dumps(bed.to_dict()))
    (tmp_path / "other.json").write_text(json.dumps({"loss": 1}))
    assert load_bed(tmp_path / "fit.json") == bed == load_bed(tmp_path / "bare.json")
    assert bed_for("tip", tmp_path / "fit.json") == bed == bed_for(None, tmp_path / "fit.json")
    assert bed_for(None, None) == get_bed() and bed_for("slp", None) == get_bed("slp")
    with pytest.raises(BadInput, match="carries the tip mat"):
        bed_for("boditrak_bt3510", tmp_path / "fit.json")
    with pytest.raises(BadInput, match="no bed record"):
        load_bed(tmp_path / "other.json")
    with pytest.raises(BadInput, match="does not exist"):
        load_bed(tmp_path / "none.json")
