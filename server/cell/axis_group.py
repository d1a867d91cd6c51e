"""An axis group of a WorldModel seen as one robot's kinematics."""

from __future__ import annotations

from typing import Any

import numpy as np

from ..kinematics import WorldModel, serial_rotary_inverse
from .robot import Array, BoolArray


class AxisGroupKinematics:
    """``link_poses``/``forward``/``params`` of one group; joints in axis-index order (SI).

    Links are the group frame, then each axis frame; ``forward`` is the last axis frame.
    """

    def __init__(self, world: WorldModel, group: str) -> None:
        self._world = world
        self._group = group

    def link_poses(self, q: Array) -> tuple[Array, BoolArray]:
        """World poses ``(..., n + 1, 4, 4)`` of the group frame and each axis frame."""
        return self._world.link_poses(self._group, q)

    def forward(self, q: Array) -> tuple[Array, BoolArray]:
        """Pose ``(..., 4, 4)`` of the last axis frame."""
        poses, ok = self.link_poses(q)
        return poses[..., -1, :, :], ok

    def inverse(self, pose: Array, q_ref: Array | None = None) -> tuple[Array, BoolArray]:
        """Positions (axis-index order) putting the last axis frame on ``pose``, near ``q_ref``."""
        return serial_rotary_inverse(self._world, self._group, pose, q_ref)

    def params(self) -> dict[str, Any]:
        """The group as ``WorldModel.params`` describes it."""
        return self._world.params(self._group)


def tilt_rotate_positioner() -> AxisGroupKinematics:
    """A 2-axis positioner: a tilt axis along base +X at 0.45 m carrying a turntable.

    The table surface is 0.1 m above the tilt axis; at zero tilt its frame is
    parallel to the base. Tilt limits +-60 deg, turn +-360 deg.
    """
    world = WorldModel()
    world.axis_group_add("positioner", [0.0, 0.0, 0.0, 0.0, 0.0, 0.0])
    world.axis_group_add_axis(
        "positioner",
        "pos_tilt",
        "",
        [0.0, 0.0, 0.45, 0.0, np.pi / 2, 0.0],
        0,
        1.0,
        1.0,
        q_limits=[-np.pi / 3, np.pi / 3],
    )
    world.axis_group_add_axis(
        "positioner",
        "pos_turn",
        "pos_tilt",
        [-0.1, 0.0, 0.0, 0.0, -np.pi / 2, 0.0],
        0,
        1.0,
        1.0,
        q_limits=[-2 * np.pi, 2 * np.pi],
    )
    return AxisGroupKinematics(world, "positioner")
