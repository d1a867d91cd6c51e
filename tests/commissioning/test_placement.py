"""A calibrated frame made a robot's: its base moved, or an axis's pose in its parent set.

Each placement is written into the demo cell's text (mm and degrees, as the
page saves it), loaded again, and the robot's own forward kinematics must put
the chosen frame on the target, at the joint values the frame was sampled at.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
from scipy.spatial.transform import Rotation

from server.cell import Robot, load_cell
from server.cell.edit import CellText
from server.commissioning import placement
from server.commissioning.errors import CommissioningError
from server.paths import DEMO_CELL

DEMO = DEMO_CELL.read_text()


def target() -> np.ndarray:
    """Some frame in the cell: turned and tilted, away from the origin (scipy, not the code)."""
    frame = np.eye(4)
    frame[:3, :3] = Rotation.from_euler("zyx", [35.0, -20.0, 10.0], degrees=True).as_matrix()
    frame[:3, 3] = [0.9, -0.4, 0.3]
    return frame


def robot_of(text: str, name: str, cache: Path) -> Robot:
    cell = load_cell(DEMO_CELL, text=text, cache_dir=cache)
    return next(r for r in cell.robots if r.name == name)


def world(robot: Robot, link: int, q: np.ndarray) -> np.ndarray:
    base = np.eye(4)
    base[:3, :3] = Rotation.from_quat(robot.base[3:]).as_matrix()
    base[:3, 3] = robot.base[:3]
    links, _, ok = robot.poses(q)
    assert ok
    frame: np.ndarray = base @ links[link]
    return frame


@pytest.mark.parametrize(("name", "axis", "link"), [("positioner", "turn", 2),
                                                     ("positioner", "tilt", 1),
                                                     ("iiwa7", None, 0)])  # fmt: skip
def test_a_base_placed_by_a_frame_puts_that_frame_there(
    name: str, axis: str | None, link: int, tmp_path: Path
) -> None:
    robot = robot_of(DEMO, name, tmp_path)
    q = np.radians([25.0, -70.0]) if name == "positioner" else np.zeros(7)
    base = placement.placed_base(robot, target(), axis, q)
    text = CellText(DEMO)
    text.set_base(name, *placement.cell_pose(base))
    placed = robot_of(text.text, name, tmp_path)
    np.testing.assert_allclose(world(placed, link, q), target(), atol=1e-9)


def test_an_axis_pose_set_by_a_frame_puts_the_axis_there_and_keeps_the_base(
    tmp_path: Path,
) -> None:
    robot = robot_of(DEMO, "positioner", tmp_path)
    q = np.radians([25.0, -70.0])
    pose = placement.axis_zero_pose(robot, "turn", target(), q)
    text = CellText(DEMO)
    text.set_axis_pose("positioner", "turn", *placement.cell_pose(pose))
    placed = robot_of(text.text, "positioner", tmp_path)
    assert placed.base == robot.base
    np.testing.assert_allclose(world(placed, 2, q), target(), atol=1e-9)
    # The tilt axis (its parent) is where it was.
    np.testing.assert_allclose(world(placed, 1, q), world(robot, 1, q), atol=1e-12)


def test_an_unknown_axis_or_wrong_joints_are_refused(tmp_path: Path) -> None:
    robot = robot_of(DEMO, "positioner", tmp_path)
    with pytest.raises(CommissioningError, match="no axis 'swing'"):
        placement.placed_base(robot, target(), "swing", np.zeros(2))
    with pytest.raises(CommissioningError, match="needs 2 finite joint values"):
        placement.placed_base(robot, target(), "turn", np.zeros(3))
