"""Limb kinematics of the sampler against the body model's own forward kinematics and capsules."""

import numpy as np

from pressurepose.body.capsules import capsules_for, posed_capsules
from pressurepose.body.lbs_numpy import Y_UP_TO_Z_UP as Q
from pressurepose.body.lbs_numpy import rodrigues
from pressurepose.pose.limbs import LIMBS, limb_geometry, limb_lengths, rotate
from pressurepose.pose.limits import joint_limits


def test_rotate_matches_rotation_matrices():
    rng = np.random.default_rng(0)
    aa = rng.normal(0, 1.5, (7, 3))
    aa[0] = 0.0
    v = rng.normal(size=(7, 4, 3))
    np.testing.assert_allclose(rotate(aa, v), np.einsum("bij,bmj->bmi", rodrigues(aa), v), atol=1e-12)


def test_limb_geometry_matches_the_body_model(female):
    rng = np.random.default_rng(1)
    lim = joint_limits()
    n = 6
    betas = rng.uniform(-3, 3, (n, 10))
    _, rest_zup = female.rest(betas)
    rest = rest_zup @ Q  # back to SMPL's frame
    pose = np.zeros((n, 24, 3))
    angles = []
    for limb in LIMBS:
        lo, hi = limb.box(lim, straight=False)
        a = rng.uniform(lo, hi, (n, lo.size))
        angles.append(a)
        pose[:, list(limb.chain)] += limb.local_axis_angles(a, lim)
    pose = pose.reshape(n, 72)
    _, joints = female.forward(betas, pose)  # root 0, no transl: z-up = Q @ SMPL frame
    for i in range(n):
        caps = capsules_for(female, betas[i])
        ends_zup, _ = posed_capsules(female, caps, betas[i], pose[i:i + 1])
        half = 0.5 * caps.length[:, None, None] * np.array([-1.0, 1.0])[None, :, None]
        local = (caps.center[:, None] + half * caps.axis[:, None]) @ Q
        for limb, a in zip(LIMBS, angles):
            aa = limb.local_axis_angles(a[i:i + 1, None], lim)
            pos, ends = limb_geometry(limb, aa, rest[i:i + 1], local[None])
            np.testing.assert_allclose(pos[0, 0] @ Q.T, joints[i, list(limb.chain)], atol=1e-9)
            np.testing.assert_allclose(ends[0, 0] @ Q.T, ends_zup[0, list(limb.capsules)], atol=1e-9)
    lengths = limb_lengths(rest)
    thigh = np.linalg.norm(rest[:, 4] - rest[:, 1], axis=-1)
    assert np.all(lengths[:, 0] > thigh) and np.all(lengths[:, 0] < 1.2)
