"""What a mock UR controller outputs at one instant: each RTDE field from the simulated machine.

A simulated axis is served at its node key (``actual_q[2]``,
``output_double_register_42``) and its setpoint at its setpoint key, in node
units. An arm axis at ``actual_q[i]`` also serves its setpoint as
``target_q[i]``, as a UR does. During a protective or emergency stop the
robot stands where it stopped; the controller's clock goes on.
"""

from __future__ import annotations

import struct
from collections.abc import Sequence
from dataclasses import dataclass, field

import numpy as np

from ..mock_ctrlx import AxisGroup, Machine, SimAxis
from ..rtde import wire

UR5E_DEMO_TARGETS = (
    (0.0, -1.57, 1.57, -1.57, -1.57, 0.0),
    (0.8, -1.2, 1.0, -1.4, -1.2, 0.6),
    (-0.7, -1.9, 1.9, -1.6, -1.9, -0.8),
    (0.3, -1.0, 0.6, -1.2, -1.5, 1.2),
)
"""Joint positions (rad) the demo UR5e cycles through: above its base, elbow up."""
POSITIONER_REGISTERS = (42, 43)
"""The MotionPlus positioner's tilt and turn, copied into these output_double_registers by a
URScript thread (docs/cell.md). 42-43: readable through ur_rtde's upper register range too."""


def demo_groups() -> list[AxisGroup]:
    """A UR5e on ``actual_q`` and a MotionPlus two-axis positioner (rad) on registers."""
    arm = tuple(
        SimAxis(
            f"ur5e_q{i}",
            "rad",
            np.radians(60.0),
            np.radians(150.0),
            -2 * np.pi,
            2 * np.pi,
            node=f"actual_q[{i}]",
            setpoint_node=f"target_q[{i}]",
        )
        for i in range(6)
    )
    tilt, turn = (wire.register_key(r) for r in POSITIONER_REGISTERS)
    positioner = (
        SimAxis(
            "positioner_tilt", "rad", np.radians(90.0), np.radians(180.0), -1.2, 1.2, node=tilt
        ),
        SimAxis("positioner_turn", "rad", np.radians(90.0), np.radians(180.0), node=turn),
    )
    turns = ((0.0, 0.0), (0.5, 2.0), (-0.7, 4.2), (0.0, 6.28))
    return [AxisGroup("ur5e", arm, UR5E_DEMO_TARGETS), AxisGroup("positioner", positioner, turns)]


@dataclass
class SafetyState:
    """The robot's modes, and when the robot stopped (None: it moves)."""

    robot_mode: int = wire.RUNNING
    safety_mode: int = wire.NORMAL
    stopped_at: float | None = None


@dataclass
class Outputs:
    """Each field's values, from the machine and the safety state (see the module doc)."""

    machine: Machine
    safety: SafetyState = field(default_factory=SafetyState)
    _served: dict[str, tuple[str, bool]] = field(init=False)
    """Node key -> (axis, setpoint?)."""

    def __post_init__(self) -> None:
        self._served = {}
        for axis in self.machine.axes.values():
            self._served[axis.position_node] = (axis.name, False)
            if axis.setpoint_node:
                self._served[axis.setpoint_node] = (axis.name, True)
            key = wire.parse_key(axis.position_node)
            if key.field == "actual_q":
                self._served.setdefault(f"target_q[{key.index}]", (axis.name, True))

    def types(self, fields: Sequence[str]) -> list[str]:
        """The answer to an output setup: each field's type, NOT_FOUND for those it lacks."""
        return [wire.KNOWN_TYPES.get(f, wire.NOT_FOUND) for f in fields]

    def layout(self, fields: Sequence[str]) -> struct.Struct:
        """The struct of a data package of ``fields`` (recipe id first)."""
        return struct.Struct(">B" + "".join(wire.TYPE_FORMATS[t] for t in self.types(fields)))

    def values(self, fields: Sequence[str], timestamp: float, t: float) -> list[float | int]:
        """The flat values of ``fields`` at unix time ``t`` (controller time ``timestamp``)."""
        moving_t = t if self.safety.stopped_at is None else self.safety.stopped_at
        actual = self.machine.snapshot(moving_t)
        planned = self.machine.snapshot(moving_t, setpoints=True)
        out: list[float | int] = []
        for name in fields:
            kind = wire.KNOWN_TYPES[name]
            width = wire.TYPE_WIDTH.get(kind, 1)
            if name == "timestamp":
                out.append(timestamp)
            elif name == "robot_mode":
                out.append(self.safety.robot_mode)
            elif name == "safety_mode":
                out.append(self.safety.safety_mode)
            elif kind in ("DOUBLE", "VECTOR6D", "VECTOR3D"):
                keys = [name] if width == 1 else [f"{name}[{i}]" for i in range(width)]
                for key in keys:
                    served = self._served.get(key)
                    if served is None:
                        out.append(0.0)
                    else:
                        out.append((planned if served[1] else actual)[served[0]])
            elif kind == "BOOL":
                out.append(False)
            else:
                out.extend([0] * width)
        return out
