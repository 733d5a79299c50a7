"""Press: rasterised lower surface, force and moment balance, closed-form sinks, symmetry, errors."""

import math

import numpy as np
import pytest
import scipy.optimize
import trimesh
from matplotlib.path import Path

from pressurepose.body.mesh import lower_surface
from pressurepose.body.model import asset_path
from pressurepose.errors import BadInput
from pressurepose.sim import DEPTH_EMPTY_M, GRAVITY, PressFailed, get_bed, press
from pressurepose.sim.press import mesh_centroid, press_grid

K_A = 6e4


def box_on_cells(grid, col0, row0, ncols, nrows, height=0.1):
    """A box whose footprint is exactly cells [col0, col0+ncols) x [row0, row0+nrows), bottom at z=0."""
    dx, dy = grid.cell_xy
    box = trimesh.creation.box(extents=[ncols * dx, nrows * dy, height])
    box.apply_translation([grid.origin_xy[0] + (col0 + ncols / 2) * dx,
                           grid.origin_xy[1] + (row0 + nrows / 2) * dy, height / 2])
    return box


def lumpy_body():
    """An asymmetric closed body: a flattened torso capsule, a head sphere, one leg, one offset box."""
    torso = trimesh.creation.capsule(height=0.5, radius=0.14, count=[24, 24])
    torso.apply_transform(trimesh.transformations.rotation_matrix(np.pi / 2, [1, 0, 0]))
    torso.vertices[:, 2] *= 0.7
    torso.apply_translation([0.40, 0.75, 0.0])
    head = trimesh.creation.icosphere(2, 0.09).apply_translation([0.40, 0.33, 0.0])
    leg = trimesh.creation.capsule(height=0.7, radius=0.06, count=[16, 16])
    leg.apply_transform(trimesh.transformations.rotation_matrix(np.pi / 2 - 0.1, [1, 0, 0]))
    leg.apply_translation([0.47, 1.4, 0.0])
    block = trimesh.creation.box(extents=[0.12, 0.2, 0.08]).apply_translation([0.2, 0.9, 0.02])
    mesh = trimesh.util.concatenate([torso, head, leg, block])
    mesh.apply_translation([0, 0, -mesh.vertices[:, 2].min()])
    return mesh


# ------------------------------------------------------------------ raster
def test_raster_interpolates_planes_exactly_and_leaves_gaps_empty():
    grid_shape, origin, cell = (40, 30), (0.0, 0.0), (0.01, 0.02)
    v = np.array([[0.05, 0.1, 0.0], [0.25, 0.15, 0.0], [0.1, 0.7, 0.0]])
    v[:, 2] = 0.3 * v[:, 0] - 0.2 * v[:, 1] + 0.05  # a tilted plane
    h = lower_surface(v, np.array([[0, 1, 2]]), origin, cell, grid_shape)
    jj, ii = np.nonzero(np.isfinite(h))
    x, y = (ii + 0.5) * cell[0], (jj + 0.5) * cell[1]
    np.testing.assert_allclose(h[jj, ii], 0.3 * x - 0.2 * y + 0.05, atol=1e-12)
    # exactly the cell centres inside the triangle are filled
    xs, ys = np.meshgrid((np.arange(30) + 0.5) * 0.01, (np.arange(40) + 0.5) * 0.02)
    inside = Path(v[:, :2]).contains_points(np.stack([xs.ravel(), ys.ravel()], 1)).reshape(40, 30)
    np.testing.assert_array_equal(np.isfinite(h), inside)


def test_raster_takes_the_lowest_surface_of_a_closed_mesh():
    grid = press_grid(get_bed())
    box = box_on_cells(grid, 40, 50, 12, 20, height=0.2)
    box.apply_translation([0, 0, 0.03])
    h = lower_surface(box.vertices, box.faces, grid.origin_xy, grid.cell_xy, grid.shape)
    filled = np.isfinite(h)
    assert filled.sum() == 12 * 20 and filled[50:70, 40:52].all()
    np.testing.assert_allclose(h[filled], 0.03, atol=1e-12)



def test_raster_ignores_surface_below_the_floor():
    """A triangle sloping from z = 0 down to z = -1: below the floor it is not there."""
    grid_shape, origin, cell = (20, 20), (0.0, 0.0), (0.01, 0.01)
    v = np.array([[0.0, 0.0, 0.0], [0.2, 0.0, -1.0], [0.0, 0.2, 0.0]])
    full = lower_surface(v, np.array([[0, 1, 2]]), origin, cell, grid_shape)
    cut = lower_surface(v, np.array([[0, 1, 2]]), origin, cell, grid_shape, floor=-0.5)
    kept = np.isfinite(full) & (full >= -0.5)
    np.testing.assert_array_equal(np.isfinite(cut), kept)
    np.testing.assert_array_equal(cut[kept], full[kept])
    assert (np.isfinite(full) & ~kept).any()

# ------------------------------------------------------------------ balance and closed forms
@pytest.mark.parametrize("coupling", [0.0, 60.0])
@pytest.mark.parametrize("mass", [3.0, 25.0, 80.0])
def test_total_force_is_the_weight(mass, coupling):
    bed = get_bed(stiffness_n_m3=K_A, coupling_n_m=coupling)
    res = press(*_mesh(lumpy_body()), mass, bed)
    assert res.bed_force.sum() == pytest.approx(mass * GRAVITY, rel=1e-6)
    assert res.force.sum() <= res.bed_force.sum() + 1e-9
    assert np.all(res.force >= 0) and np.all(np.isfinite(res.pressure))


def test_flat_box_on_winkler_sinks_by_weight_over_stiffness_times_area():
    bed = get_bed(stiffness_n_m3=K_A, coupling_n_m=0.0)
    grid = press_grid(bed)
    box = box_on_cells(grid, 30, 42, 24, 36)  # whole taxels (3 x 3 cells each)
    for mass in (5.0, 40.0):
        res = press(*_mesh(box), mass, bed)
        area = 24 * 36 * grid.cell_xy[0] * grid.cell_xy[1]
        assert res.sink_m == pytest.approx(mass * GRAVITY / (K_A * area), rel=1e-9)
        np.testing.assert_allclose(res.tilt_rad, 0, atol=1e-12)
        # every covered cell carries the same force
        assert np.ptp(res.bed_force[res.bed_force > 0]) < 1e-9


def test_horizontal_cylinder_on_winkler_sinks_as_the_closed_form_says():
    bed = get_bed(stiffness_n_m3=K_A, coupling_n_m=0.0)
    grid = press_grid(bed)
    dx, dy = grid.cell_xy
    radius, ncell = 0.1, 60
    length = ncell * dy
    x0 = grid.origin_xy[0] + 45 * dx  # on a cell boundary: symmetric sampling across the axis
    cyl = trimesh.creation.cylinder(radius=radius, height=length, sections=720)
    cyl.apply_transform(trimesh.transformations.rotation_matrix(np.pi / 2, [1, 0, 0]))
    cyl.apply_translation([x0, grid.origin_xy[1] + 60 * dy + length / 2, radius])
    xs = (np.arange(-30, 30) + 0.5) * dx  # cell centres across the axis
    for mass in (5.0, 20.0):
        weight = mass * GRAVITY
        res = press(*_mesh(cyl), mass, bed)

        def continuum(d):  # k L x (area of the circular segment of depth d)
            a = math.sqrt(2 * radius * d - d * d)
            return K_A * length * (radius ** 2 * math.asin(a / radius) - a * (radius - d)) - weight

        def sampled(d):  # the same integral sampled at the press's cell centres
            pen = np.maximum(d - (radius - np.sqrt(np.maximum(radius ** 2 - xs ** 2, 0))), 0)
            return K_A * dx * dy * ncell * pen.sum() - weight

        d_cont = scipy.optimize.brentq(continuum, 1e-9, radius)
        d_disc = scipy.optimize.brentq(sampled, 1e-9, radius)
        lowest_sample = radius - math.sqrt(radius ** 2 - (dx / 2) ** 2)  # centres sit dx/2 off the axis
        assert res.sink_m + lowest_sample == pytest.approx(d_disc, rel=1e-4)
        assert res.sink_m + lowest_sample == pytest.approx(d_cont, rel=0.01)
        assert abs(res.tilt_rad).max() < 1e-9


def test_flat_strip_on_pasternak_carries_the_shear_ring_of_the_closed_form():
    g_shear = 30.0
    bed = get_bed(stiffness_n_m3=K_A, coupling_n_m=g_shear)
    grid = press_grid(bed)
    dx, dy = grid.cell_xy
    nx, ny = 20, 100
    mass = 30.0
    res = press(*_mesh(box_on_cells(grid, 30, 40, nx, ny)), mass, bed)
    d = res.sink_m
    kc, gx, gy = K_A * dx * dy, g_shear * dy / dx, g_shear * dx / dy

    def decay(eps):  # outside a straight edge the sheet falls off as rho^n, rho + 1/rho = 2 + eps
        return (2 + eps - math.sqrt((2 + eps) ** 2 - 4)) / 2

    edge = 2 * ny * gx * (1 - decay(kc / gx)) + 2 * nx * gy * (1 - decay(kc / gy))
    weight = mass * GRAVITY
    assert d * (kc * nx * ny + edge) == pytest.approx(weight, rel=0.01)  # the four corners add the rest
    assert d * kc * nx * ny < 0.85 * weight  # without the shear ring it would sink 20 % deeper
    # continuum closed form F = d (k A + sqrt(k G) perimeter), to discretisation error
    area, perim = nx * dx * ny * dy, 2 * (nx * dx + ny * dy)
    assert d * (K_A * area + math.sqrt(K_A * g_shear) * perim) == pytest.approx(weight, rel=0.06)


def test_pasternak_solution_meets_the_contact_conditions(pasternak_patch):
    """Check the CG answer against a sparse direct solve of K w = lam on the same patch."""
    c = pasternak_patch(tol=1e-9)
    np.testing.assert_allclose(c.found.stiffness_matrix(c.flat).toarray(), c.stiff[c.flat][:, c.flat].toarray(),
                               atol=1e-12)
    gap, on, sol = c.gap, c.on, c.sol
    assert gap.min() > -1e-8                       # the sheet never rises through the body
    assert np.abs(gap[on]).max() < 1e-8            # it touches wherever it pushes
    assert sol.lam.min() >= 0                      # it only pushes
    np.testing.assert_allclose(c.jac.T @ sol.lam, [c.weight, 0, 0], atol=1e-8 * c.weight)  # force, 2 moments
    assert on.sum() < c.under.sum()                # the contact set is a real subset


def test_centre_of_pressure_lies_under_the_centre_of_mass():
    body = lumpy_body()
    for coupling in (0.0, 60.0):
        bed = get_bed(stiffness_n_m3=K_A, coupling_n_m=coupling, press_cell_m=0.0286 / 4)
        res = press(*_mesh(body), 40.0, bed)
        centres = bed.full_grid.centers()
        cop = (res.bed_force[..., None] * centres).sum((0, 1)) / res.bed_force.sum()
        # taxel-level centre of pressure vs the exact cell-level one: within a quarter taxel
        np.testing.assert_allclose(cop, res.com[:2], atol=0.0286 / 4)
        _, centroid = mesh_centroid(body.vertices, body.faces)
        np.testing.assert_allclose(res.com, centroid, atol=1e-12)


def test_an_off_centre_weight_tilts_the_body_toward_it():
    bed = get_bed(stiffness_n_m3=K_A, coupling_n_m=0.0)
    grid = press_grid(bed)
    box = box_on_cells(grid, 30, 40, 30, 30)
    centre = box.vertices.mean(0)[:2]
    for shift in ([0.01, 0.0], [0.0, -0.008]):
        res = press(*_mesh(box), 20.0, bed, com_xy=centre + np.array(shift))
        # heavy on +x: the +x side goes down, a rotation about +y by a positive angle; heavy on -y:
        # the -y side goes down, a rotation about +x by a positive angle
        for tilt, s in zip(res.tilt_rad, (-shift[1], shift[0])):
            assert (abs(tilt) < 1e-9) if s == 0 else (np.sign(tilt) == np.sign(s) and abs(tilt) > 0.01)
        centres = bed.full_grid.centers()
        cop = (res.bed_force[..., None] * centres).sum((0, 1)) / res.bed_force.sum()
        np.testing.assert_allclose(cop, centre + shift, atol=0.002)


def test_transform_moves_the_body_to_where_the_press_left_it():
    bed = get_bed(stiffness_n_m3=K_A, coupling_n_m=60.0)
    body = lumpy_body()
    res = press(*_mesh(body), 50.0, bed)
    t = res.transform
    assert np.allclose(t[:3, :3] @ t[:3, :3].T, np.eye(3)) and np.linalg.det(t[:3, :3]) == pytest.approx(1)
    assert 0.02 < abs(res.tilt_rad).max() < 0.1  # this lopsided body needs a real tilt
    moved = body.vertices @ t[:3, :3].T + t[:3, 3]
    assert moved[:, 2].min() == pytest.approx(-res.sink_m, abs=1e-3)  # vertices vs sampled surface
    np.testing.assert_allclose(t[:3, :3] @ res.com + t[:3, 3] - res.com, [0, 0, res.shift_m], atol=1e-12)
    again = press(moved, body.faces, 50.0, bed)  # pressing the pressed body moves it no further
    assert abs(again.shift_m) < 2e-4 and abs(again.tilt_rad).max() < 0.01
    np.testing.assert_allclose(again.pressure, res.pressure, atol=0.05 * res.pressure.max())


# ------------------------------------------------------------------ outputs
def test_depth_contact_and_empty_taxels():
    bed = get_bed(stiffness_n_m3=K_A, coupling_n_m=60.0)
    res = press(*_mesh(lumpy_body()), 50.0, bed)
    assert res.depth.shape == res.pressure.shape == res.force.shape == res.contact.shape == (64, 27)
    np.testing.assert_array_equal(res.contact, res.depth < 0)
    assert res.depth.min() == pytest.approx(-res.sink_m)
    empty = res.depth == DEPTH_EMPTY_M
    assert empty.any() and (~empty).any() and np.all(res.force[empty] == 0)
    assert np.all(res.depth[~empty] < 0.5)
    assert np.all(res.force[res.contact].sum() > 0.9 * res.force.sum())


@pytest.mark.parametrize("coupling", [0.0, 60.0])
def test_mirrored_body_gives_a_mirrored_image(coupling):
    bed = get_bed(stiffness_n_m3=K_A, coupling_n_m=coupling)
    body = lumpy_body()
    mirrored = body.vertices * [-1, 1, 1] + [bed.mat.width_m, 0, 0]
    a = press(body.vertices, body.faces, 45.0, bed)
    b = press(mirrored, body.faces[:, ::-1], 45.0, bed)
    np.testing.assert_allclose(b.force, a.force[:, ::-1], atol=1e-6 * a.force.max())
    np.testing.assert_allclose(b.pressure, a.pressure[:, ::-1], atol=1e-6 * a.pressure.max())
    np.testing.assert_allclose(b.depth, a.depth[:, ::-1], atol=1e-7)
    assert b.sink_m == pytest.approx(a.sink_m)


def test_heavier_presses_harder_and_deeper():
    bed = get_bed(stiffness_n_m3=K_A, coupling_n_m=60.0)
    body = _mesh(lumpy_body())
    results = [press(*body, m, bed) for m in (30.0, 60.0, 90.0)]
    for light, heavy in zip(results, results[1:]):
        assert heavy.force.sum() > light.force.sum()
        assert heavy.sink_m > light.sink_m
        assert heavy.pressure.max() >= light.pressure.max()
        assert heavy.contact.sum() >= light.contact.sum()
        assert np.all(heavy.depth <= light.depth + 1e-12)


def test_stiffer_bed_sinks_less():
    body = _mesh(lumpy_body())
    soft = press(*body, 60.0, get_bed(stiffness_n_m3=3e4, coupling_n_m=30.0))
    hard = press(*body, 60.0, get_bed(stiffness_n_m3=1e5, coupling_n_m=30.0))
    coupled = press(*body, 60.0, get_bed(stiffness_n_m3=3e4, coupling_n_m=300.0))
    assert hard.sink_m < soft.sink_m and coupled.sink_m < soft.sink_m
    assert hard.contact.sum() < soft.contact.sum()


def test_random_meshes_never_give_nan():
    """Random convex bodies dropped anywhere: a finite, balanced answer or a clear PressFailed."""
    rng = np.random.default_rng(7)
    bed = get_bed(stiffness_n_m3=K_A, coupling_n_m=60.0)
    solved = 0
    for _ in range(16):
        pts = rng.normal(size=(40, 3)) * np.r_[rng.uniform(0.05, 0.2, size=2), rng.uniform(0.01, 0.03)]
        hull = trimesh.convex.convex_hull(pts)
        hull.apply_translation([rng.uniform(0.1, 0.65), rng.uniform(0.2, 1.6), -hull.vertices[:, 2].min()
                                + rng.uniform(-0.05, 0.05)])
        mass = float(rng.uniform(0.5, 30))
        try:
            res = press(*_mesh(hull), mass, bed)
        except PressFailed:
            continue  # a tall hull resting on a corner may tip over
        solved += 1
        for arr in (res.pressure, res.force, res.depth, res.bed_force):
            assert np.all(np.isfinite(arr))
        assert res.bed_force.sum() == pytest.approx(mass * GRAVITY, rel=1e-6)
        assert np.all(res.pressure >= 0) and np.all(res.pressure <= bed.mat.max_mmhg)
    assert solved >= 12


def test_other_mats_press_too():
    body = _mesh(lumpy_body())
    for name in ("slp", "tip"):
        bed = get_bed(name, stiffness_n_m3=K_A, coupling_n_m=60.0)
        res = press(*body, 40.0, bed)
        assert res.pressure.shape == bed.mat.shape
        assert res.bed_force.sum() == pytest.approx(40 * GRAVITY, rel=1e-6)



@pytest.mark.parametrize("coupling", [0.0, 60.0])
@pytest.mark.parametrize("torso_bottom, limb_bottom", [(-0.035, -0.55), (0.0, -0.19)])
def test_a_limb_hanging_beside_the_mattress_carries_no_load(coupling, torso_bottom, limb_bottom):
    """A torso lying at the mattress's side edge with a limb hanging down beside it, 2 cm of the
    limb over the mattress (as a settled mesh spills over the edge): the mattress carries the
    torso only, exactly as if the limb were not there (same mass and centre of mass), and the
    body does not "sink through the mattress". The limb reaches below the mattress's bottom
    where the body is given, or (torso given 3 cm above its rest) only once the body has sunk."""
    bed = get_bed(stiffness_n_m3=K_A, coupling_n_m=coupling)
    x_edge = bed.mattress_bounds[1]
    torso = trimesh.creation.box(extents=[0.3, 0.5, 0.15]).apply_translation(
        [x_edge - 0.17, 0.9, torso_bottom + 0.075])
    limb = trimesh.creation.box(extents=[0.08, 0.06, 0.05 - limb_bottom]).apply_translation(
        [x_edge + 0.02, 0.9, (0.05 + limb_bottom) / 2])
    com_xy = (x_edge - 0.17, 0.9)  # over the torso's centre: no tilt, so the centres' heights do not matter
    with_limb = press(*_mesh(trimesh.util.concatenate([torso, limb])), 30.0, bed, com_xy=com_xy)
    without = press(*_mesh(torso), 30.0, bed, com_xy=com_xy)
    assert with_limb.bed_force.sum() == pytest.approx(30.0 * GRAVITY, rel=1e-6)
    np.testing.assert_allclose(with_limb.bed_force, without.bed_force, atol=1e-9 * 30.0 * GRAVITY)
    assert with_limb.sink_m == pytest.approx(without.sink_m, abs=1e-9) and with_limb.sink_m < 0.1

# ------------------------------------------------------------------ failures
def test_bad_inputs_are_named():
    body = lumpy_body()
    v, f = body.vertices, body.faces
    bad_v = v.copy()
    bad_v[3, 1] = np.nan
    cases = [((bad_v, f, 50.0), "NaN"), ((v[:, :2], f, 50.0), "vertices"), ((v, f[:, :2], 50.0), "faces"),
             ((v, f + len(v), 50.0), "index"), ((v, f.astype(float), 50.0), "faces"), ((v, f, -3.0), "mass_kg"),
             ((v, f, float("nan")), "mass_kg"), ((v, f, True), "mass_kg")]
    for args, match in cases:
        with pytest.raises(BadInput, match=match):
            press(*args)
    with pytest.raises(BadInput, match="BedSpec"):
        press(v, f, 50.0, bed="boditrak_bt3510")
    with pytest.raises(BadInput, match="com_xy"):
        press(v, f, 50.0, com_xy=[0.1])
    flat = trimesh.creation.box(extents=[0.2, 0.2, 0.1])
    with pytest.raises(BadInput, match="volume"):
        press(flat.vertices * [1, 1, 0] + [0.3, 0.5, 0], flat.faces, 5.0)


def test_bodies_without_equilibrium_fail_clearly():
    off = lumpy_body().apply_translation([5.0, 0, 0])
    with pytest.raises(PressFailed, match="not over the mattress"):
        press(off.vertices, off.faces, 50.0)
    # a small foot touching the bed, a big block held above it beside the foot: it tips over
    foot = trimesh.creation.box(extents=[0.05, 0.05, 0.5]).apply_translation([0.2, 0.8, 0.25])
    arm = trimesh.creation.box(extents=[0.5, 0.1, 0.05]).apply_translation([0.47, 0.8, 0.5])
    lever = trimesh.util.concatenate([foot, arm])
    for coupling in (0.0, 60.0):
        with pytest.raises(PressFailed, match="tips over|through the"):
            press(lever.vertices, lever.faces, 20.0, get_bed(coupling_n_m=coupling))
    # a brick on its end, too heavy for the mattress: it bottoms out
    bed = get_bed(coupling_n_m=0.0)
    brick = box_on_cells(press_grid(bed), 30, 30, 15, 15, height=0.3)
    with pytest.raises(PressFailed, match="through the"):
        press(*_mesh(brick), 300.0, bed)


def _mesh(m):
    return np.asarray(m.vertices), np.asarray(m.faces)


@pytest.mark.skipif(not asset_path("female.npz").is_file(), reason="the shipped female body model is not baked")
def test_supine_and_prone_bodies_touch_where_anatomy_says():
    from pressurepose.body import BodyModel
    from pressurepose.body.joints import JOINT_NAMES
    from pressurepose.calibrate.objects import supine_body_mesh

    bed = get_bed()
    body = BodyModel("female")
    v, f, joints = supine_body_mesh(body, bed)
    j = {n: joints[JOINT_NAMES.index(n)] for n in JOINT_NAMES}

    def load_near(res, point, radius=0.06):
        """Newtons on the taxels within ``radius`` (m) of a point's footprint."""
        d = np.linalg.norm(bed.taxel_centers() - point[:2], axis=-1)
        return res.force[d < radius].sum()

    supine = press(v, f, 62.5, bed)
    weight = 62.5 * GRAVITY
    centre = (v.max(0) + v.min(0)) / 2
    turn = np.diag([-1.0, 1.0, -1.0])  # prone: the same body turned over about the bed's long axis
    prone_v = (v - centre) @ turn.T + centre
    prone_v[:, 2] -= prone_v[:, 2].min()
    joints_p = (joints - centre) @ turn.T + centre
    jp = {n: joints_p[JOINT_NAMES.index(n)] for n in JOINT_NAMES}
    prone = press(prone_v, f, 62.5, bed)

    def on_back(name, radius=0.06):
        return load_near(supine, j[name], radius)

    def on_front(name, radius=0.06):
        return load_near(prone, jp[name], radius)

    # supine: the back of the head, the shoulder blades, sacrum and buttocks, the calves carry it
    assert on_back("head", 0.08) > 0
    assert on_back("pelvis") + on_back("left_hip") > 0.1 * weight
    calf = (j["left_knee"] + j["left_ankle"]) / 2
    assert load_near(supine, calf, 0.06) > 0.005 * weight
    # back against front: shoulder blades and buttocks press supine, chest and toes prone
    assert on_back("left_collar") > 3 * on_front("left_collar")
    assert on_back("left_hip") > 1.5 * on_front("left_hip")
    assert on_front("spine2") > 2 * on_back("spine2")
    assert on_front("left_foot") > 0.02 * weight > 100 * on_back("left_foot")  # toes point up when supine


# ------------------------------------------------------------------ which surface carries each taxel
def test_raster_names_the_vertex_of_the_lowest_surface_nearest_each_cell():
    grid_shape, origin, cell = (10, 10), (0.0, 0.0), (0.01, 0.01)
    low = [[0.0, 0.0, 0.0], [0.1, 0.0, 0.0], [0.0, 0.1, 0.0]]
    v = np.array(low + [[x, y, 0.05] for x, y, _ in low])  # the same triangle 5 cm higher
    h, nearest = lower_surface(v, np.array([[3, 4, 5], [0, 1, 2]]), origin, cell, grid_shape, return_vertex=True)
    assert nearest[0, 0] == 0 and nearest[0, 8] == 1 and nearest[8, 0] == 2  # corners of the lower one
    np.testing.assert_array_equal(nearest >= 0, np.isfinite(h))
    assert nearest[9, 9] == -1


def test_press_labels_each_taxel_with_the_surface_that_carries_its_force():
    bed = get_bed(stiffness_n_m3=K_A, coupling_n_m=60.0)
    grid = press_grid(bed)
    r0, c0 = 3 * (bed.full_grid.row0 + 20), 3 * (bed.full_grid.col0 + 5)  # whole taxels of the sensing area
    a, b = box_on_cells(grid, c0, r0, 6, 9), box_on_cells(grid, c0 + 6, r0, 9, 9)
    verts = np.vstack([a.vertices, b.vertices])
    faces = np.vstack([a.faces, b.faces + len(a.vertices)])
    labels = np.r_[np.full(len(a.vertices), 3), np.full(len(b.vertices), 7)]
    res = press(verts, faces, 20.0, bed, vertex_label=labels)
    assert res.label.shape == res.force.shape
    np.testing.assert_array_equal(res.label >= 0, res.force > 0)
    assert (res.label[20:23, 5:7] == 3).all() and (res.label[20:23, 7:10] == 7).all()
    assert press(verts, faces, 20.0, bed).label is None
    with pytest.raises(BadInput, match="vertex_label"):
        press(verts, faces, 20.0, bed, vertex_label=labels[:-1])


@pytest.mark.skipif(not asset_path("female.npz").is_file(), reason="the shipped female body model is not baked")
def test_a_pressed_body_labels_the_taxels_under_its_head_head():
    from pressurepose.body import BodyModel
    from pressurepose.body.joints import JOINT_NAMES
    from pressurepose.body.sites import SITES, vertex_sites
    from pressurepose.calibrate.objects import supine_body_mesh

    bed = get_bed()
    body = BodyModel("female")
    v, f, joints = supine_body_mesh(body, bed)
    res = press(v, f, 62.5, bed, vertex_label=vertex_sites(body))
    d = np.linalg.norm(bed.taxel_centers() - joints[JOINT_NAMES.index("head"), :2], axis=-1)
    under_head = (d < 0.05) & (res.force > 0)
    assert under_head.any() and (res.label[under_head] == SITES.index("head")).all()
    d = np.linalg.norm(bed.taxel_centers() - joints[JOINT_NAMES.index("pelvis"), :2], axis=-1)
    assert (res.label[(d < 0.05) & (res.force > 0)] == SITES.index("sacrum")).all()
    carried = {SITES[k]: res.force[res.label == k].sum() for k in range(len(SITES))}
    assert carried["sacrum"] + carried["scapulae"] > 0.3 * res.force.sum()
