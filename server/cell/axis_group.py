"""An axis group of a WorldModel seen as one robot's kinematics."""

from __future__ import annotations

from typing import Any

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

    def inverse(
        self, pose: Array, q_ref: Array | None = None, limited: bool = True
    ) -> tuple[Array, BoolArray]:
        """Positions (axis-index order) putting the last axis frame on ``pose``, near ``q_ref``.

        ``limited=False`` ignores the limits (see ``serial_rotary_inverse``).
        """
        return serial_rotary_inverse(self._world, self._group, pose, q_ref, limited)

    def params(self) -> dict[str, Any]:
        """The group as ``WorldModel.params`` describes it."""
        return self._world.params(self._group)
