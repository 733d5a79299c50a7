"""``synthetic_producer``: a cheap, deterministic TEST AND DEMO producer. It is not physics.

It lays a stick figure (the toy body's rest joints, scaled to a height) on the mat with the
partition's roll, a random yaw and shift, and draws the pressure image as Gaussian blobs under the
joints, carrying the body weight (the mat records the part of it over the sensing area). Images and
labels are consistent (force <= m g, pressure = force / taxel area, contact where force is present,
depth = Winkler sink) but the picture
is not a resting human: use it to exercise storage, the pipeline, readers and training code.
``transl`` is the root joint's position (no body model is involved).

Options (``GenerationConfig.options``):
  reject_rate (float, default 0.1): probability that an attempt is rejected as "synthetic_unstable"
  cost_ms (float, default 0): CPU busy-work per attempt, to stand in for a real producer's cost
  sleep_ms (float, default 0): idle wait per attempt (slows a run without loading the CPU)
"""

from __future__ import annotations

import time

import numpy as np

from pressurepose.body.toy import TOY_REST_JOINTS
from pressurepose.data.resample import MMHG_PA
from pressurepose.data.schema import GenerationConfig, Sample
from pressurepose.sim.simulate import Rejected

GRAVITY = 9.81
DEPTH_EMPTY_M = 1.0  # depth where no body is above a taxel, as pressurepose.sim.press reports it
WINKLER_K = 1.0e5  # N/m^3, foundation modulus used for the synthetic sink depth (a foam mattress's)
# share of body weight carried under each joint (pelvis, hips, spine, shoulders... hands)
_LOAD = np.array([12, 6, 6, 8, 4, 4, 8, 2, 2, 8, 1, 1, 3, 3, 3, 7, 3, 3, 2, 2, 1, 1, 0.5, 0.5])
_LOAD = _LOAD / _LOAD.sum()
_ROLL = {"general": None, "prone_hands_up": np.pi}  # None: uniform in [-pi, pi); others supine (0)


def _lying_template() -> np.ndarray:
    """Toy rest joints laid supine along the bed, arms down by the sides: head toward -y, body's left
    toward -x, pelvis at the origin, metres."""
    j = TOY_REST_JOINTS - TOY_REST_JOINTS[0]
    lying = np.stack([-j[:, 0], -j[:, 2], -j[:, 1]], axis=1)  # lie down, then 180 deg about z
    for side, (shoulder, elbow, wrist, hand) in enumerate(((16, 18, 20, 22), (17, 19, 21, 23))):
        x = lying[shoulder, 0] + (-0.03 if side == 0 else 0.03)
        for joint, dy in ((elbow, 0.28), (wrist, 0.52), (hand, 0.60)):
            lying[joint] = (x * (1 + dy / 2), lying[shoulder, 1] + dy, lying[shoulder, 2])
    return lying


def _busy(cost_ms: float) -> None:
    """Burn about ``cost_ms`` of this process's CPU time (deterministic work, result unused)."""
    end = time.process_time() + cost_ms / 1000.0
    a = np.full((48, 48), 0.5)
    while time.process_time() < end:
        a = np.tanh(a @ a)


def _rot_y(angle: float) -> np.ndarray:
    c, s = np.cos(angle), np.sin(angle)
    return np.array([[c, 0, s], [0, 1, 0], [-s, 0, c]])


def _rot_z(angle: float) -> np.ndarray:
    c, s = np.cos(angle), np.sin(angle)
    return np.array([[c, -s, 0], [s, c, 0], [0, 0, 1]])


def synthetic_producer(config: GenerationConfig, rng: np.random.Generator) -> Sample | Rejected:
    """One synthetic attempt (see the module docstring). Same config and rng state -> same result."""
    if config.option("cost_ms", 0):
        _busy(float(config.option("cost_ms")))
    if config.option("sleep_ms", 0):
        time.sleep(float(config.option("sleep_ms")) / 1000.0)
    grid = config.grid
    if rng.random() < float(config.option("reject_rate", 0.1)):
        return Rejected("synthetic_unstable")

    female = config.gender == "f"
    betas = rng.uniform(-3.0, 3.0, 10)
    height = (1.62 if female else 1.76) * (1 + 0.02 * betas[0])
    mass = (62.5 if female else 78.4) * (1 + 0.08 * betas[0]) * (1 + 0.05 * betas[1])
    roll_fixed = _ROLL.get(config.partition, 0.0)
    roll = rng.uniform(-np.pi, np.pi) if roll_fixed is None else roll_fixed
    yaw = rng.uniform(-np.pi / 6, np.pi / 6)
    shift = rng.uniform(-0.2, 0.2, 2)
    limb_jitter = rng.normal(0.0, 0.03, (24, 3))
    pose = np.concatenate([[0.0, roll, yaw], rng.normal(0.0, 0.2, 69)])

    scale = height / 1.62
    body = (_lying_template() * scale + limb_jitter * np.arange(24).clip(0, 1)[:, None]) @ (
        _rot_z(yaw) @ _rot_y(roll)).T
    root = np.array([grid.width_m / 2 + shift[0], grid.length_m / 2 + 0.05 + shift[1], 0.10])
    joints = body + root
    on_mat = (joints[:, 0] >= 0) & (joints[:, 0] <= grid.width_m) & (joints[:, 1] >= 0) & \
        (joints[:, 1] <= grid.length_m)
    if not on_mat[0] or on_mat.mean() < 0.8:
        return Rejected("off_mat")

    # each joint's load spread as a Gaussian over the bed; the mat records the part over it
    yc = (np.arange(grid.rows) + 0.5) * grid.pitch_row_m
    xc = (np.arange(grid.cols) + 0.5) * grid.pitch_col_m
    sigma = 0.06 * scale
    gy = np.exp(-0.5 * ((yc[None, :] - joints[:, 1:2]) / sigma) ** 2) * grid.pitch_row_m  # (24, R)
    gx = np.exp(-0.5 * ((xc[None, :] - joints[:, 0:1]) / sigma) ** 2) * grid.pitch_col_m  # (24, C)
    force = np.einsum("j,jr,jc->rc", _LOAD * mass * GRAVITY / (2 * np.pi * sigma ** 2), gy, gx)
    force[force < 1e-3 * force.max()] = 0.0
    pressure_pa = force / grid.taxel_area_m2
    contact = force > 0
    depth = np.where(contact, -pressure_pa / WINKLER_K, DEPTH_EMPTY_M)

    f32 = np.float32
    return Sample(
        pressure=(pressure_pa / MMHG_PA).astype(f32), force=force.astype(f32), depth=depth.astype(f32),
        contact=contact, betas=betas.astype(f32), pose=pose.astype(f32), transl=root.astype(f32),
        joints=joints.astype(f32), gender=config.gender, mass=float(mass), height=float(height),
        partition=config.partition)
