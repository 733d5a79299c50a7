"""Capsule masses: analytic inertia against numerical integration, shared volumes, totals."""

import numpy as np
import pytest

from pressurepose.body import BodyModel
from pressurepose.body.capsules import CAPSULE_NAMES, fit_capsules
from pressurepose.body.masses import (
    CAPSULE_SEGMENTS,
    PAPER_VOXEL,
    RUNTIME_VOXEL,
    SEGMENT_FRACTIONS,
    capsule_inertia,
    segment_fractions,
    segment_masses,
    shared_volumes,
)
from pressurepose.body.model import asset_path
from pressurepose.body.toy import toy_body_arrays
from pressurepose.errors import BadInput


def capsule_ends(center, axis, length):
    axis = np.asarray(axis, float) / np.linalg.norm(axis)
    return np.array([center - 0.5 * length * axis, center + 0.5 * length * axis])


def numerical_inertia(radius, length, mass, h=0.001):
    """Inertia about the centre of a uniform capsule along z, by summing 1 mm voxels."""
    half = 0.5 * length + radius
    x = np.arange(-radius, radius, h) + h / 2
    z = np.arange(-half, half, h) + h / 2
    X, Y, Z = np.meshgrid(x, x, z, indexing="ij")
    zc = np.clip(Z, -0.5 * length, 0.5 * length)
    inside = X**2 + Y**2 + (Z - zc) ** 2 <= radius**2
    P = np.stack([X[inside], Y[inside], Z[inside]], 1)
    dm = mass / len(P)
    return dm * (np.eye(3) * (P**2).sum() - P.T @ P)


@pytest.mark.parametrize("radius,length", [(0.05, 0.2), (0.08, 0.0), (0.03, 0.35)])
def test_capsule_inertia_matches_numerical_integration(radius, length):
    mass = 3.7
    analytic = capsule_inertia(mass, radius, length)
    numeric = numerical_inertia(radius, length, mass)
    np.testing.assert_allclose(analytic, numeric, rtol=0.01, atol=1e-9 * mass)


def test_capsule_inertia_limits():
    # sphere: 2/5 m r^2 about every axis
    np.testing.assert_allclose(capsule_inertia(2.0, 0.1, 0.0), 0.4 * 2.0 * 0.01 * np.eye(3))
    # very long thin capsule -> rod: m L^2 / 12 across, m r^2 / 2 along
    I = capsule_inertia(1.0, 1e-4, 2.0)
    assert I[0, 0] == pytest.approx(4.0 / 12.0, rel=1e-3)
    assert I[2, 2] == pytest.approx(0.5 * 1e-8, rel=1e-3)
    assert capsule_inertia(np.ones(5), 0.1, 0.2).shape == (5, 3, 3)


def test_shared_volumes_of_simple_arrangements():
    r, L = 0.05, 0.2
    exact = np.pi * r**2 * L + 4 / 3 * np.pi * r**3
    one = capsule_ends(np.zeros(3), [1, 2, 3], L)
    far = capsule_ends(np.array([1.0, 0, 0]), [0, 0, 1], L)
    # alone or far apart: the whole volume (within voxel error)
    v = shared_volumes(np.array([one, far]), np.array([r, r]), voxel=0.002)
    np.testing.assert_allclose(v, exact, rtol=0.02)
    # two identical capsules: half each
    v = shared_volumes(np.array([one, one]), np.array([r, r]), voxel=0.002)
    np.testing.assert_allclose(v, exact / 2, rtol=0.02)
    assert v[0] == v[1]
    # a sphere wholly inside a capsule: the sphere gets half its volume, the capsule the rest
    ball = np.zeros((2, 3))
    v = shared_volumes(np.array([one, ball]), np.array([r, 0.03]), voxel=0.001)
    ball_vol = 4 / 3 * np.pi * 0.03**3
    np.testing.assert_allclose(v, [exact - ball_vol / 2, ball_vol / 2], rtol=0.02)
    # only the asked-for capsules are returned; the others still take their share
    np.testing.assert_allclose(shared_volumes(np.array([one, ball]), np.array([r, 0.03]), 0.001, [1]),
                               v[1:])
    with pytest.raises(BadInput, match="voxel"):
        shared_volumes(np.array([one]), np.array([r]), voxel=0.0)


def test_segment_fractions_follow_the_table():
    for g in ("female", "male"):
        f = segment_fractions(g)
        table = SEGMENT_FRACTIONS[g]
        total = sum(v * (1 if s in ("trunk", "head_neck") else 2) for s, v in table.items())
        k = CAPSULE_NAMES.index("left_thigh")
        assert f[k] == pytest.approx(table["thigh"] / total)
    np.testing.assert_allclose(segment_fractions("n"), (segment_fractions("f") + segment_fractions("m")) / 2,
                               rtol=0.01)
    with pytest.raises(BadInput, match="gender"):
        segment_fractions("x")


def check_masses(body, betas, gender, voxel=RUNTIME_VOXEL):
    masses = segment_masses(body, betas, gender, voxel=voxel)
    # the total comes from the rest mesh directly; BodyModel.mass runs the full skinning (rounding differs)
    assert masses.total == pytest.approx(body.mass(betas[None])[0], rel=1e-6)
    assert masses.mass.sum() == pytest.approx(masses.total, rel=1e-12)
    assert np.all(masses.mass > 0)
    frac = segment_fractions(gender)
    seg = np.array(CAPSULE_SEGMENTS)
    for s in ("trunk", "head_neck", "thigh", "hand"):
        k = np.flatnonzero(seg == s)
        share = frac[k[0]] * (1 if s in ("trunk", "head_neck") else len(k))
        assert masses.mass[k].sum() == pytest.approx(share * masses.total, rel=1e-9), s
    caps = fit_capsules(body, betas) if body.arrays.meta.get("source") == "toy" else None
    if caps is not None:
        np.testing.assert_allclose(masses.inertia, capsule_inertia(masses.mass, caps.radius, caps.length))
    np.testing.assert_array_equal(masses.com, 0.0)
    return masses


def test_toy_masses_sum_to_body_mass():
    body = BodyModel(toy_body_arrays())
    for g in ("f", "m", "n"):
        check_masses(body, np.random.default_rng(0).uniform(-3, 3, 10), g)


def test_masses_bad_input():
    body = BodyModel(toy_body_arrays())
    with pytest.raises(BadInput, match="betas"):
        segment_masses(body, np.full(10, np.nan))
    with pytest.raises(BadInput, match="betas"):
        segment_masses(body, np.zeros(12))
    with pytest.raises(BadInput, match="gender"):
        segment_masses(body, np.zeros(10), gender="q")
    with pytest.raises(BadInput, match="voxel"):
        segment_masses(body, np.zeros(10), voxel=-1.0)


@pytest.mark.parametrize("gender", ["female", "male"])
def test_human_masses(gender):
    if not asset_path(f"{gender}.npz").is_file():
        pytest.skip(f"shipped body model {gender}.npz not baked yet (tools/bake_body_model.py)")
    body = BodyModel(gender)
    betas = np.random.default_rng(1).uniform(-2, 2, 10)
    masses = check_masses(body, betas, gender, voxel=PAPER_VOXEL)
    # the paper's 2 mm grid and the 5 mm run-time default agree to within 1.5 % per capsule
    coarse = segment_masses(body, betas, gender)
    assert coarse.voxel == RUNTIME_VOXEL == 0.005 and masses.voxel == PAPER_VOXEL == 0.002
    np.testing.assert_allclose(coarse.mass, masses.mass, rtol=0.015)
    mean = segment_masses(body, np.zeros(10), gender)
    for k, name in enumerate(CAPSULE_NAMES):
        if name.startswith("left_"):
            assert mean.mass[k] == pytest.approx(mean.mass[CAPSULE_NAMES.index("right_" + name[5:])], rel=0.02)


def test_joint_frame_mass_properties_rotate_the_capsule_inertia():
    from pressurepose.body.masses import joint_frame_mass_properties

    body = BodyModel(toy_body_arrays())
    betas = np.linspace(-1, 1, 10)
    caps = fit_capsules(body, betas)
    masses = segment_masses(body, betas, caps=caps)
    com, inertia = joint_frame_mass_properties(masses, caps)
    np.testing.assert_allclose(com, caps.center)
    # the inertia about the capsule axis is the axial moment, across it the transverse one
    axial = np.einsum("ki,kij,kj->k", caps.axis, inertia, caps.axis)
    np.testing.assert_allclose(axial, masses.inertia[:, 2, 2])
    np.testing.assert_allclose(np.trace(inertia, axis1=1, axis2=2),
                               np.trace(masses.inertia, axis1=1, axis2=2))
