"""UR pose vectors ``[x, y, z, rx, ry, rz]`` <-> 4x4 homogeneous poses (batch-first).

A pose vector is a translation in metres followed by a rotation vector
(axis-angle, radians): the rotation turns by ``|r|`` about the unit axis
``r / |r|``. This is the ``p[x, y, z, rx, ry, rz]`` convention of URScript and
MotionPlus. ``pose_vector_from_matrix`` returns angles in ``[0, pi]``; at
exactly ``pi`` the rotation vectors ``r`` and ``-r`` are the same rotation and
either may come back.
"""

from __future__ import annotations

import numpy as np
import numpy.typing as npt

from ._rotations import quat_xyzw_from_matrix

Array = npt.NDArray[np.float64]

# Below these, the closed forms lose digits to cancellation; the Taylor series
# are exact to double precision there (the next term is below 1e-24).
_SMALL_ANGLE = 1e-4
_SMALL_SINE = 1e-6


def rotation_from_rotvec(rotvec: npt.ArrayLike) -> Array:
    """Rotation matrices ``(..., 3, 3)`` from rotation vectors ``(..., 3)`` (rad).

    Rodrigues' formula ``R = I + (sin t / t) K + ((1 - cos t) / t^2) K^2`` with
    ``K`` the cross-product matrix of ``r`` and ``t = |r|``; series near 0.
    """
    r = np.asarray(rotvec, dtype=np.float64)
    theta = np.linalg.norm(r, axis=-1)
    small = theta < _SMALL_ANGLE
    t = np.where(small, 1.0, theta)
    t2 = theta * theta
    sinc = np.where(small, 1.0 - t2 / 6.0 + t2 * t2 / 120.0, np.sin(t) / t)
    cosc = np.where(small, 0.5 - t2 / 24.0 + t2 * t2 / 720.0, (1.0 - np.cos(t)) / (t * t))
    x, y, z = r[..., 0], r[..., 1], r[..., 2]
    out = np.empty(r.shape[:-1] + (3, 3))
    # K^2 = r r^T - |r|^2 I, written out per element.
    out[..., 0, 0] = 1.0 - cosc * (y * y + z * z)
    out[..., 1, 1] = 1.0 - cosc * (x * x + z * z)
    out[..., 2, 2] = 1.0 - cosc * (x * x + y * y)
    out[..., 0, 1] = cosc * x * y - sinc * z
    out[..., 1, 0] = cosc * x * y + sinc * z
    out[..., 0, 2] = cosc * x * z + sinc * y
    out[..., 2, 0] = cosc * x * z - sinc * y
    out[..., 1, 2] = cosc * y * z - sinc * x
    out[..., 2, 1] = cosc * y * z + sinc * x
    return out


def rotvec_from_rotation(rot: npt.ArrayLike) -> Array:
    """Rotation vectors ``(..., 3)`` (rad, angle in ``[0, pi]``) of rotations ``(..., 3, 3)``.

    Goes through the unit quaternion (Shepperd's method, ``w >= 0``), which stays
    accurate near ``pi`` where ``acos((trace - 1) / 2)`` would not.
    """
    quat = quat_xyzw_from_matrix(np.asarray(rot, dtype=np.float64))
    v, w = quat[..., :3], quat[..., 3]
    s = np.linalg.norm(v, axis=-1)
    small = s < _SMALL_SINE
    safe_s = np.where(small, 1.0, s)
    safe_w = np.where(small, w, 1.0)
    # angle / sin(angle / 2) -> 2 / w * (1 - s^2 / (3 w^2)) as s -> 0.
    scale = np.where(
        small,
        2.0 / safe_w * (1.0 - s * s / (3.0 * safe_w * safe_w)),
        2.0 * np.arctan2(s, w) / safe_s,
    )
    result: Array = v * scale[..., None]
    return result


def matrix_from_pose_vector(pose: npt.ArrayLike) -> Array:
    """4x4 poses ``(..., 4, 4)`` of UR pose vectors ``(..., 6)``: [x, y, z] m, [rx, ry, rz] rad."""
    p = np.asarray(pose, dtype=np.float64)
    if p.ndim == 0 or p.shape[-1] != 6:
        raise ValueError(f"a pose vector has 6 elements [x, y, z, rx, ry, rz], got shape {p.shape}")
    out = np.zeros(p.shape[:-1] + (4, 4))
    out[..., :3, :3] = rotation_from_rotvec(p[..., 3:])
    out[..., :3, 3] = p[..., :3]
    out[..., 3, 3] = 1.0
    return out


def pose_vector_from_matrix(matrix: npt.ArrayLike) -> Array:
    """UR pose vectors ``(..., 6)`` ([x, y, z] m, [rx, ry, rz] rad) of 4x4 poses ``(..., 4, 4)``."""
    m = np.asarray(matrix, dtype=np.float64)
    if m.ndim < 2 or m.shape[-2:] != (4, 4):
        raise ValueError(f"a pose matrix has shape (..., 4, 4), got {m.shape}")
    return np.concatenate([m[..., :3, 3], rotvec_from_rotation(m[..., :3, :3])], axis=-1)
