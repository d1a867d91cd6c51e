"""Kinematics: pure numpy, batch-first, SI units (m, rad); no I/O, no asyncio.

Every ``forward``, ``link_poses`` and ``inverse`` takes inputs batched over
leading axes and returns ``(values, ok)`` with ``ok`` a boolean array over them.
"""

from ._pose_vector import matrix_from_pose_vector, pose_vector_from_matrix
from ._rotations import (
    matrix_from_pose7,
    matrix_from_quat_xyzw,
    pose7_from_matrix,
    quat_xyzw_from_matrix,
)
from .axis_group import WorldModel
from .axis_group_ik import serial_rotary_inverse
from .calibration import (
    LinearCalibration,
    RotaryCalibration,
    calibrate_linear_axis,
    calibrate_rotary_axis,
)
from .dh import DHChain
from .iiwa import IiwaSolutions, LBRiiwa, iiwa7
from .motion import SpeedMove, TrapezoidMove, plan_movej, plan_speedj
from .rpy import matrix_from_rpy, rpy_from_matrix
from .type12 import Type12, circle_circle_intersection
from .urdf import UrdfChain, UrdfJoint, UrdfMimic, UrdfTree

__all__ = [
    "DHChain",
    "IiwaSolutions",
    "LBRiiwa",
    "iiwa7",
    "matrix_from_rpy",
    "rpy_from_matrix",
    "LinearCalibration",
    "RotaryCalibration",
    "SpeedMove",
    "TrapezoidMove",
    "Type12",
    "WorldModel",
    "calibrate_linear_axis",
    "calibrate_rotary_axis",
    "circle_circle_intersection",
    "matrix_from_pose_vector",
    "plan_movej",
    "plan_speedj",
    "pose_vector_from_matrix",
    "matrix_from_pose7",
    "matrix_from_quat_xyzw",
    "pose7_from_matrix",
    "quat_xyzw_from_matrix",
    "serial_rotary_inverse",
    "UrdfChain",
    "UrdfJoint",
    "UrdfMimic",
    "UrdfTree",
]
