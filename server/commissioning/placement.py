"""Where a robot stands, from numbers or from a calibrated frame (4x4 poses, m, rad; numpy only).

A calibration (``server.kinematics.calibrate_rotary_axis`` / ``_linear_axis``)
gives a frame in the measuring robot's base frame, as MotionPlus does: origin
on the axis, +Z along it, +X towards the first sample. The frame is that of a
link of the robot being placed (an axis of an axis group, or its base) at the
joint values it had when the first sample was taken; so the robot's base in the
cell is ``frame_world @ inv(link(q))``. For an axis of an axis group, the
frame can instead become the axis's zero-position pose in its parent (as
``axis_group_update_axis(name, pose=...)`` takes it): ``inv(parent(q)) @
frame @ inv(motion(q_axis))``.
"""

from __future__ import annotations

from typing import Any

import numpy as np
import numpy.typing as npt

from ..cell import Robot
from ..kinematics import (
    matrix_from_pose7,
    matrix_from_pose_vector,
    matrix_from_rpy,
    pose_vector_from_matrix,
    rpy_from_matrix,
)
from ..kinematics._rotations import rot_z
from .errors import CommissioningError

Array = npt.NDArray[np.float64]


def base_matrix(robot: Robot) -> Array:
    """``robot``'s base in the cell (world frame, 4x4)."""
    return matrix_from_pose7(np.asarray(robot.base, dtype=np.float64))


def cell_pose(matrix: Array) -> tuple[list[float], list[float]]:
    """A 4x4 pose as a cell file writes it: ``xyz`` (mm) and ``rpy_deg`` (fixed X, Y, Z)."""
    xyz = (np.asarray(matrix)[:3, 3] * 1000.0).tolist()
    rpy = np.degrees(rpy_from_matrix(np.asarray(matrix)[:3, :3])).tolist()
    return xyz, rpy


def pose_from_xyz_rpy(xyz_m: list[float], rpy_rad: list[float]) -> Array:
    """4x4 pose from a translation (m) and fixed-axis roll, pitch, yaw (rad)."""
    matrix = np.eye(4)
    matrix[:3, :3] = matrix_from_rpy(np.asarray(rpy_rad, dtype=np.float64))
    matrix[:3, 3] = xyz_m
    return matrix


def tcp_now(robot: Robot, q: Array) -> tuple[list[float], list[float]]:
    """``robot``'s TCP at joints ``q`` (SI) as UR pose vectors: in its base frame, in the cell.

    The first is what MotionPlus samples (``get_actual_tcp_pose()``).
    """
    _, tcp, ok = robot.poses(np.asarray(q, dtype=np.float64))
    if not bool(ok):
        raise CommissioningError(409, f"{robot.name} has no pose at its joint values now")
    in_base = pose_vector_from_matrix(tcp)
    in_world = pose_vector_from_matrix(base_matrix(robot) @ tcp)
    return in_base.tolist(), in_world.tolist()


def _link_poses(robot: Robot, q: Array) -> Array:
    values = np.asarray(q, dtype=np.float64)
    if values.shape != (len(robot.joints),) or not np.isfinite(values).all():
        raise CommissioningError(
            422, f"{robot.name} needs {len(robot.joints)} finite joint values (SI)"
        )
    links, _, ok = robot.poses(values)
    if not bool(ok):
        raise CommissioningError(422, f"{robot.name} has no pose at the sampled joint values")
    return links


def axis_link(robot: Robot, axis: str | None) -> tuple[int, dict[str, Any] | None]:
    """The link index of axis ``axis`` of an axis group, with its parameters (None: the base)."""
    if axis is None:
        return 0, None
    axes = robot.kinematics.params().get("axes") if robot.family == "axis_group" else None
    names = [a["name"] for a in axes or []]
    if axis not in names or axes is None:
        raise CommissioningError(422, f"{robot.name} has no axis {axis!r}")
    return 1 + names.index(axis), axes[names.index(axis)]


def frame_in_world(measuring: Robot, frame: list[float]) -> Array:
    """A frame given in ``measuring``'s base frame (UR pose vector) in the cell's frame."""
    return base_matrix(measuring) @ matrix_from_pose_vector(np.asarray(frame, dtype=np.float64))


def placed_base(robot: Robot, frame_world: Array, axis: str | None, q: Array) -> Array:
    """The base that puts ``robot``'s ``axis`` frame (None: its base) on ``frame_world``
    when its joints are at ``q`` (SI, the values when the first sample was taken)."""
    link, _ = axis_link(robot, axis)
    links = _link_poses(robot, q)
    placed: Array = frame_world @ np.linalg.inv(links[link])
    return placed


def axis_zero_pose(robot: Robot, axis: str, frame_world: Array, q: Array) -> Array:
    """The zero-position pose, in its parent frame, that puts ``axis`` on ``frame_world``
    at joints ``q`` (SI); ``robot``'s base stays where it is."""
    link, params = axis_link(robot, axis)
    assert params is not None
    links = _link_poses(robot, q)
    parent = params["parent"]
    names = [a["name"] for a in robot.kinematics.params()["axes"]]
    parent_link = links[1 + names.index(parent)] if parent else _group_frame(robot)
    value = float(np.asarray(q, dtype=np.float64)[link - 1])
    motion = np.eye(4)
    if params["type"] == 0:
        motion[:3, :3] = rot_z(np.asarray(value))
    else:
        motion[2, 3] = value
    in_base = np.linalg.inv(base_matrix(robot)) @ frame_world
    pose: Array = np.linalg.inv(parent_link) @ in_base @ np.linalg.inv(motion)
    return pose


def _group_frame(robot: Robot) -> Array:
    """The axis group's base frame in the robot's base frame (its ``kinematics.pose``)."""
    return matrix_from_pose_vector(np.asarray(robot.kinematics.params()["pose"], dtype=float))
