"""Rotation helpers shared by every kinematic family (pure numpy, batch-first)."""

from __future__ import annotations

import numpy as np
import numpy.typing as npt

Array = npt.NDArray[np.float64]


def wrap_angle(angle: Array) -> Array:
    """Angles (rad) wrapped to [-pi, pi)."""
    return (angle + np.pi) % (2.0 * np.pi) - np.pi


def snap_unit(value: float) -> float:
    """``value`` with rounding noise removed around 0 and +-1 (cos(pi/2) is 6e-17, not 0)."""
    for exact in (0.0, 1.0, -1.0):
        if abs(value - exact) < 1e-15:
            return exact
    return value


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


def _shepperd_map() -> tuple[Array, Array]:
    """Linear map from the 9 matrix entries to Shepperd's 4 candidate quaternions (x, y, z, w)."""
    # Each candidate is (sign, i, j) terms of m[i, j] plus a constant; candidate k
    # is the one to use when its k-th "diagonal" term (4 q_k^2) is the largest.
    terms = [
        [
            [(1, 2, 1), (-1, 1, 2)],
            [(1, 0, 2), (-1, 2, 0)],
            [(1, 1, 0), (-1, 0, 1)],
            [(1, 0, 0), (1, 1, 1), (1, 2, 2)],
        ],
        [
            [(1, 0, 0), (-1, 1, 1), (-1, 2, 2)],
            [(1, 0, 1), (1, 1, 0)],
            [(1, 0, 2), (1, 2, 0)],
            [(1, 2, 1), (-1, 1, 2)],
        ],
        [
            [(1, 0, 1), (1, 1, 0)],
            [(-1, 0, 0), (1, 1, 1), (-1, 2, 2)],
            [(1, 1, 2), (1, 2, 1)],
            [(1, 0, 2), (-1, 2, 0)],
        ],
        [
            [(1, 0, 2), (1, 2, 0)],
            [(1, 1, 2), (1, 2, 1)],
            [(-1, 0, 0), (-1, 1, 1), (1, 2, 2)],
            [(1, 1, 0), (-1, 0, 1)],
        ],
    ]
    linear, constant = np.zeros((9, 16)), np.zeros(16)
    for k, candidate in enumerate(terms):
        for c, component in enumerate(candidate):
            for sign, i, j in component:
                linear[3 * i + j, 4 * k + c] += sign
    for col in (3, 4, 9, 14):  # the "1 +" of each candidate's diagonal term
        constant[col] = 1.0
    return linear, constant


_SHEPPERD_LINEAR, _SHEPPERD_CONSTANT = _shepperd_map()
_DIAGONAL_COLUMNS = np.array([3, 4, 9, 14])
"""Where each candidate's leading term (4 q_k^2) sits among the 16 candidate numbers."""


def _quat_rows(rot: Array) -> Array:
    """Quaternions (n, 4) from rotation matrices flattened to rows (n, 9): Shepperd's method.

    Of four candidate formulas, each row uses the one whose leading term is
    largest, so no square root sees a small argument. The candidates are linear
    in the matrix entries, hence one matrix product. This runs for every link of
    every frame, mostly on a handful of matrices, so it is written for few
    numpy calls rather than for clarity of the formula.
    """
    n = rot.shape[0]
    cand = rot @ _SHEPPERD_LINEAR
    cand += _SHEPPERD_CONSTANT
    pick = cand[:, _DIAGONAL_COLUMNS].argmax(axis=1)
    q: Array = cand.reshape(n, 4, 4)[np.arange(n), pick]
    q *= (np.copysign(1.0, q[:, 3]) / np.sqrt(np.einsum("ij,ij->i", q, q)))[:, None]
    return q


def quat_xyzw_from_matrix(rot: Array) -> Array:
    """Unit quaternions (x, y, z, w), w >= 0, from rotation matrices ``(..., 3, 3)``."""
    m = np.asarray(rot, dtype=np.float64)
    return _quat_rows(m.reshape(-1, 9)).reshape(m.shape[:-2] + (4,))


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
    flat = p.reshape(-1, 4, 4)
    out = np.empty((flat.shape[0], 7))
    out[:, :3] = flat[:, :3, 3]
    out[:, 3:] = _quat_rows(flat[:, :3, :3].reshape(-1, 9))
    return out.reshape(p.shape[:-2] + (7,))


def matrix_from_pose7(pose7: Array) -> Array:
    """4x4 poses from the wire form [x, y, z, qx, qy, qz, qw]."""
    p = np.asarray(pose7, dtype=np.float64)
    out = np.zeros(p.shape[:-1] + (4, 4))
    out[..., :3, :3] = matrix_from_quat_xyzw(p[..., 3:])
    out[..., :3, 3] = p[..., :3]
    out[..., 3, 3] = 1.0
    return out
