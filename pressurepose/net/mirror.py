"""Left-right mirroring of images and bodies; test-time mirror averaging (read an image and its
mirror, and average the two bodies).

A bed, a mat and the body models are symmetric across the bed's long axis (the default bodies'
rest joints to 0.02 mm, posed joints over random shapes and poses to 2 mm), so the mirror of a pressure image (its columns reversed) is the
image of the mirrored body. Mirroring, in the bed frame (x across the bed on ``[0, width]``, y
along it, z up):

* a point: x -> width - x;
* an SMPL pose (B, 72): left and right joints swap (:func:`pressurepose.body.joints.mirror_permutation`)
  and each joint's axis-angle (a_x, a_y, a_z) becomes (a_x, -a_y, -a_z), the root included (the
  reflection x -> -x commutes with the body layer's fixed y-up to z-up turn, a turn about x);
* the root's (roll, pitch, yaw): (-roll, pitch, -yaw);
* the shape (betas): unchanged (the body models are symmetric).

:func:`mirror_averaged` runs a PressureNet on each image and on its mirror in one batch, mirrors the
second estimate back and averages the two: betas and translation by their mean, each joint's
rotation by its geodesic midpoint (the normalised sum of the two quaternions, same hemisphere). The
averaged body is posed again, with its PMR maps. A network that read a mirrored image exactly as
the mirror of what it read from the image gives the same body either way; one with a left/right
bias (a trained network has some) gives the average of both readings. Each module's estimate is
averaged on its own; Mod2 refines each branch's own Mod1 estimate.
"""

from __future__ import annotations

import warnings
from functools import lru_cache

import torch

from pressurepose.body.joints import NUM_JOINTS, mirror_permutation
from pressurepose.net.outputs import BodyParams
from pressurepose.net.rotations import axis_angle_to_quat, quat_to_axis_angle

SYMMETRY_TOLERANCE_M = 0.005  # rest joints this far from their mirror: the averaging's premise fails


@lru_cache(maxsize=8)
def _permutation(device: torch.device) -> torch.Tensor:
    """The left/right joint permutation on ``device``, made once (a copy to a GPU per call would
    make the host wait)."""
    return torch.tensor(mirror_permutation(), device=device)


def mirror_images(images: torch.Tensor) -> torch.Tensor:
    """Images (..., R, C) with their columns reversed (the mat seen in a mirror along the bed)."""
    return images.flip(-1)


def mirror_pose(pose: torch.Tensor) -> torch.Tensor:
    """SMPL poses (B, 72) of the mirrored bodies (root first)."""
    b = pose.shape[0]
    turned = pose.reshape(b, NUM_JOINTS, 3).index_select(1, _permutation(pose.device))
    return torch.cat([turned[..., :1], -turned[..., 1:]], -1).reshape(b, 3 * NUM_JOINTS)


def mirror_points(points: torch.Tensor, width_m: float) -> torch.Tensor:
    """Bed-frame points (..., 3) reflected across the mat's centre line: x -> width_m - x."""
    return torch.cat([width_m - points[..., :1], points[..., 1:]], -1)


def mirror_joints(joints: torch.Tensor, width_m: float) -> torch.Tensor:
    """Joint positions (B, 24, 3) of the mirrored bodies: points reflected and left/right swapped."""
    return mirror_points(joints, width_m).index_select(1, _permutation(joints.device))


def midpoint_rotation(a: torch.Tensor, b: torch.Tensor) -> torch.Tensor:
    """Axis-angle (..., 3) of the geodesic midpoint of the rotations a and b (..., 3 axis-angle each)."""
    qa, qb = axis_angle_to_quat(a), axis_angle_to_quat(b)
    same = (qa * qb).sum(-1, keepdim=True) >= 0
    q = qa + torch.where(same, qb, -qb)
    # opposite rotations (a half turn apart) have no unique midpoint; fall back to a
    norm = torch.linalg.vector_norm(q, dim=-1, keepdim=True)
    q = torch.where(norm > 1e-6, q / norm.clamp_min(1e-12), qa)
    return quat_to_axis_angle(q)


def _wrap(angle: torch.Tensor) -> torch.Tensor:
    return torch.atan2(torch.sin(angle), torch.cos(angle))


def average_with_mirrored(direct: BodyParams, mirrored: BodyParams, width_m: float) -> BodyParams:
    """The mean of ``direct`` and the mirror of ``mirrored`` (an estimate made from the mirrored
    image). ``unconstrained`` is the direct estimate's (it has no mirror: the network's inner values)."""
    pose_back = mirror_pose(mirrored.pose)
    pose = midpoint_rotation(direct.pose.reshape(-1, NUM_JOINTS, 3),
                             pose_back.reshape(-1, NUM_JOINTS, 3)).reshape(direct.pose.shape)
    roll, pitch, yaw = mirrored.root_euler.unbind(-1)
    euler_back = torch.stack([-roll, pitch, -yaw], -1)
    euler = direct.root_euler + 0.5 * _wrap(euler_back - direct.root_euler)
    transl_back = mirror_points(mirrored.transl, width_m)
    return BodyParams(unconstrained=direct.unconstrained, betas=0.5 * (direct.betas + mirrored.betas),
                      transl=0.5 * (direct.transl + transl_back), root_euler=_wrap(euler),
                      global_orient=pose[:, :3], body_pose=pose[:, 3:])


def rest_asymmetry_m(layer) -> float:
    """Largest distance (m) between a body layer's rest joints (zero pose and shape) and their mirror
    image: about 0.00002 for the open default bodies."""
    with torch.no_grad():
        j = layer().joints.double()
    return float((mirror_joints(j, 0.0) - j).norm(dim=-1).max())


def check_symmetric(net) -> None:
    """Warn (once per body layer) when a PressureNet's body is not mirror symmetric, so that mirror
    averaging would average a body with a different one."""
    for layer in net.body.layers:
        if getattr(layer, "_mirror_checked", False):
            continue
        err = rest_asymmetry_m(layer)
        layer._mirror_checked = True
        if err > SYMMETRY_TOLERANCE_M:
            warnings.warn(f"this body model is not mirror symmetric (its rest joints lie up to {1000 * err:.1f} mm "
                          f"from their mirror image); mirror averaging assumes a symmetric body", stacklevel=3)


def mirror_averaged(net, pressure: torch.Tensor, gender: torch.Tensor):
    """(out1, out2) like ``net(pressure, gender)`` for images (B, R, C) and genders (B,), each
    module's estimate averaged with its reading of the mirrored image (module docstring). out1 has
    no maps (nothing reads Mod1's averaged maps); out2 has vertices and maps, as ``net`` gives.
    Warns once if the body is not mirror symmetric (:func:`check_symmetric`)."""
    check_symmetric(net)
    b = pressure.shape[0]
    both = torch.cat([gender, gender])
    x1 = net.inputs(torch.cat([pressure, mirror_images(pressure)]))
    out1 = net.run_mod1(x1, both, maps=net.config.use_pmr, vertices=net.config.use_pmr)
    # each branch's Mod2 parameters only: the averaged body is posed (and mapped) once below
    out2 = net.run_mod2(x1, both, out1, maps=False, vertices=False)
    width = net.config.grid.size_m[0]
    averaged = []
    for out, maps in ((out1, False), (out2, True)):
        p = out.params
        direct = BodyParams(**{k: v[:b] for k, v in vars(p).items()})
        mirrored = BodyParams(**{k: v[b:] for k, v in vars(p).items()})
        averaged.append(net.pose_body(average_with_mirrored(direct, mirrored, width), gender, maps=maps))
    return tuple(averaged)

