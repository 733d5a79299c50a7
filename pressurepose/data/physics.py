"""The physics producer: sample a body, settle it on the bed (MuJoCo), press its mesh, read the mat.

This is the data engine's real per-sample function (registered as ``physics`` in
:data:`pressurepose.data.producers.PRODUCERS`)::

    pose sampler --> settle (capsule ragdoll on the slider-cell bed) --> press (mesh on the
    calibrated foundation) --> Sample (pressure, force, depth, contact + labels)

The labels describe the body where the image was made: the press's small rigid correction (a
tilt about the centre of mass and a vertical shift) is folded into the root orientation and
translation, so ``BodyModel.forward(betas, pose, transl)`` reproduces the pressed mesh exactly.
"""

from __future__ import annotations

from functools import lru_cache

import numpy as np

from pressurepose.body import BodyModel
from pressurepose.body.lbs_numpy import Y_UP_TO_Z_UP, rodrigues, rotation_to_axis_angle, shaped_rest
from pressurepose.data.producers import Rejected
from pressurepose.data.schema import GenerationConfig, Sample


@lru_cache(maxsize=8)
def _setup(gender: str, mat: str):
    """Body model and bed, built once per worker process for a (gender, mat) pair."""
    from pressurepose.sim.bed import get_bed

    return BodyModel(gender), get_bed(mat)


def apply_rigid_motion(body: BodyModel, betas: np.ndarray, pose: np.ndarray, transl: np.ndarray,
                       transform: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """SMPL root parameters of a body after a rigid motion of the whole body.

    betas (S,), pose (72,), transl (3,) place the body; transform (4, 4) moves it in the bed frame.
    Returns (pose', transl') with ``forward(betas, pose', transl') == transform applied to
    forward(betas, pose, transl)``: only the root orientation (pose'[:3]) and transl change.
    """
    Q = Y_UP_TO_Z_UP
    R, t = transform[:3, :3], transform[:3, 3]
    _, rest = shaped_rest(body.arrays, np.asarray(betas)[None])
    root = Q @ rest[0, 0]                      # the root joint's offset, z-up, before transl
    new_pose = np.array(pose, dtype=np.float64)
    new_pose[:3] = rotation_to_axis_angle(Q.T @ R @ Q @ rodrigues(new_pose[:3]))
    new_transl = R @ (root + transl) + t - root
    return new_pose, new_transl


def physics_producer(config: GenerationConfig, rng: np.random.Generator) -> Sample | Rejected:
    """One attempt at a labelled sample with the full physics; all randomness from ``rng``."""
    from pressurepose.pose.sampler import sample_one
    from pressurepose.sim.press import PressFailed, press
    from pressurepose.sim.settle import settle

    body, bed = _setup(config.gender, config.mat)
    drawn = sample_one(config.partition, config.gender, rng, config.limbs_on_bed, body=body)
    rest = settle(body, drawn.betas, drawn.pose, drawn.transl, config.gender, bed=bed)
    if not rest.ok:
        return Rejected(rest.status)
    verts, _ = body.forward(rest.betas, rest.pose, rest.transl)
    try:
        image = press(verts[0], body.faces, rest.mass_kg, bed)
    except PressFailed:
        return Rejected("press_failed")
    pose, transl = apply_rigid_motion(body, rest.betas, rest.pose, rest.transl, image.transform)
    _, joints = body.forward(rest.betas, pose, transl)
    betas = np.zeros(10)
    betas[: len(rest.betas)] = rest.betas
    return Sample(
        pressure=image.pressure, force=image.force, depth=image.depth, contact=image.contact,
        betas=betas, pose=pose, transl=transl, joints=joints[0], gender=config.gender,
        mass=float(rest.mass_kg), height=float(body.height(rest.betas)[0]), partition=config.partition,
    )
