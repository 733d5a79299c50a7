"""SMPL forward pass as a batched, differentiable torch layer (CPU or CUDA, float32 or float64).

Call shape follows the community convention::

    out = layer(betas=(B, S), body_pose=(B, 3(J-1)), global_orient=(B, 3), transl=(B, 3))
    out.vertices  # (B, V, 3) metres
    out.joints    # (B, J, 3) metres

Same frames as :mod:`pressurepose.body.lbs_numpy`: SMPL parameters in, z-up project frame out.
"""

from __future__ import annotations

import functools
from dataclasses import dataclass

import numpy as np
import torch
from torch import nn

from pressurepose.body.lbs_numpy import Y_UP_TO_Z_UP
from pressurepose.body.smpl_io import SmplArrays
from pressurepose.errors import BadInput


@dataclass
class BodyOutput:
    """Result of a body forward pass: vertices (B, V, 3) and joints (B, J, 3), metres.

    ``rotations`` (B, J, 3, 3) are the joint frames' rotations in the project frame (the fixed
    y-up to z-up turn included).
    """

    vertices: torch.Tensor
    joints: torch.Tensor
    rotations: torch.Tensor | None = None


def batch_rodrigues(axis_angle: torch.Tensor) -> torch.Tensor:
    """Rotation matrices (..., 3, 3) from axis-angle (..., 3); smooth and exact at zero angle.

    Uses sin(t)/t and (1-cos t)/t^2 with Taylor series near 0 so gradients stay finite there.
    """
    theta2 = (axis_angle * axis_angle).sum(-1, keepdim=True)
    small = theta2 < 1e-8
    t2 = torch.where(small, torch.ones_like(theta2), theta2)
    theta = torch.sqrt(t2)
    a = torch.where(small, 1.0 - theta2 / 6.0, torch.sin(theta) / theta)
    b = torch.where(small, 0.5 - theta2 / 24.0, (1.0 - torch.cos(theta)) / t2)
    K = (axis_angle @ _cross_matrix_map(axis_angle.dtype, axis_angle.device)).unflatten(-1, (3, 3))
    eye = torch.eye(3, dtype=axis_angle.dtype, device=axis_angle.device)
    return eye + a[..., None] * K + b[..., None] * (K @ K)


@functools.lru_cache(maxsize=8)
def _cross_matrix_map(dtype: torch.dtype, device: torch.device) -> torch.Tensor:
    """(3, 9): v @ this is the cross-product matrix [v]x of v (3,), row-major; its entries are
    0 and +-1, so the product is exact, and it is one operation instead of a stack of nine."""
    with torch.inference_mode(False):  # a constant first made during inference must still enter autograd
        E = torch.zeros(3, 3, 3, dtype=dtype, device=device)
        for (i, j), (k, sign) in {(0, 1): (2, -1), (0, 2): (1, 1), (1, 0): (2, 1), (1, 2): (0, -1),
                                  (2, 0): (1, -1), (2, 1): (0, 1)}.items():
            E[k, i, j] = sign
        return E.reshape(3, 9)


@functools.lru_cache(maxsize=8)
def _homogeneous_row(dtype: torch.dtype, device: torch.device) -> torch.Tensor:
    """(1, 4) the last row [0 0 0 1] of a 4 x 4 transform, made once per dtype and device (not from a
    Python list per call: on a GPU that is a blocking copy)."""
    with torch.inference_mode(False):  # usable in autograd even when first made during inference
        row = torch.zeros(1, 4, dtype=dtype, device=device)
        row[0, 3] = 1.0
        return row


def _tree_jumps(parents: list[int]) -> list[list[int]]:
    """Index tables for posing the kinematic tree (root 0) by pointer jumping: a virtual identity
    node is appended at index J (the root's parent and its own); table k holds each node's ancestor
    2^k links up (J once past the root). Composing every node's transform with that ancestor's, once
    per table, leaves each node with its world transform, in ceil(log2(depth + 1)) products of all
    joints at once, whatever the tree's shape (SMPL: 4, against 8 levels one at a time)."""
    n = len(parents)
    up = [n if j == 0 or p < 0 else p for j, p in enumerate(parents)] + [n]
    depth = [0] * n
    for j in range(1, n):
        d, p = 1, parents[j]
        while p > 0:
            d, p = d + 1, parents[p]
        depth[j] = d
    tables, span = [], 1
    while span < max(depth, default=0) + 1:  # a node's chain to the identity has depth + 1 links
        tables.append(up)
        up = [up[a] for a in up]
        span *= 2
    return tables


class BodyLayer(nn.Module):
    """Differentiable SMPL-format body model. Build with ``BodyModel(...).torch_layer()``.

    All model arrays are buffers: ``.to(device, dtype)`` moves them, nothing is trained.
    """

    def __init__(self, arrays: SmplArrays, dtype: torch.dtype = torch.float32):
        super().__init__()
        self.num_joints = arrays.num_joints
        self.num_betas = arrays.num_betas
        self.parents = [int(p) for p in arrays.parents]

        def buf(name, value):
            self.register_buffer(name, torch.as_tensor(np.asarray(value), dtype=dtype), persistent=False)

        buf("v_template", arrays.v_template)
        buf("shapedirs", arrays.shapedirs)
        # (P, V*3) row-major: a transposed view makes the pose blend product ~3x slower
        buf("posedirs", np.ascontiguousarray(arrays.posedirs.reshape(-1, arrays.posedirs.shape[2]).T))
        buf("J_regressor", arrays.J_regressor)
        buf("weights", arrays.weights)
        buf("y_up_to_z_up", Y_UP_TO_Z_UP)
        # the rest joints are linear in betas: J = J_template + J_shapedirs . betas (precomputed in
        # float64), which spares a (J, V) x (V, 3) product per pose
        jreg = np.asarray(arrays.J_regressor, dtype=np.float64)
        buf("J_template", jreg @ np.asarray(arrays.v_template, dtype=np.float64))
        buf("J_shapedirs", np.einsum("jv,vcs->jcs", jreg, np.asarray(arrays.shapedirs, dtype=np.float64)))
        self._jumps = _tree_jumps(self.parents)
        self._jump_index: dict = {}  # the jump tables as index tensors per device
        self.register_buffer("faces", torch.as_tensor(arrays.faces, dtype=torch.long), persistent=False)

    def forward(self, betas: torch.Tensor | None = None, body_pose: torch.Tensor | None = None,
                global_orient: torch.Tensor | None = None, transl: torch.Tensor | None = None,
                check: bool = True, vertices: bool = True) -> BodyOutput:
        """Pose the body. Any argument may be None (zeros); batch size from the first given.

        check: BadInput for NaN or infinite parameters, as the numpy path (PressureNet passes False
        for its own outputs, which keeps a training step free of a device sync).
        vertices: False skips the mesh (the output's vertices are None); the joints need only the
        skeleton, a small part of the work.
        """
        for name, t in (("betas", betas), ("body_pose", body_pose), ("global_orient", global_orient),
                        ("transl", transl)):
            if check and t is not None and not bool(torch.isfinite(t).all()):
                raise BadInput(f"{name} contains NaN or infinite values")
        ref = next((t for t in (betas, body_pose, global_orient, transl) if t is not None), None)
        bsz = 1 if ref is None else ref.shape[0]
        dt, dev = self.v_template.dtype, self.v_template.device

        def or_zeros(t, n):
            return torch.zeros(bsz, n, dtype=dt, device=dev) if t is None else t.to(dt)

        n_j = self.num_joints
        betas = or_zeros(betas, self.num_betas)
        body_pose = or_zeros(body_pose, 3 * (n_j - 1))
        global_orient = or_zeros(global_orient, 3)
        if betas.shape[-1] > self.num_betas:
            raise BadInput(f"betas has {betas.shape[-1]} values; this body model has {self.num_betas}")
        if body_pose.shape[-1] != 3 * (n_j - 1):
            raise BadInput(f"body_pose has {body_pose.shape[-1]} values; expected {3 * (n_j - 1)}")

        s = betas.shape[-1]
        J = self.J_template + torch.einsum("jcs,bs->bjc", self.J_shapedirs[..., :s], betas)
        pose = torch.cat([global_orient, body_pose], dim=-1).reshape(bsz, n_j, 3)
        rot = batch_rodrigues(pose)

        Rw, tw = self._kinematic_tree(rot, J)
        Q = self.y_up_to_z_up
        Rw = Q @ Rw
        joints = tw @ Q.T
        verts = self._skin(betas, rot, J, Rw, joints) if vertices else None
        if transl is not None:
            t = transl.to(dt)[:, None]
            joints = joints + t
            verts = None if verts is None else verts + t
        return BodyOutput(vertices=verts, joints=joints, rotations=Rw)

    def _jump_tensors(self, device) -> list[torch.Tensor]:
        idx = self._jump_index.get(device)
        if idx is None:
            with torch.inference_mode(False):  # made during inference, still usable in training
                idx = [torch.tensor(t, dtype=torch.long, device=device) for t in self._jumps]
            self._jump_index[device] = idx
        return idx

    def _kinematic_tree(self, rot: torch.Tensor, J: torch.Tensor) -> tuple[torch.Tensor, torch.Tensor]:
        """World rotations (B, J, 3, 3) and positions (B, J, 3) of the joints (y-up) from their
        local rotations rot (B, J, 3, 3) and rest positions J (B, J, 3), by pointer jumping
        (:func:`_tree_jumps`): a few products of all joints at once instead of one per tree level,
        so a training step dispatches far fewer small operations (a GPU step is dispatch-bound)."""
        jumps = self._jump_tensors(rot.device)
        b, n = rot.shape[:2]
        if not jumps:
            return rot, J
        # homogeneous 4 x 4 transforms, one composition a product; node n: the identity at the origin
        t = torch.cat([J, J.new_zeros(b, 1, 3)], 1)
        t = t - t.index_select(1, jumps[0])  # each joint from its parent (the root from the origin)
        R = torch.cat([rot, torch.eye(3, dtype=rot.dtype, device=rot.device).expand(b, 1, 3, 3)], 1)
        bottom = _homogeneous_row(rot.dtype, rot.device).expand(b, n + 1, 1, 4)
        T = torch.cat([torch.cat([R, t[..., None]], -1), bottom], -2)
        for up in jumps:  # each node's transform from the ancestor 2^k links up, then from twice as far
            T = T.index_select(1, up) @ T
        return T[:, :n, :3, :3], T[:, :n, :3, 3]

    def _skin(self, betas, rot, J, Rw, joints) -> torch.Tensor:
        """Vertices (B, V, 3), z-up, before the translation: shape and pose blend shapes, then
        linear blend skinning with the joints' world rotations Rw (z-up) at ``joints``."""
        bsz, n_j = rot.shape[:2]
        v_shaped = self.v_template + torch.einsum("vcs,bs->bvc", self.shapedirs[..., :betas.shape[-1]], betas)
        eye = torch.eye(3, dtype=rot.dtype, device=rot.device)
        pose_feature = (rot[:, 1:] - eye).reshape(bsz, -1)
        v_posed = v_shaped + (pose_feature @ self.posedirs).reshape(bsz, -1, 3)
        t_skin = joints - (Rw @ J[..., None])[..., 0]
        # blend the joints' transforms [R | t] with the skinning weights in one product
        T = self.weights @ torch.cat([Rw.reshape(bsz, n_j, 9), t_skin], -1)  # (B, V, 12)
        return torch.einsum("bvcd,bvd->bvc", T[..., :9].reshape(bsz, -1, 3, 3), v_posed) + T[..., 9:]
