"""Roll, pitch and yaw angles (the KUKA LBR arm tutorial's formulas [8] and [9]), batch-first.

Convention: ``rpy = (roll, pitch, yaw)`` in radians, rotations about the fixed
X, Y and Z axes in that order, so ``R = Rz(yaw) Ry(pitch) Rx(roll)`` (the same
matrix as intrinsic Z, Y', X''). Frame-free: the matrix maps the rotated
frame's coordinates into the reference frame's.
"""

from __future__ import annotations

import numpy as np
import numpy.typing as npt

Array = npt.NDArray[np.float64]

# Below this cos(pitch) the matrix is treated as gimbal-locked (pitch = +-90 deg).
# Near it both branches reproduce the matrix to about 2e-8: the locked one
# drops cos(pitch), the general one divides rounding noise by it.
GIMBAL_LOCK_COS = 1e-8


def matrix_from_rpy(rpy: npt.ArrayLike) -> Array:
    """Rotation matrices ``(..., 3, 3)`` from angles ``(..., 3)`` (rad), formula [8]."""
    angles = np.asarray(rpy, dtype=np.float64)
    cr, cp, cy = np.cos(angles[..., 0]), np.cos(angles[..., 1]), np.cos(angles[..., 2])
    sr, sp, sy = np.sin(angles[..., 0]), np.sin(angles[..., 1]), np.sin(angles[..., 2])
    out = np.empty(angles.shape[:-1] + (3, 3))
    out[..., 0, 0] = cy * cp
    out[..., 0, 1] = cy * sp * sr - sy * cr
    out[..., 0, 2] = cy * sp * cr + sy * sr
    out[..., 1, 0] = sy * cp
    out[..., 1, 1] = sy * sp * sr + cy * cr
    out[..., 1, 2] = sy * sp * cr - cy * sr
    out[..., 2, 0] = -sp
    out[..., 2, 1] = cp * sr
    out[..., 2, 2] = cp * cr
    return out


def rpy_from_matrix(rot: npt.ArrayLike) -> Array:
    """Angles ``(..., 3)`` = (roll, pitch, yaw) rad of rotations ``(..., 3, 3)``, formula [9].

    Pitch is in [-pi/2, pi/2], roll and yaw in [-pi, pi]. At pitch = +-90 deg
    only yaw -/+ roll is defined; as in the tutorial, roll is then 0 and yaw
    carries the whole turn. (The tutorial's +90 deg branch drops the sign of yaw;
    this one keeps the matrix: ``matrix_from_rpy(rpy_from_matrix(R)) == R``.)
    """
    m = np.asarray(rot, dtype=np.float64)
    cos_pitch = np.hypot(m[..., 0, 0], m[..., 1, 0])
    locked = cos_pitch < GIMBAL_LOCK_COS
    pitch = np.arctan2(-m[..., 2, 0], np.where(locked, 0.0, cos_pitch))
    # At +-90 deg, m01 = -sin(yaw -/+ roll) and m11 = cos(yaw -/+ roll).
    locked_yaw = -np.arctan2(m[..., 0, 1], m[..., 1, 1])
    roll = np.where(locked, 0.0, np.arctan2(m[..., 2, 1], m[..., 2, 2]))
    yaw = np.where(locked, locked_yaw, np.arctan2(m[..., 1, 0], m[..., 0, 0]))
    return np.stack([roll, pitch, yaw], axis=-1)
