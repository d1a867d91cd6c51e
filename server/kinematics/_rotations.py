"""Rotation helpers shared by every kinematic family (pure numpy, batch-first)."""

from __future__ import annotations

import numpy as np
import numpy.typing as npt

Array = npt.NDArray[np.float64]


def rot_z(angle: Array) -> Array:
    """3x3 rotations about +Z by ``angle`` (rad), shape ``angle.shape + (3, 3)``."""
    c, s = np.cos(angle), np.sin(angle)
    out = np.zeros(np.shape(angle) + (3, 3))
    out[..., 0, 0] = c
    out[..., 0, 1] = -s
    out[..., 1, 0] = s
    out[..., 1, 1] = c
    out[..., 2, 2] = 1.0
    return out


def planar_poses(xy: Array, heading: Array) -> Array:
    """4x4 poses in the base XY plane (z = 0), at ``xy`` (m) and turned by ``heading`` (rad)."""
    pose = np.zeros(np.shape(heading) + (4, 4))
    pose[..., :3, :3] = rot_z(heading)
    pose[..., :2, 3] = xy
    pose[..., 3, 3] = 1.0
    return pose


def quat_xyzw_from_matrix(rot: Array) -> Array:
    """Unit quaternions (x, y, z, w), w >= 0, from rotation matrices ``(..., 3, 3)``.

    Shepperd's method: branch per element on the largest diagonal term so the
    square root never sees a small argument.
    """
    m = np.asarray(rot, dtype=np.float64)
    m00, m11, m22 = m[..., 0, 0], m[..., 1, 1], m[..., 2, 2]
    trace = m00 + m11 + m22
    cand = np.stack(
        [
            np.stack(
                [
                    m[..., 2, 1] - m[..., 1, 2],
                    m[..., 0, 2] - m[..., 2, 0],
                    m[..., 1, 0] - m[..., 0, 1],
                    1.0 + trace,
                ],
                -1,
            ),
            np.stack(
                [
                    1.0 + m00 - m11 - m22,
                    m[..., 0, 1] + m[..., 1, 0],
                    m[..., 0, 2] + m[..., 2, 0],
                    m[..., 2, 1] - m[..., 1, 2],
                ],
                -1,
            ),
            np.stack(
                [
                    m[..., 0, 1] + m[..., 1, 0],
                    1.0 - m00 + m11 - m22,
                    m[..., 1, 2] + m[..., 2, 1],
                    m[..., 0, 2] - m[..., 2, 0],
                ],
                -1,
            ),
            np.stack(
                [
                    m[..., 0, 2] + m[..., 2, 0],
                    m[..., 1, 2] + m[..., 2, 1],
                    1.0 - m00 - m11 + m22,
                    m[..., 1, 0] - m[..., 0, 1],
                ],
                -1,
            ),
        ],
        -2,
    )
    pick = np.argmax(np.stack([trace, m00, m11, m22], -1), axis=-1)
    q = np.take_along_axis(cand, pick[..., None, None], axis=-2)[..., 0, :]
    q /= np.linalg.norm(q, axis=-1, keepdims=True)
    return np.where(q[..., 3:4] < 0.0, -q, q)


def matrix_from_quat_xyzw(quat: Array) -> Array:
    """Rotation matrices ``(..., 3, 3)`` from quaternions (x, y, z, w); normalises first."""
    q = np.asarray(quat, dtype=np.float64)
    q = q / np.linalg.norm(q, axis=-1, keepdims=True)
    x, y, z, w = q[..., 0], q[..., 1], q[..., 2], q[..., 3]
    out = np.empty(q.shape[:-1] + (3, 3))
    out[..., 0, 0] = 1 - 2 * (y * y + z * z)
    out[..., 0, 1] = 2 * (x * y - z * w)
    out[..., 0, 2] = 2 * (x * z + y * w)
    out[..., 1, 0] = 2 * (x * y + z * w)
    out[..., 1, 1] = 1 - 2 * (x * x + z * z)
    out[..., 1, 2] = 2 * (y * z - x * w)
    out[..., 2, 0] = 2 * (x * z - y * w)
    out[..., 2, 1] = 2 * (y * z + x * w)
    out[..., 2, 2] = 1 - 2 * (x * x + y * y)
    return out


def pose7_from_matrix(pose: Array) -> Array:
    """Wire form [x, y, z, qx, qy, qz, qw] (m, unit quaternion) of 4x4 poses ``(..., 4, 4)``."""
    p = np.asarray(pose, dtype=np.float64)
    return np.concatenate([p[..., :3, 3], quat_xyzw_from_matrix(p[..., :3, :3])], axis=-1)


def matrix_from_pose7(pose7: Array) -> Array:
    """4x4 poses from the wire form [x, y, z, qx, qy, qz, qw]."""
    p = np.asarray(pose7, dtype=np.float64)
    out = np.zeros(p.shape[:-1] + (4, 4))
    out[..., :3, :3] = matrix_from_quat_xyzw(p[..., 3:])
    out[..., :3, 3] = p[..., :3]
    out[..., 3, 3] = 1.0
    return out
