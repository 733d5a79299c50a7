"""Soft tissue in the press: a spring E A / t per cell in series with the mattress."""

import math

import numpy as np
import pytest
import scipy.optimize
import trimesh

from pressurepose.body.model import asset_path
from pressurepose.errors import BadInput
from pressurepose.sim import GRAVITY, get_bed, press
from pressurepose.sim.press import (
    Heightfield,
    body_heightfield,
    press_grid,
    press_heightfield,
)
from pressurepose.sim.tissue import TISSUE_MIN_M, Bones, tissue_depth

K_A = 6e4


def _mesh(m):
    return np.asarray(m.vertices), np.asarray(m.faces)


def test_tissue_depth_is_the_distance_to_the_nearest_bone():
    bones = Bones(np.array([[[0, 0, 0], [1, 0, 0]], [[0, 1, 0], [0, 2, 0]]], float), np.array([0.01, 0.02]))
    pts = np.array([[0.5, 0, -0.05], [0, 1.5, -0.1], [2.0, 0, 0], [0.5, 0, -0.011]])
    np.testing.assert_allclose(tissue_depth(pts, bones), [0.04, 0.08, 0.15, TISSUE_MIN_M])
    with pytest.raises(BadInput, match="bones"):
        Bones(np.zeros((2, 3)), np.zeros(2))


def test_flat_plate_on_two_springs_in_series():
    """A flat plate with uniform tissue t on a Winkler bed: the plate sinks W / A (1/k_A + t/E), the
    mattress by W / (A k_A), and the pressure is W / A everywhere."""
    e_t, t = 8e3, 0.04
    bed = get_bed(stiffness_n_m3=K_A, coupling_n_m=0.0, tissue_modulus_pa=e_t)
    grid = press_grid(bed)
    bottom = np.full(grid.shape, np.inf)
    bottom[40:76, 30:54] = 0.0  # 36 x 24 cells, whole taxels
    xs, ys = grid.centers()
    com = np.array([xs[30:54].mean(), ys[40:76].mean(), 0.1])
    area = 36 * 24 * grid.cell_xy[0] * grid.cell_xy[1]
    for mass in (5.0, 40.0):
        w = mass * GRAVITY
        rigid = press_heightfield(Heightfield(bottom, com, grid), mass, bed)
        soft = press_heightfield(Heightfield(bottom, com, grid, np.where(np.isfinite(bottom), t, 0.0)), mass, bed)
        assert rigid.sink_m == pytest.approx(w / (K_A * area), rel=1e-9)
        assert soft.sink_m == pytest.approx(w / area * (1 / K_A + t / e_t), rel=1e-9)
        np.testing.assert_allclose(soft.bed_force, rigid.bed_force, rtol=1e-9, atol=1e-12)
        assert soft.bed_force.sum() == pytest.approx(w, rel=1e-12)


def _cylinder(grid, radius, ncell, col=45, row=60):
    dx, dy = grid.cell_xy
    length = ncell * dy
    x0 = grid.origin_xy[0] + col * dx  # on a cell boundary: symmetric sampling across the axis
    y0 = grid.origin_xy[1] + row * dy
    cyl = trimesh.creation.cylinder(radius=radius, height=length, sections=720)
    cyl.apply_transform(trimesh.transformations.rotation_matrix(np.pi / 2, [1, 0, 0]))
    cyl.apply_translation([x0, y0 + length / 2, radius])
    axis = np.array([[[x0, y0, radius], [x0, y0 + length, radius]]])
    return cyl, axis, length


def test_rigid_cylinder_on_two_springs_in_series_sinks_as_the_closed_form_says():
    """A cylinder of radius R with tissue R - r_bone over a bone on its axis, on a Winkler bed: one
    spring per area k = 1 / (1/k_A + t/E) carries it, so it sinks as a rigid cylinder on k."""
    e_t, radius, r_bone = 6e3, 0.1, 0.06
    bed = get_bed(stiffness_n_m3=K_A, coupling_n_m=0.0, tissue_modulus_pa=e_t)
    grid = press_grid(bed)
    dx, dy = grid.cell_xy
    cyl, axis, length = _cylinder(grid, radius, 60)
    bones = Bones(axis, np.array([r_bone]))
    k_eff = 1.0 / (1.0 / K_A + (radius - r_bone) / e_t)
    xs = (np.arange(-30, 30) + 0.5) * dx
    for mass in (5.0, 20.0):
        weight = mass * GRAVITY
        res = press(*_mesh(cyl), mass, bed, bones=bones)

        def continuum(d):  # k L x (area of the circular segment of depth d)
            a = math.sqrt(2 * radius * d - d * d)
            return k_eff * length * (radius ** 2 * math.asin(a / radius) - a * (radius - d)) - weight

        def sampled(d):  # the same integral at the press's cell centres
            pen = np.maximum(d - (radius - np.sqrt(np.maximum(radius ** 2 - xs ** 2, 0))), 0)
            return k_eff * dx * dy * 60 * pen.sum() - weight

        lowest_sample = radius - math.sqrt(radius ** 2 - (dx / 2) ** 2)
        assert res.sink_m + lowest_sample == pytest.approx(scipy.optimize.brentq(sampled, 1e-9, radius), rel=1e-4)
        assert res.sink_m + lowest_sample == pytest.approx(scipy.optimize.brentq(continuum, 1e-9, radius), rel=0.01)
        assert res.bed_force.sum() == pytest.approx(weight, rel=1e-12)


@pytest.mark.parametrize("coupling", [0.0, 6.24, 60.0])
def test_tissue_spreads_contact_and_lowers_the_peak(coupling):
    """The same cylinder, rigid and with tissue: the soft one spreads its load wider across its axis
    (the force-weighted spread, and the taxels over 5 mmHg), with a lower peak and the same total
    force."""
    bed = get_bed(stiffness_n_m3=K_A, coupling_n_m=coupling, tissue_modulus_pa=5e3)
    cyl, axis, _ = _cylinder(press_grid(bed), 0.15, 40)
    rigid = press(*_mesh(cyl), 4.0, bed)
    soft = press(*_mesh(cyl), 4.0, bed, bones=Bones(axis, np.array([0.1])))
    x = bed.full_grid.centers()[..., 0]

    def spread(res):
        f = res.bed_force
        xc = (f * x).sum() / f.sum()
        return math.sqrt((f * (x - xc) ** 2).sum() / f.sum())

    assert spread(soft) > 1.1 * spread(rigid)
    assert (soft.pressure > 5).sum() >= (rigid.pressure > 5).sum()
    assert soft.bed_force.max() < 0.9 * rigid.bed_force.max()
    assert soft.sink_m > rigid.sink_m
    assert soft.bed_force.sum() == pytest.approx(rigid.bed_force.sum(), rel=1e-12)


def test_pasternak_with_tissue_meets_the_contact_conditions(pasternak_patch):
    """The CG answer with compliance c: the gap w + b + c lam is >= 0, zero where lam > 0, and the
    load and both moments balance (checked against a sparse direct solve of K w = lam)."""
    c = pasternak_patch(lambda n, k_cell: np.random.default_rng(0).uniform(0.0, 3.0, n) / k_cell,  # up to 3x the bed's
                        tol=1e-10)
    gap, on, sol = c.gap, c.on, c.sol
    assert gap.min() > -1e-8
    assert np.abs(gap[on]).max() < 1e-8
    assert sol.lam.min() >= 0
    np.testing.assert_allclose(c.jac.T @ sol.lam, [c.weight, 0, 0], atol=1e-8 * c.weight)


@pytest.mark.skipif(not asset_path("female.npz").is_file(), reason="the shipped female body model is not baked")
def test_a_body_with_tissue_balances_exactly_and_spreads_its_contact():
    from pressurepose.body import BodyModel
    from pressurepose.body.joints import JOINT_NAMES
    from pressurepose.calibrate.objects import supine_body_mesh
    from pressurepose.sim.tissue import body_bones

    bed = get_bed()
    body = BodyModel("female")
    v, f, joints = supine_body_mesh(body, bed)
    # the pose and rigid motion supine_body_mesh uses (arms lowered 1.3 rad, turned to lie supine)
    from pressurepose.body.joints import joint_index

    pose = np.zeros(72)
    pose[3 * joint_index("left_shoulder") + 2] -= 1.3
    pose[3 * joint_index("right_shoulder") + 2] += 1.3
    verts, _ = body.forward(np.zeros(body.num_betas), pose)
    motion = np.eye(4)
    motion[:3, :3] = np.array([[-1.0, 0.0, 0.0], [0.0, 0.0, -1.0], [0.0, -1.0, 0.0]])
    motion[:3, 3] = v[0] - motion[:3, :3] @ verts[0, 0]
    np.testing.assert_allclose(verts[0] @ motion[:3, :3].T + motion[:3, 3], v, atol=1e-9)
    bones = body_bones(body, np.zeros(body.num_betas), pose, np.zeros(3)).moved(motion)
    hf = body_heightfield(v, f, bed, bones=bones)
    xs, ys = press_grid(bed).centers()

    def tissue_at(name, radius=0.05, toward=None):
        j = joints[JOINT_NAMES.index(name)]
        if toward is not None:
            j = (j + joints[JOINT_NAMES.index(toward)]) / 2
        near = np.hypot(xs[None, :] - j[0], ys[:, None] - j[1]) < radius
        sel = near & np.isfinite(hf.bottom)
        return np.median(hf.tissue[sel])

    # thin over the back of the head and the heels, thick under the thighs and calves
    assert tissue_at("head") < 0.015
    assert tissue_at("left_ankle") < 0.015
    assert tissue_at("left_knee", 0.03, toward="left_ankle") > 0.025
    assert tissue_at("left_hip", 0.03, toward="left_knee") > 0.04
    rigid = press(v, f, 62.5, bed)
    soft = press(v, f, 62.5, bed, bones=bones)
    weight = 62.5 * GRAVITY
    assert soft.bed_force.sum() == pytest.approx(weight, rel=1e-9)
    centres = bed.full_grid.centers()
    cop = (soft.bed_force[..., None] * centres).sum((0, 1)) / weight
    np.testing.assert_allclose(cop, soft.com[:2], atol=0.0286 / 2)
    assert (soft.pressure > 5).sum() > (rigid.pressure > 5).sum()
    assert soft.pressure.max() <= rigid.pressure.max()
    # a thicker pelvic bone (less buttock over it) puts more of the weight under the pelvis
    bony = press(v, f, 62.5, bed, bones=body_bones(body, np.zeros(body.num_betas), pose, np.zeros(3),
                                                    {"pelvis": 0.95}).moved(motion))
    pelvis_y = joints[JOINT_NAMES.index("pelvis")][1]
    band = np.abs(centres[..., 1] - pelvis_y) < 0.1
    assert bony.bed_force.sum() == pytest.approx(weight, rel=1e-9)
    assert bony.bed_force[band].sum() > soft.bed_force[band].sum() * 1.05


def test_bone_fractions_scale_each_parts_capsules():
    from pressurepose.body import BodyModel
    from pressurepose.body.capsules import CAPSULE_NAMES
    from pressurepose.sim.bed import TISSUE_BONE_FRACTION
    from pressurepose.sim.tissue import CAPSULE_PART, bone_cores

    if not asset_path("male.npz").is_file():
        pytest.skip("the shipped male body model is not baked")
    body = BodyModel("male")
    cores = bone_cores(body, np.full(body.num_betas, 0.5), np.zeros(72), np.zeros(3))
    default, thin = cores.bones(), cores.bones({"thigh": 0.1})
    for k, name in enumerate(CAPSULE_NAMES):
        same = CAPSULE_PART[name] != "thigh"
        assert (thin.radius[k] == default.radius[k]) == same
    k = CAPSULE_NAMES.index("left_thigh")
    assert thin.radius[k] == pytest.approx(default.radius[k] * 0.1 / TISSUE_BONE_FRACTION[5])
    assert set(CAPSULE_PART) == set(CAPSULE_NAMES)
