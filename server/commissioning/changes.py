"""The changes the page makes to a cell, as the API takes them (SI units), and how each is made.

Each change names its robot by name and its joint by the name ``hello`` gives
it. Lengths are metres and angles radians here, as everywhere in the API; the
file gets millimetres and degrees (``server.cell.edit``). A joint's ``scale``
and ``offset`` are the cell's own (``offset`` in the node's unit).
"""

from __future__ import annotations

from collections.abc import Callable, Mapping
from pathlib import Path
from typing import Annotated, Literal

import numpy as np
import numpy.typing as npt
from pydantic import BaseModel, ConfigDict, Field

from ..cell import Cell, Robot
from ..cell.edit import CellText
from ..cell.robot import UNIT_SCALE
from . import placement
from .descriptions import Catalog
from .errors import CommissioningError

Finite = Annotated[float, Field(allow_inf_nan=False)]
Vec3 = Annotated[list[Finite], Field(min_length=3, max_length=3)]
Name = Annotated[str, Field(min_length=1, max_length=200)]


class _Change(BaseModel):
    model_config = ConfigDict(extra="forbid", strict=True)

    robot: Name


class JointMapping(_Change):
    """A joint's mapping: ``scale`` (its sign too), ``offset`` (node unit), ``unit``."""

    op: Literal["joint"]
    joint: Name
    scale: Finite | None = None
    offset: Finite | None = None
    unit: Literal["deg", "rad", "mm", "m"] | None = None


class JointReads(_Change):
    """ "This joint reads ``value`` (rad or m) now": the offset that makes it so."""

    op: Literal["joint_reads"]
    joint: Name
    value: Finite


class Base(_Change):
    """Where the robot stands: ``xyz`` (m), fixed-axis roll, pitch, yaw ``rpy`` (rad)."""

    op: Literal["base"]
    xyz: Vec3
    rpy: Vec3


class AxisPose(_Change):
    """An axis's zero-position pose in its parent: ``xyz`` (m), ``rpy`` (rad)."""

    op: Literal["axis_pose"]
    axis: Name
    xyz: Vec3
    rpy: Vec3


class Calibrated(_Change):
    """A calibrated frame (``POST /api/calibrate``'s ``pose``, in ``measured_by``'s base
    frame) made the frame of ``axis`` (None: the robot's base) at ``joints`` (SI, the
    robot's joints when the first sample was taken): by moving the robot's ``base``, or
    by setting the axis's zero-position pose in its parent (``set = "axis"``)."""

    op: Literal["calibrated"]
    measured_by: Name
    pose: Annotated[list[Finite], Field(min_length=6, max_length=6)]
    joints: Annotated[list[Finite], Field(min_length=1, max_length=32)]
    axis: Name | None = None
    set: Literal["base", "axis"] = "base"


class Describe(_Change):
    """Describe the robot by a listed description (``id``); ``joints``: for each of the
    robot's joints, in its order now (``hello``'s), the description's joint that its node
    drives (default: the description's joints in its own order)."""

    op: Literal["description"]
    id: Annotated[str, Field(min_length=1, max_length=64)]
    joints: Annotated[list[Name], Field(max_length=32)] | None = None


Change = Annotated[
    JointMapping | JointReads | Base | AxisPose | Calibrated | Describe,
    Field(discriminator="op"),
]


class Changes(BaseModel):
    """``POST /api/cell/changes``: made in order, run at once, saved later."""

    model_config = ConfigDict(extra="forbid", strict=True)

    changes: list[Change] = Field(min_length=1, max_length=64)


Values = Mapping[str, npt.NDArray[np.float64]]
"""The newest joint values (node units, hello order) of each robot."""


def maker(
    change: Change, cell: Cell, values: Values, catalog: Catalog
) -> Callable[[CellText], None]:
    """What ``change`` does to the file's text, decided against the running ``cell``."""
    robot = _robot(cell, change.robot)
    if isinstance(change, JointMapping):
        position = _joint(robot, change.joint)
        keys = {
            k: v
            for k, v in (("scale", change.scale), ("offset", change.offset), ("unit", change.unit))
            if v is not None
        }
        return lambda text: text.set_joint(robot.name, change.joint, position, keys)
    if isinstance(change, JointReads):
        position = _joint(robot, change.joint)
        joint = robot.joints[position]
        now = values.get(robot.name)
        if now is None:
            raise CommissioningError(409, f"{robot.name} has no joint values yet")
        # SI = (raw x scale + offset) x unit factor, so this offset makes raw read ``value``.
        offset = change.value / UNIT_SCALE[joint.source_unit] - float(now[position]) * joint.scale
        return lambda text: text.set_joint(robot.name, change.joint, position, {"offset": offset})
    if isinstance(change, Base):
        xyz, rpy = _mm_deg(change.xyz, change.rpy)
        return lambda text: text.set_base(robot.name, xyz, rpy)
    if isinstance(change, AxisPose):
        placement.axis_link(robot, change.axis)
        xyz, rpy = _mm_deg(change.xyz, change.rpy)
        return lambda text: text.set_axis_pose(robot.name, change.axis, xyz, rpy)
    if isinstance(change, Calibrated):
        return _calibrated(change, cell, robot)
    return _described(change, cell, robot, catalog)


def _robot(cell: Cell, name: str) -> Robot:
    found = next((r for r in cell.robots if r.name == name), None)
    if found is None:
        raise CommissioningError(404, f"no robot named {name!r} in the cell")
    return found


def _joint(robot: Robot, name: str) -> int:
    names = [j.name for j in robot.joints]
    if name not in names:
        raise CommissioningError(404, f"{robot.name} has no joint {name!r} ({', '.join(names)})")
    return names.index(name)


def _mm_deg(xyz: list[float], rpy: list[float]) -> tuple[list[float], list[float]]:
    return [v * 1000.0 for v in xyz], np.degrees(rpy).tolist()


def _calibrated(change: Calibrated, cell: Cell, robot: Robot) -> Callable[[CellText], None]:
    measuring = _robot(cell, change.measured_by)
    frame = placement.frame_in_world(measuring, change.pose)
    if change.set == "axis":
        if change.axis is None:
            raise CommissioningError(422, "set = 'axis' needs the axis the frame belongs to")
        pose = placement.axis_zero_pose(robot, change.axis, frame, np.asarray(change.joints))
        axis = change.axis
        xyz, rpy = placement.cell_pose(pose)
        return lambda text: text.set_axis_pose(robot.name, axis, xyz, rpy)
    base = placement.placed_base(robot, frame, change.axis, np.asarray(change.joints))
    xyz, rpy = placement.cell_pose(base)
    return lambda text: text.set_base(robot.name, xyz, rpy)


def _described(
    change: Describe, cell: Cell, robot: Robot, catalog: Catalog
) -> Callable[[CellText], None]:
    description = catalog.get(change.id)
    names = list(description.joints) if change.joints is None else change.joints
    if sorted(names) != sorted(description.joints) or len(names) != len(robot.joints):
        raise CommissioningError(
            422,
            f"{robot.name} has {len(robot.joints)} joints entries; give each one joint of "
            f"{description.path.name} ({', '.join(description.joints)}), each once",
        )
    folder = cell.folder
    file = _relative(description.path, folder)
    packages = {
        name: _relative(path, folder) for name, path in catalog.packages(description).items()
    }
    by_joint = dict(zip((j.name for j in robot.joints), names, strict=True))
    return lambda text: text.set_description(robot.name, file, packages, by_joint)


def _relative(path: Path, folder: Path | None) -> str:
    """``path`` as a cell file names it: relative to the cell's folder if inside it."""
    if folder is not None and path.is_relative_to(folder.resolve()):
        return path.relative_to(folder.resolve()).as_posix()
    return str(path)
