"""Body sites: every model's vertices get the clinician's sites, and the load per site is exact."""

import numpy as np
import pytest

from pressurepose.body import BodyModel
from pressurepose.body.mesh import lower_surface
from pressurepose.body.model import asset_path
from pressurepose.body.sites import (
    NO_SITE,
    OTHER,
    SITES,
    body_loads,
    body_site_map,
    fit_offset,
    lowest_vertices,
    site_index,
    site_label,
    site_loads,
    site_stats,
    taxel_sites,
    vertex_pressure,
    vertex_sites,
)
from pressurepose.body.toy import toy_body_arrays
from pressurepose.errors import BadInput
from pressurepose.mat import custom_mat, get_mat
from pressurepose.pose.root import root_axis_angle, world_rotation

MAT = custom_mat(4, 5, 0.02)  # 4 rows x 5 cols of 2 cm taxels: 4 cm^2 each


def shipped(gender):
    if not asset_path(f"{gender}.npz").is_file():
        pytest.skip(f"shipped body model {gender}.npz not baked yet (tools/bake_body_model.py)")
    return BodyModel(gender)


def centre(r, c, z=0.0, mat=MAT):
    return [(c + 0.5) * mat.pitch_col_m, (r + 0.5) * mat.pitch_row_m, z]


def sheet(rows, cols, z=0.0):
    """A flat triangulated sheet with a vertex at the centre of each taxel (r, c) of rows x cols:
    (vertices (N, 3), faces (F, 3), the (r, c) of each vertex)."""
    from scipy.spatial import Delaunay

    cells = [(r, c) for r in rows for c in cols]
    v = np.array([centre(r, c, z) for r, c in cells])
    return v, Delaunay(v[:, :2]).simplices.astype(np.int64), cells


def meshes(*parts):
    """One mesh of several (vertices, faces, sites) parts."""
    verts, faces, sites, n = [], [], [], 0
    for v, f, site in parts:
        verts.append(v)
        faces.append(f + n)
        sites.append(np.broadcast_to(site, len(v)))
        n += len(v)
    return np.concatenate(verts), np.concatenate(faces), np.concatenate(sites).astype(np.int64)


# --------------------------------------------------------------------------- the exact statistics
def test_synthetic_mesh_gives_exact_site_statistics():
    head, sacrum, heel = site_index("head"), site_index("sacrum"), site_index("left_heel")
    v, f, cells = sheet(range(4), range(5))
    skin = np.array([head if c < 2 else sacrum for _, c in cells])  # the skin on the mat
    top = sheet(range(4), range(5), z=0.15)  # a limb lying on top: never the one on the mat
    verts, faces, sites = meshes((v, f, skin), (top[0], top[1], heel))
    pressure = np.zeros((4, 5))
    pressure[0, 0], pressure[1, 1], pressure[2, 0] = 10.0, 30.0, 20.0   # head: 3 taxels, 60 in all
    pressure[0, 3], pressure[3, 4] = 40.0, 100.0                        # sacrum: 2 taxels, 140
    loads = site_loads(pressure, verts[None], faces, sites, MAT)
    h, s = loads.peak_mmhg[0], loads.share[0]
    assert h[head] == 30.0 and h[sacrum] == 100.0 and h[heel] == 0.0
    assert loads.mean_mmhg[0, head] == pytest.approx(20.0) and loads.mean_mmhg[0, sacrum] == pytest.approx(70.0)
    assert loads.area_cm2[0, head] == pytest.approx(12.0) and loads.area_cm2[0, sacrum] == pytest.approx(8.0)
    assert s[head] == pytest.approx(60 / 200) and s[sacrum] == pytest.approx(140 / 200)
    assert s.sum() == pytest.approx(1.0) and s[heel] == 0.0
    assert loads.most_loaded() == ["sacrum"]
    t = loads.taxel_site[0]
    assert t[0, 0] == head and t[3, 4] == sacrum and t[0, 1] == NO_SITE  # unloaded taxels carry no site
    rec = loads.to_records()[0]
    assert set(rec) == set(SITES) and rec["sacrum"] == {"peak_mmhg": 100.0, "mean_mmhg": 70.0, "area_cm2": 8.0,
                                                        "share": 0.7}


def test_a_loaded_taxel_without_skin_over_it_takes_the_nearest_skin():
    head, sacrum = site_index("head"), site_index("sacrum")
    verts, faces, sites = meshes((*sheet(range(2), range(2))[:2], head), (*sheet(range(2), range(3, 5))[:2], sacrum),
                                 (*sheet(range(2), range(3, 5), z=0.1)[:2], OTHER))
    pressure = np.zeros((4, 5))
    pressure[3, 0], pressure[3, 4], pressure[0, 4] = 5.0, 5.0, 5.0
    t = taxel_sites(pressure, verts[None], faces, sites, MAT)[0]
    assert t[3, 0] == head and t[3, 4] == sacrum and t[0, 4] == sacrum  # the lower of the two sheets at (0, 4)


def test_min_mmhg_leaves_noise_out_and_empty_images_have_no_shares():
    v, f, _ = sheet(range(4), range(5))
    k = site_index("scapulae")
    pressure = np.full((2, 4, 5), 0.5)
    pressure[0, 1, 1] = 50.0
    pressure[1] = 0.0
    loads = site_loads(pressure, np.stack([v, v]), f, np.full(len(v), k), MAT, min_mmhg=1.0)
    assert loads.area_cm2[0, k] == pytest.approx(4.0) and loads.share[0, k] == 1.0
    assert loads.share[1].sum() == 0.0 and loads.most_loaded() == ["scapulae", ""]


def test_the_rest_of_the_body_is_no_site_a_nurse_can_turn_so_the_named_site_loaded_most_is_given():
    pressure = np.zeros((2, 4, 5))
    pressure[0, 0, :] = 40.0  # image 0: 'other' carries 5 taxels, the sacrum 2
    pressure[0, 3, :2] = 40.0
    pressure[1, 0, :] = 40.0  # image 1: only 'other'
    taxel = np.full((2, 4, 5), NO_SITE, np.int8)
    taxel[:, 0, :] = OTHER
    taxel[0, 3, :2] = site_index("sacrum")
    loads = site_stats(pressure, taxel, MAT)
    assert loads.most_loaded() == ["other", "other"]
    assert loads.most_loaded(named=True) == ["sacrum", ""]
    assert site_label("other") == "rest of the body" and site_label("left_heel") == "left heel"
    assert site_label("right_trochanter") == "right hip (trochanter)"


def test_site_stats_refuse_malformed_input():
    v, f, _ = sheet(range(2), range(2))
    with pytest.raises(BadInput, match="taxel_site"):
        site_stats(np.zeros((4, 5)), np.full((4, 5), len(SITES)), MAT)
    with pytest.raises(BadInput, match="vertices"):
        site_loads(np.zeros((2, 4, 5)), v[None], f, np.zeros(len(v), int), MAT)
    with pytest.raises(BadInput, match="mat"):
        site_loads(np.zeros((3, 3)), v[None], f, np.zeros(len(v), int), MAT)
    with pytest.raises(BadInput, match="faces"):
        site_loads(np.zeros((4, 5)), v[None], f + 10, np.zeros(len(v), int), MAT)
    with pytest.raises(BadInput, match="vertex_site"):
        site_loads(np.zeros((4, 5)), v[None], f, np.full(len(v), len(SITES)), MAT)
    with pytest.raises(BadInput, match="unknown body site"):
        site_index("elbow")


def test_vertex_pressure_reads_the_taxel_under_the_skin_only():
    v, f, _ = sheet(range(4), range(5))
    extra = np.array([centre(1, 1, 0.01), centre(1, 1, 0.10), [-1.0, 0.0, 0.0]])  # near the skin, above it, off the mat
    verts = np.vstack([v, extra])
    pressure = np.zeros((4, 5))
    pressure[1, 1], pressure[2, 2] = 30.0, 12.0
    vp = vertex_pressure(pressure, verts[None], f, MAT)[0]
    assert vp[len(v):].tolist() == [30.0, 0.0, 0.0]
    assert vp[:len(v)].reshape(4, 5).tolist() == pressure.tolist()


def test_lowest_vertices_one_per_covered_taxel():
    verts = np.array([centre(0, 0, 0.3), centre(0, 0, 0.1), centre(3, 4, 0.2)])
    cell, low = lowest_vertices(verts, MAT)
    assert cell.tolist() == [0, 19] and low.tolist() == [1, 2]


# --------------------------------------------------------------------------- the site map
@pytest.mark.parametrize("gender", ["female", "male", "neutral"])
def test_every_site_is_on_the_shipped_models_and_mirrors(gender):
    body = shipped(gender)
    s = vertex_sites(body)
    assert s.shape == (body.num_vertices,) and set(np.unique(s)) == set(range(len(SITES)))
    v = body.arrays.v_template
    for name in SITES:
        if name.startswith("left_"):  # the model is symmetric: a site's mirror image is its partner
            left, right = v[s == site_index(name)], v[s == site_index("right_" + name[5:])]
            assert abs(len(left) - len(right)) <= 0.1 * len(left)
            assert left[:, 0].min() > 0 > right[:, 0].max()
    heel, ankle = v[s == site_index("left_heel")], v[s == site_index("left_ankle")]
    assert heel[:, 1].mean() < ankle[:, 1].mean() and heel[:, 2].mean() < ankle[:, 2].mean()  # below, behind
    assert v[s == site_index("sacrum"), 2].max() < 0 and v[s == site_index("scapulae"), 2].max() < 0.02  # the back


def test_site_map_covers_every_taxel_and_takes_one_site_list_per_body():
    head, sacrum = site_index("head"), site_index("sacrum")
    v, f, cells = sheet(range(2), range(2))
    per_body = np.array([[head] * len(v), [sacrum] * len(v)])
    maps = body_site_map(np.stack([v, v]), f, per_body, MAT)
    assert maps.shape == (2, 4, 5) and (maps[0] == head).all() and (maps[1] == sacrum).all()  # nearest skin beyond it
    pressure = np.zeros((2, 4, 5))
    pressure[:, 0, 1] = 10.0
    t = taxel_sites(pressure, np.stack([v, v]), f, per_body, MAT)
    assert t[0, 0, 1] == head and t[1, 0, 1] == sacrum and (t[:, 2:] == NO_SITE).all()


def test_smpl_format_toy_body_gets_sites():
    body = BodyModel(toy_body_arrays())
    s = vertex_sites(toy_body_arrays())
    np.testing.assert_array_equal(vertex_sites(body), s)
    np.testing.assert_array_equal(vertex_sites(body.torch_layer()), s)  # the network's body layer too
    for name in ("head", "scapulae", "sacrum", "left_heel", "right_heel", "left_elbow", "left_knee"):
        assert (s == site_index(name)).any(), name
    with pytest.raises(BadInput, match="BodyModel"):
        vertex_sites("female")


def _lying(body, roll):
    """A body lying on the bed with roll (0 supine, +pi/2 on its left side); on its side, arms forward
    and hips and knees bent, as people lie on their side."""
    pose = np.zeros(72)
    pose[:3] = root_axis_angle(world_rotation(roll, 0.0))[0]
    if roll == 0:
        pose[48:51], pose[51:54] = [0, 0, -1.3], [0, 0, 1.3]  # arms down beside the body
    else:
        pose[48:51], pose[51:54] = [0, -np.pi / 2, 0], [0, np.pi / 2, 0]  # arms forward
        pose[3:6], pose[6:9] = [-0.5, 0, -0.1], [-0.5, 0, 0.1]  # hips bent, thighs together
        pose[12:15] = pose[15:18] = [0.6, 0, 0]
    v, _ = body.forward(np.zeros(10), pose)
    mat = get_mat("boditrak_bt3510")
    v = v[0] - [v[0, :, 0].mean() - mat.width_m / 2, v[0, :, 1].min() - 0.05, v[0, :, 2].min()]
    return v, mat


def _sunk(v, faces, mat, sink_m):
    """A pressure image (mmHg) of a body sunk sink_m into a bed of springs: each taxel reads in
    proportion to how far the body's lower surface over its centre is below the mattress top."""
    bottom = lower_surface(v, faces, (0.0, 0.0), (mat.pitch_col_m, mat.pitch_row_m), mat.shape)
    return np.where(np.isfinite(bottom), np.maximum(sink_m - bottom, 0.0), 0.0) * 1000.0  # 1 mmHg per mm


@pytest.mark.parametrize("gender", ["female", "male"])
def test_supine_body_loads_sacrum_scapulae_and_heels(gender):
    body = shipped(gender)
    v, mat = _lying(body, 0.0)
    loads = site_loads(_sunk(v, body.faces, mat, 0.09), v[None], body.faces, vertex_sites(body), mat)
    share = dict(zip(SITES, loads.share[0]))
    named = sorted((k for k in SITES if k != "other"), key=share.get, reverse=True)
    assert set(named[:2]) == {"sacrum", "scapulae"}
    assert share["left_heel"] > 0 and share["right_heel"] > 0
    assert share["left_heel"] == pytest.approx(share["right_heel"], rel=0.2)
    assert sum(loads.share[0]) == pytest.approx(1.0)


@pytest.mark.parametrize("gender", ["female", "male"])
def test_body_on_its_left_side_loads_its_left_shoulder_and_trochanter(gender):
    body = shipped(gender)
    v, mat = _lying(body, np.pi / 2)
    loads = site_loads(_sunk(v, body.faces, mat, 0.1), v[None], body.faces, vertex_sites(body), mat)
    share = dict(zip(SITES, loads.share[0]))
    assert share["left_shoulder"] > 0.05 and share["left_trochanter"] > 0.02
    for name in ("right_shoulder", "right_trochanter", "right_knee", "right_heel", "head"):
        assert share[name] == 0.0, name
    supine_v, _ = _lying(body, 0.0)
    supine = dict(zip(SITES, site_loads(_sunk(supine_v, body.faces, mat, 0.1), supine_v[None], body.faces, vertex_sites(body),
                                        mat).share[0]))
    assert share["sacrum"] + share["scapulae"] < 0.5 * (supine["sacrum"] + supine["scapulae"])


def test_body_loads_are_site_loads_and_vertex_pressure_together():
    body = shipped("female")
    v, mat = _lying(body, 0.0)
    p = _sunk(v, body.faces, mat, 0.06)
    loads, on_skin = body_loads(p, v[None], body.faces, vertex_sites(body), mat, min_mmhg=1.0)
    alone = site_loads(p, v[None], body.faces, vertex_sites(body), mat, min_mmhg=1.0)
    np.testing.assert_array_equal(loads.taxel_site, alone.taxel_site)
    np.testing.assert_allclose(loads.share, alone.share)
    np.testing.assert_allclose(on_skin, vertex_pressure(p, v[None], body.faces, mat))
    assert on_skin.max() == pytest.approx(p.max()) and (on_skin > 0).sum() < 0.3 * body.num_vertices


def test_a_body_read_a_taxel_off_its_print_is_moved_back_onto_it():
    body = shipped("female")
    v, mat = _lying(body, 0.0)
    p = _sunk(v, body.faces, mat, 0.09)[None]
    sites = vertex_sites(body)
    right = taxel_sites(p, v[None], body.faces, sites, mat)
    off = v + [0.0, -mat.pitch_row_m, 0.0]  # read one taxel toward the head
    heights = lower_surface(off, body.faces, (0.0, 0.0), (mat.pitch_col_m, mat.pitch_row_m), mat.shape)
    assert fit_offset(p[0], heights, mat) == (1, 0)
    np.testing.assert_array_equal(taxel_sites(p, off[None], body.faces, sites, mat), right)
    # as read, the body off its print gives the sacrum's and scapulae's taxels to their neighbours
    as_read = body_site_map(off[None], body.faces, sites, mat)
    assert (np.where(p > 0, as_read, NO_SITE) != right).sum() > 20
    np.testing.assert_array_equal(np.where(p > 0, body_site_map(off[None], body.faces, sites, mat, p), NO_SITE), right)


def test_a_body_already_on_its_print_and_an_empty_image_are_not_moved():
    body = shipped("male")
    v, mat = _lying(body, 0.0)
    heights = lower_surface(v, body.faces, (0.0, 0.0), (mat.pitch_col_m, mat.pitch_row_m), mat.shape)
    assert fit_offset(_sunk(v, body.faces, mat, 0.09), heights, mat) == (0, 0)
    assert fit_offset(np.zeros(mat.shape), heights, mat) == (0, 0)
    assert fit_offset(_sunk(v, body.faces, mat, 0.09), np.full(mat.shape, np.inf), mat) == (0, 0)


def test_fit_offset_leaves_readings_at_or_below_min_mmhg_out_as_taxel_sites_does():
    mat = custom_mat(12, 9, 0.02)
    r, c = np.mgrid[0:12, 0:9]
    # a bowl-shaped lower surface, 1 mm deeper per squared taxel toward its lowest point (6, 4), and
    # the print it leaves sunk 2 mm into a bed of springs (10 mmHg per mm): it lies on its print
    heights = np.where((abs(r - 6) <= 3) & (abs(c - 4) <= 3), 0.001 * ((r - 6) ** 2 + (c - 4) ** 2), np.inf)
    print_ = np.where(np.isfinite(heights), np.maximum(0.002 - heights, 0.0), 0.0) * 1e4
    image = np.where(r < 4, 5.0, print_)  # and a sheet reading 5 mmHg across the first 4 rows
    assert (print_ > 5.0).sum() == 5 and fit_offset(print_, heights, mat) == (0, 0)
    assert fit_offset(image, heights, mat, min_mmhg=5.0) == (0, 0)
    # counted as load, the sheet's readings pull the body off its print toward them
    assert fit_offset(image, heights, mat)[0] < 0
    with pytest.raises(BadInput, match="min_mmhg"):
        fit_offset(image, heights, mat, min_mmhg=-1.0)


def test_site_map_refuses_images_that_do_not_match_the_bodies():
    v, f, _ = sheet(range(2), range(2))
    with pytest.raises(BadInput, match="one image per body"):
        body_site_map(np.stack([v, v]), f, np.zeros(len(v), int), MAT, np.zeros((1, 4, 5)))


def test_fit_offset_refuses_an_image_or_heights_off_the_mat():
    heights = np.full(MAT.shape, np.inf)
    with pytest.raises(BadInput, match="pressure has shape"):
        fit_offset(np.zeros((MAT.rows + 1, MAT.cols)), heights, MAT)
    with pytest.raises(BadInput, match="pressure has shape"):
        fit_offset(np.full(MAT.shape, np.nan), heights, MAT)
    with pytest.raises(BadInput, match="heights has shape"):
        fit_offset(np.zeros(MAT.shape), heights[:, :-1], MAT)
    with pytest.raises(BadInput, match="reach_m"):
        fit_offset(np.zeros(MAT.shape), heights, MAT, reach_m=-0.01)
