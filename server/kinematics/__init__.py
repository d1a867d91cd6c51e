"""Kinematics: pure numpy, batch-first, SI units (m, rad); no I/O, no asyncio.

Every ``forward``, ``link_poses`` and ``inverse`` takes inputs batched over
leading axes and returns ``(values, ok)`` with ``ok`` a boolean array over them.
"""

from ._rotations import (
    matrix_from_pose7,
    matrix_from_quat_xyzw,
    pose7_from_matrix,
    quat_xyzw_from_matrix,
)
from .type12 import Type12, circle_circle_intersection

__all__ = [
    "Type12",
    "circle_circle_intersection",
    "matrix_from_pose7",
    "matrix_from_quat_xyzw",
    "pose7_from_matrix",
    "quat_xyzw_from_matrix",
]
