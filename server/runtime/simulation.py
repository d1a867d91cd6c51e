"""The machine an embedded mock simulates for one source: exactly the nodes its robots read.

Each robot becomes one axis group of the mock, moving in synchronised
trapezoids (MotionPlus ``axis_group_movej``) between targets within its joint limits:
the cell's ``demo_targets`` if given, else targets drawn from a generator
seeded by the robot's name (the same cell always moves the same way).
Everything here is in the nodes' units, as the mock serves them. A joint's
``setpoint`` node serves the planned position, which the actual one trails
by the mock's lag.
"""

from __future__ import annotations

import zlib

import numpy as np

from ..cell import Robot
from ..mock_ctrlx import DEFAULT_LAG_S, HOLD_S, AxisGroup, Machine, SimAxis

SPEED_SI = {"rad": (np.radians(60.0), np.radians(150.0)), "m": (0.25, 1.0)}
"""Velocity and acceleration limits of simulated joints, (per s, per s^2) in SI."""
FREE_RANGE_SI = {"rad": np.pi / 2, "m": 0.2}
"""Half the range drawn from for joints without limits."""
USED_SHARE = 0.7
"""Drawn targets stay within this share of each joint's range ..."""
MAX_HALF_RANGE_SI = {"rad": np.radians(120.0), "m": 0.5}
"""... and this far from its middle: a joint that may turn twice round need not, to be seen."""
FLOOR_M = -0.01
"""Drawn targets keep every link origin above the robot's base plane (z, base frame)."""
DRAWN_TARGETS = 5


def machine_for(robots: list[Robot], hold_s: float = HOLD_S) -> Machine:
    """A mock machine serving every joint node of ``robots`` (a node read twice moves once).

    A commanded pose is held ``hold_s`` before the demo cycle resumes.
    """
    groups: list[AxisGroup] = []
    simulated: set[str] = set()
    for robot in robots:
        group = _group(robot, simulated)
        if group is not None:
            groups.append(group)
    return Machine(groups, lag_s=DEFAULT_LAG_S, hold_s=hold_s)


def _group(robot: Robot, simulated: set[str]) -> AxisGroup | None:
    keep = [i for i, j in enumerate(robot.joints) if j.node not in simulated]
    if not keep:
        return None
    simulated.update(robot.joints[i].node for i in keep)
    lo, hi = _node_range(robot)
    axes = []
    for i in keep:
        joint = robot.joints[i]
        v_si, a_si = SPEED_SI[joint.si_unit]
        gain = abs(joint.to_si(1.0) - joint.to_si(0.0))  # SI per node unit
        axes.append(
            SimAxis(
                name=_axis_name(joint.node),
                unit=joint.source_unit,
                v_max=v_si / gain,
                a_max=a_si / gain,
                lo=float(lo[i]),
                hi=float(hi[i]),
                node=joint.node,
                setpoint_node=joint.setpoint,
            )
        )
    targets = robot.demo_targets or _drawn_targets(robot, lo, hi)
    return AxisGroup(robot.name, tuple(axes), tuple(tuple(t[i] for i in keep) for t in targets))


def _node_range(robot: Robot) -> tuple[np.ndarray, np.ndarray]:
    """Joint limits in node units (``-inf``/``inf`` where a joint has none)."""
    a, b = robot.from_si(robot.limits[:, 0]), robot.from_si(robot.limits[:, 1])
    return np.minimum(a, b), np.maximum(a, b)


def _drawn_targets(robot: Robot, lo: np.ndarray, hi: np.ndarray) -> list[list[float]]:
    """Targets within the limits where the kinematics is defined, above the floor (node units)."""
    rng = np.random.default_rng(zlib.crc32(robot.name.encode()))
    free = np.array([FREE_RANGE_SI[j.si_unit] for j in robot.joints])
    lo_si = np.where(np.isfinite(robot.limits[:, 0]), robot.limits[:, 0], -free)
    hi_si = np.where(np.isfinite(robot.limits[:, 1]), robot.limits[:, 1], free)
    mid, half = 0.5 * (lo_si + hi_si), 0.5 * USED_SHARE * (hi_si - lo_si)
    half = np.minimum(half, [MAX_HALF_RANGE_SI[j.si_unit] for j in robot.joints])
    home = np.clip(np.zeros(len(robot.joints)), lo_si, hi_si)
    targets = [home]
    for _ in range(50 * DRAWN_TARGETS):
        if len(targets) == DRAWN_TARGETS:
            break
        q = mid + half * rng.uniform(-1.0, 1.0, len(robot.joints))
        links, _, ok = robot.poses(q)
        if bool(ok) and links[:, 2, 3].min() >= FLOOR_M:
            targets.append(q)
    return [robot.from_si(q).tolist() for q in targets]


def _axis_name(node: str) -> str:
    """A readable axis name: ``<axis>`` of ``motion/axs/<axis>/...``, else the node itself."""
    parts = node.split("/")
    return parts[2] if len(parts) > 2 and parts[:2] == ["motion", "axs"] else node
