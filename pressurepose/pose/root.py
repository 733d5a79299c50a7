"""The global transform of a body lying on the bed: roll, yaw (pitch 0) to SMPL's root axis-angle.

Bed frame (whole project): metres, origin at the head-end left corner of the mat's sensing area on
the unloaded mattress surface, x across the bed, y along it toward the foot, z up.

Roll 0, yaw 0 is the body lying supine along the bed: head toward y = 0 (row 0), face up (+z), the
body's left toward -x. ``roll`` is a right-handed rotation about the body's head direction (the bed's
-y axis before yaw): +pi/2 lays the body on its left side, -pi/2 on its right side, +-pi prone. ``yaw``
then turns the body about the bed's z axis (right-handed, seen from above: counter-clockwise).

The body model's output for a root axis-angle r is ``W @ rest`` with ``W = Q R(r) Q^T`` (Q =
``Y_UP_TO_Z_UP``), so the root pose for a world rotation W is ``r = Q^T rotvec(W)``.
"""

from __future__ import annotations

import math

import numpy as np

from pressurepose.body.lbs_numpy import Y_UP_TO_Z_UP, rotation_to_axis_angle

# z-up rest body (head +z, face -y, left +x) -> supine on the bed (head -y, face +z, left -x)
SUPINE = np.array([[-1.0, 0.0, 0.0], [0.0, 0.0, -1.0], [0.0, -1.0, 0.0]])


def world_rotation(roll, yaw) -> np.ndarray:
    """World rotations (B, 3, 3) of the z-up rest body for roll, yaw (B,) rad (see module doc)."""
    roll = np.atleast_1d(np.asarray(roll, dtype=np.float64))
    yaw = np.atleast_1d(np.asarray(yaw, dtype=np.float64))
    cr, sr, cy, sy = np.cos(roll), np.sin(roll), np.cos(yaw), np.sin(yaw)
    one, zero = np.ones_like(cr), np.zeros_like(cr)
    # right-handed rotation by `roll` about -y is a rotation by -roll about +y
    about_head = np.stack([cr, zero, -sr, zero, one, zero, sr, zero, cr], -1).reshape(-1, 3, 3)
    about_z = np.stack([cy, -sy, zero, sy, cy, zero, zero, zero, one], -1).reshape(-1, 3, 3)
    return about_z @ about_head @ SUPINE


def root_axis_angle(W: np.ndarray) -> np.ndarray:
    """SMPL root axis-angle (B, 3) giving world rotations W (B, 3, 3) of the z-up rest body."""
    return rotation_to_axis_angle(W) @ Y_UP_TO_Z_UP  # row-vector form of Q^T w


def root_rotation(root_pose: np.ndarray) -> np.ndarray:
    """World rotations W (B, 3, 3) of the z-up rest body for SMPL root axis-angles (B, 3)."""
    from pressurepose.body.lbs_numpy import rodrigues

    Q = Y_UP_TO_Z_UP
    return Q @ rodrigues(np.atleast_2d(root_pose)) @ Q.T


def body_axes(W: np.ndarray) -> dict[str, np.ndarray]:
    """World directions (B, 3) of the body's head, face (front) and left for rotations W (B, 3, 3)."""
    return {"head": W[..., :, 2], "face": -W[..., :, 1], "left": W[..., :, 0]}


def truncated_normal(rng: np.random.Generator, sd: float, bound: float, size=None) -> np.ndarray:
    """N(0, sd) values redrawn until |value| <= bound (sd 0: zeros). Deterministic for a given rng."""
    out = np.zeros(size) if size is not None else np.zeros(())
    if sd <= 0:
        return out if size is not None else float(out)
    todo = np.ones(out.shape, dtype=bool)
    while todo.any():
        out[todo] = rng.normal(0.0, sd, int(todo.sum()))
        todo = np.abs(out) > bound
    return out if size is not None else float(out)


def draw_betas(rng: np.random.Generator, config, count: int) -> np.ndarray:
    """Body shape (count,) betas. ``config.shapes`` 'normal' (default): N(0, beta_sd) truncated to
    +-beta_range, SMPL's own population (its betas are unit-variance PCA coefficients of scanned
    adults); 'uniform': U(-beta_range, beta_range), the paper's (a sixth of its bodies have a BMI
    under 17 or over 35; see docs/physics.md)."""
    if config.shapes == "uniform":
        return rng.uniform(-config.beta_range, config.beta_range, count)
    return truncated_normal(rng, config.beta_sd, config.beta_range, count)


def draw_placement(rng: np.random.Generator, config, crown_m: float, roll: float = 0.0,
                   ) -> tuple[float, np.ndarray]:
    """Yaw (rad) and the pelvis's bed-frame (x, y) for a body whose crown lies ``crown_m`` from its
    pelvis joint along the body's head direction and whose root is rolled by ``roll`` (rad, 0
    supine).

    'centred' (default): yaw ~ N(0, yaw_sd) within +-yaw_max; the pelvis N(0, hypot(across_sd_m
    cos roll, across_sd_lateral_m sin roll)) across the mattress's centre line, and along the bed
    so that the crown lies head_gap_m +- along_sd_m (normal) from the mattress's head end, as
    people lie in a bed. 'uniform' (the paper's): yaw ~ U(-yaw_max, yaw_max), the pelvis
    U(-shift_max, shift_max) across and along from the mattress's centre.
    """
    centre = config.mattress_centre
    if config.placement == "uniform":
        yaw = rng.uniform(-config.yaw_max, config.yaw_max)
        return float(yaw), centre + rng.uniform(-config.shift_max, config.shift_max, 2)
    yaw = truncated_normal(rng, config.yaw_sd, config.yaw_max)
    sd = math.hypot(config.across_sd_m * math.cos(roll), config.across_sd_lateral_m * math.sin(roll))
    across = rng.normal(0.0, sd) if sd > 0 else 0.0
    gap = rng.normal(config.head_gap_m, config.along_sd_m) if config.along_sd_m > 0 else config.head_gap_m
    head = world_rotation(0.0, yaw)[0, :, 2]  # the body's head direction on the bed
    y = config.mattress[2] + gap - crown_m * head[1]
    return float(yaw), np.array([centre[0] + across, y])


def slide_along_bed(joints: np.ndarray, config) -> float:
    """How far (m, toward the foot) to slide a 'centred' body whose limbs were drawn with joints
    (24, 3) bed frame so that no limb joint lies within ``head_gap_m`` of the mattress's head end
    (arms raised above the head: people lying so lie lower in the bed), as far as the room left
    at the foot end (5 cm kept clear past the lowest joint) allows. 0 for the 'uniform' placement."""
    if config.placement != "centred":
        return 0.0
    y0, y1 = config.mattress[2], config.mattress[3]
    need = y0 + config.head_gap_m - joints[:, 1].min()
    room = y1 - 0.05 - joints[:, 1].max()
    return float(np.clip(need, 0.0, max(room, 0.0)))
