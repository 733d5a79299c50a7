"""A tiny synthetic PressurePose-like dataset for tests: the toy body lying on a small mat, its
"pressure" image the PMR sink map of its own mesh (so the images carry the pose)."""

from __future__ import annotations

import numpy as np
import torch

from pressurepose.body.joints import JOINT_NAMES
from pressurepose.body.model import BodyModel
from pressurepose.body.toy import toy_body_arrays
from pressurepose.mat import MatSpec, custom_mat, get_mat
from pressurepose.net.pmr import pmr
from pressurepose.net.rotations import euler_to_root_axis_angle

GRID = custom_mat(rows=40, cols=20, pitch_row_m=0.05, pitch_col_m=0.05)  # 2.0 x 1.0 m, coarse and fast


def toy_body() -> BodyModel:
    return BodyModel(toy_body_arrays())


def toy_pose(rng: np.random.Generator, n: int) -> np.ndarray:
    """(n, 72) poses: supine or prone-ish roll, small yaw, arms down, random knees and elbows."""
    pose = np.zeros((n, 72))
    euler = np.stack([rng.choice([0.0, 0.3, -0.3], n), np.zeros(n), rng.uniform(-0.2, 0.2, n)], 1)
    pose[:, :3] = euler_to_root_axis_angle(torch.tensor(euler)).numpy()
    j = JOINT_NAMES.index
    pose[:, 3 * j("left_shoulder") + 2] = rng.uniform(-1.2, -0.6, n)
    pose[:, 3 * j("right_shoulder") + 2] = rng.uniform(0.6, 1.2, n)
    for side in ("left", "right"):  # bent knees with the thigh raised keep the foot on the bed
        knee = rng.uniform(0.0, 1.0, n)
        pose[:, 3 * j(side + "_knee")] = knee
        pose[:, 3 * j(side + "_hip")] = -0.5 * knee
    pose[:, 3 * j("left_elbow") + 1] = rng.uniform(-1.0, 0.0, n)
    return pose


def toy_dataset(n: int = 8, seed: int = 0, grid: MatSpec = GRID) -> dict[str, torch.Tensor]:
    """n samples of the toy body resting on ``grid`` (its lowest tenth of vertices sunk by at least
    1 cm), as the training data mapping."""
    rng = np.random.default_rng(seed)
    body = toy_body()
    pose = toy_pose(rng, n)
    betas = rng.uniform(-1, 1, (n, 10))
    transl = np.zeros((n, 3))
    v0, _ = body.forward(betas, pose, transl)
    w, length = grid.size_m
    target = np.stack([rng.uniform(0.4 * w, 0.6 * w, n), rng.uniform(0.45 * length, 0.55 * length, n)], 1)
    transl[:, :2] = target - v0[:, :, :2].mean(1)
    transl[:, 2] = -0.01 - np.quantile(v0[:, :, 2], 0.1, axis=1)
    verts, joints = body.forward(betas, pose, transl)
    maps = pmr(torch.tensor(verts), grid)
    return {"pressure": (0.5 * maps.q).float(), "gender": torch.tensor(rng.integers(0, 2, n)),
            "betas": torch.tensor(betas).float(), "pose": torch.tensor(pose).float(),
            "transl": torch.tensor(transl).float(), "joints": torch.tensor(joints).float()}


BODITRAK = get_mat("boditrak_bt3510")


def write_toy_dataset(out, n: int = 4, seed: int = 0):
    """A complete on-disk dataset (pressurepose.data format, BodiTrak mat) of toy-body samples with
    two partitions and both genders. Returns the in-memory data mapping too."""
    from pressurepose.data.schema import GenerationConfig, Sample
    from pressurepose.data.store import write_dataset

    data = toy_dataset(n, seed=seed, grid=BODITRAK)
    data["gender"] = torch.arange(n) % 2
    depth = pmr(torch.tensor(toy_body().forward(data["betas"].numpy(), data["pose"].numpy(),
                                                 data["transl"].numpy())[0]), BODITRAK).depth.numpy()
    parts = ("general_supine", "supine_straight_limbs")
    samples = [Sample(pressure=data["pressure"][i].numpy(), force=data["pressure"][i].numpy() * 0.1,
                      depth=depth[i], contact=depth[i] < 0, betas=data["betas"][i].numpy(),
                      pose=data["pose"][i].numpy(), transl=data["transl"][i].numpy(),
                      joints=data["joints"][i].numpy(), gender="fm"[int(data["gender"][i])], mass=60.0,
                      height=1.7, partition=parts[i % 2], index=i) for i in range(n)]
    config = GenerationConfig(partition="general_supine", gender="f", count=n, seed=seed, shard_size=3)
    write_dataset(out, config, samples)
    return data
