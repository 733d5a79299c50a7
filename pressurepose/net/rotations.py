"""The body's root rotation as three Euler angles in the bed frame, and its SMPL axis-angle.

Convention (bed frame: x across the bed, y along it toward the foot, z up), angles (roll, pitch,
yaw) in radians; the body's world rotation is

    W = R_z(yaw) @ R_x(pitch) @ R_y(-roll) @ W0

W0 lays the standing rest body (z-up, facing -y) supine with its head at row 0: it maps
x -> -x, y -> -z, z -> -y (180 deg about (0, 1, -1)/sqrt 2). ``roll`` is a right-handed turn about
the body's head direction -y (0 supine, +pi/2 on the left side, -pi/2 on the right side, +-pi
prone), ``pitch`` tilts the head up or down, ``yaw`` turns the body in the bed's plane
(counter-clockwise seen from above). With pitch 0 this is exactly the pose sampler's (roll, yaw)
(:mod:`pressurepose.pose.root`). The middle angle is the pitch, which is 0 in the data (the paper's
public code, Healthcare-Robotics/bodies-at-rest, samples none), so the convention is far from its
gimbal lock at pitch = +-pi/2.

SMPL's root parameter r rotates the y-up model; the body layer turns its output by the fixed
Q = Y_UP_TO_Z_UP, so R(r) = Q^T W Q. Everything goes through unit quaternions (w, x, y, z) and is
differentiable, including at rotation angles of pi (prone bodies).
"""

from __future__ import annotations

import math

import torch

_S = math.sqrt(0.5)
Q_W0 = (0.0, 0.0, _S, -_S)       # W0: 180 deg about (0, 1, -1) / sqrt 2
Q_Y_UP_TO_Z_UP = (_S, _S, 0.0, 0.0)  # +90 deg about x


def quat_mul(a: torch.Tensor, b: torch.Tensor) -> torch.Tensor:
    """Hamilton product of quaternions (..., 4) in (w, x, y, z) order."""
    aw, ax, ay, az = a.unbind(-1)
    bw, bx, by, bz = b.unbind(-1)
    return torch.stack([aw * bw - ax * bx - ay * by - az * bz,
                        aw * bx + ax * bw + ay * bz - az * by,
                        aw * by - ax * bz + ay * bw + az * bx,
                        aw * bz + ax * by - ay * bx + az * bw], -1)


def _axis_quat(angle: torch.Tensor, axis: int) -> torch.Tensor:
    half = 0.5 * angle
    zero = torch.zeros_like(half)
    parts = [torch.cos(half), zero, zero, zero]
    parts[1 + axis] = torch.sin(half)
    return torch.stack(parts, -1)


def quat_to_axis_angle(q: torch.Tensor) -> torch.Tensor:
    """Axis-angle (..., 3) of unit quaternions (..., 4); angle in [0, pi]; smooth at angle 0."""
    q = torch.where(q[..., :1] < 0, -q, q)
    w, v = q[..., 0], q[..., 1:]
    n = torch.linalg.vector_norm(v, dim=-1)
    small = n < 1e-6
    n_safe = torch.where(small, torch.ones_like(n), n)
    w_safe = torch.where(small, w, torch.ones_like(w))  # w ~ 1 where the angle is small
    factor = torch.where(small, 2.0 / w_safe - (2.0 / 3.0) * n * n / w_safe ** 3,
                         2.0 * torch.atan2(n, w) / n_safe)
    return v * factor[..., None]


def axis_angle_to_quat(aa: torch.Tensor) -> torch.Tensor:
    """Unit quaternions (..., 4) (w, x, y, z) of axis-angle vectors (..., 3); smooth at angle 0."""
    angle = torch.linalg.vector_norm(aa, dim=-1, keepdim=True)
    half = 0.5 * angle
    small = angle < 1e-6
    # sin(a/2)/a -> 1/2 - a^2/48 near 0
    factor = torch.where(small, 0.5 - angle * angle / 48.0, torch.sin(half) / torch.where(small, torch.ones_like(angle), angle))
    return torch.cat([torch.cos(half), aa * factor], -1)


def euler_to_world_quat(euler: torch.Tensor) -> torch.Tensor:
    """Quaternion (..., 4) of W for bed-frame Euler angles (..., 3) = (roll, pitch, yaw)."""
    roll, pitch, yaw = euler.unbind(-1)
    q0 = torch.tensor(Q_W0, dtype=euler.dtype, device=euler.device).expand(roll.shape + (4,))
    q = quat_mul(_axis_quat(-roll, 1), q0)
    q = quat_mul(_axis_quat(pitch, 0), q)
    return quat_mul(_axis_quat(yaw, 2), q)


def _right_product_matrix(c: tuple[float, ...]) -> torch.Tensor:
    """The 4 x 4 matrix M (float64) with q (x) c = q @ M for quaternions q (row vectors)."""
    eye = torch.eye(4, dtype=torch.float64)
    return quat_mul(eye, torch.tensor(c, dtype=torch.float64).expand(4, 4))


def _conjugated_w0() -> tuple[float, ...]:
    qq = torch.tensor(Q_Y_UP_TO_Z_UP, dtype=torch.float64)
    qq_inv = qq * torch.tensor([1.0, -1.0, -1.0, -1.0], dtype=torch.float64)
    return tuple(quat_mul(quat_mul(qq_inv, torch.tensor(Q_W0, dtype=torch.float64)), qq).tolist())


# Q^-1 W Q = Q^-1 R_z(yaw) Q . Q^-1 R_x(pitch) Q . Q^-1 R_y(-roll) Q . Q^-1 W0 Q, and Q^-1 turns
# z into y and y into -z: R_y(yaw) R_x(pitch) R_z(roll) (Q^-1 W0 Q), the last factor a constant
_ROOT_RIGHT = _right_product_matrix(_conjugated_w0())


def euler_to_root_axis_angle(euler: torch.Tensor) -> torch.Tensor:
    """SMPL root axis-angle r (..., 3) with Q R(r) Q^T = W(roll, pitch, yaw); euler (..., 3).

    Written out for speed (it runs twice per PressureNet call): the quaternion of
    R_y(yaw) R_x(pitch) R_z(roll) in closed form, times a precomputed constant."""
    half = 0.5 * euler
    c, s = torch.cos(half), torch.sin(half)
    cr, cp, cy = c.unbind(-1)
    sr, sp, sy = s.unbind(-1)
    w, x, y, z = cy * cp, cy * sp, sy * cp, -sy * sp  # R_y(yaw) R_x(pitch)
    q = torch.stack([w * cr - z * sr, x * cr + y * sr, y * cr - x * sr, w * sr + z * cr], -1)  # ... R_z(roll)
    return quat_to_axis_angle(q @ _ROOT_RIGHT.to(dtype=euler.dtype, device=euler.device))


def pairs_to_euler(pairs: torch.Tensor) -> torch.Tensor:
    """Euler angles (..., 3) from the network's 3 (x, y) pairs laid out as (x_u, x_v, x_w, y_u,
    y_v, y_w) (..., 6): angle_k = atan2(y_k, x_k)."""
    return torch.atan2(pairs[..., 3:6], pairs[..., 0:3])
