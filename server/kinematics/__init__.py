"""Kinematics: pure numpy, batch-first, SI units (m, rad); no I/O, no asyncio.

Every ``forward``, ``link_poses`` and ``inverse`` takes inputs batched over
leading axes and returns ``(values, ok)`` with ``ok`` a boolean array over them.

One family per module or package: ``dh/`` (Denavit-Hartenberg chains, the
KUKA LBR iiwa), ``urdf/`` (URDF joint trees), ``type12``, ``axis_group``;
shared helpers are the ``_``-prefixed modules here (``_numeric_ik`` is the
damped-least-squares inverse that every serial family falls back on).
Reading URDF files and meshes is ``server.urdf``'s job, not this package's.
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
from .configurations import configuration_names
from .dh import DHChain, IiwaSolutions, LBRiiwa, iiwa7
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
    "configuration_names",
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
