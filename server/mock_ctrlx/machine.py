"""The simulated machine behind the mock data layer: axis groups moving between demo targets.

Each group (one demo robot) repeats a cycle of synchronized trapezoidal moves
(``server.kinematics.plan_movej``) between its demo targets, with a short
dwell at each. Positions are a pure function of time (and of the commands
given), so no background task is needed. A commanded move (``command``)
takes its group over; the group holds the commanded pose until the next
command or for ``hold_s`` (``HOLD_S`` by default), then moves back to its first
demo target and the cycle resumes from there, so a command never stops the
demo for good.

Values are in each axis's own unit (``deg``, ``rad``, ``mm`` or ``m``, as the
data layer serves them), velocities per second and accelerations per second
squared: the planner's arithmetic is the same in any unit.

The planned trajectory is the setpoint (a ctrlX axis's ``state/values/ipo/pos``);
the actual position follows it ``lag_s`` later, as a drive's does.
"""

from __future__ import annotations

import threading
import time
from collections.abc import Callable, Sequence
from dataclasses import dataclass
from typing import Literal, get_args

import numpy as np
import numpy.typing as npt

from ..kinematics import TrapezoidMove, plan_movej

Array = npt.NDArray[np.float64]
Unit = Literal["deg", "rad", "mm", "m"]
UNITS: tuple[str, ...] = get_args(Unit)
HOLD_S = 30.0
"""How long a commanded pose is held by default before the demo cycle resumes (s): long
enough to look at it and compare it with the page, short enough that the demo goes on."""
ACTUAL_POS = "motion/axs/{name}/state/values/actual/pos"
"""Where an axis's actual position is served unless ``SimAxis.node`` says otherwise."""


@dataclass(frozen=True)
class SimAxis:
    """One simulated axis: name, unit, motion limits, the range commands may reach, its node."""

    name: str
    unit: Unit
    v_max: float
    """Velocity limit (unit/s)."""
    a_max: float
    """Acceleration limit (unit/s^2)."""
    lo: float = -np.inf
    hi: float = np.inf
    node: str | None = None
    """Data-layer address of the actual position (None: ``ACTUAL_POS`` with the axis name)."""
    setpoint_node: str | None = None
    """Where an axis at its own address serves its setpoint; None: nowhere (at the default
    address the motion tree has ``state/values/ipo/pos`` anyway)."""

    def __post_init__(self) -> None:
        if self.unit not in UNITS:
            raise ValueError(f"axis {self.name!r}: unit must be one of {UNITS}, not {self.unit!r}")
        if self.node is not None and not self.node.strip("/"):
            raise ValueError(f"axis {self.name!r}: node must be a data-layer address")

    @property
    def position_node(self) -> str:
        """The node that serves this axis's actual position (no leading or trailing slash)."""
        return (self.node or ACTUAL_POS.format(name=self.name)).strip("/")


@dataclass(frozen=True)
class Trafo:
    """A joint transformation as the controller describes it: its name and parameters."""

    name: str
    params: tuple[tuple[str, float, str], ...]
    """``(name, value, unit)`` of each parameter, e.g. ``("L1", 200.0, "mm")``."""
    axes: tuple[str, ...]
    """The names the transformation gives its axes, in ACS index order."""


@dataclass(frozen=True)
class AxisGroup:
    """Axes that move together (one robot) and the demo targets they cycle through.

    ``kinematics``: the joint transformation of the ctrlX kinematics these axes
    form (served under ``motion/kin/<name>``); None for loose axes.
    """

    name: str
    axes: tuple[SimAxis, ...]
    targets: tuple[tuple[float, ...], ...]
    dwell_s: float = 0.3
    kinematics: Trafo | None = None


TYPE12_TRAFO = Trafo(
    "IndraMotionType12",
    tuple(
        (f"L{i}", length, "mm") for i, length in enumerate((200.0, 150.0, 100.0, 200.0, 100.0), 1)
    ),
    ("a0", "a1"),
)
"""The IndraMotion MLC kinematic Type 12 (five-bar), with the demo cell's link lengths."""
_IIWA_D = (340.0, 0.0, 400.0, 0.0, 400.0, 0.0, 126.0)
_IIWA_ALPHA = (-90.0, 90.0, 90.0, -90.0, -90.0, 90.0, 0.0)
IIWA_TRAFO = Trafo(
    "DenavitHartenberg",
    tuple(
        param
        for i, (d, alpha) in enumerate(zip(_IIWA_D, _IIWA_ALPHA, strict=True), 1)
        for param in ((f"d{i}", d, "mm"), (f"a{i}", 0.0, "mm"), (f"alpha{i}", alpha, "deg"))
    ),
    tuple(f"A{i}" for i in range(1, 8)),
)
"""The KUKA LBR iiwa 7 R800 as a standard Denavit-Hartenberg table."""


def _deg(name: str, v: float, a: float, limit: float | None = None) -> SimAxis:
    lo, hi = (-np.inf, np.inf) if limit is None else (-limit, limit)
    return SimAxis(name, "deg", v, a, lo, hi)


def demo_groups() -> list[AxisGroup]:
    """The demo cell: Type 12 mechanism, a 7-axis arm and a two-axis positioner.

    Targets stay where each mechanism is well defined: the Type 12 within
    ±40° (its loop only closes there), the arm within 70 % of its limits.
    """
    iiwa_limits = (170.0, 120.0, 170.0, 120.0, 170.0, 120.0, 175.0)
    return [
        AxisGroup(
            "kin12",
            (_deg("kin12_a0", 60.0, 200.0, 40.0), _deg("kin12_a1", 60.0, 200.0, 40.0)),
            ((0.0, 0.0), (30.0, -25.0), (-20.0, 30.0), (35.0, 20.0), (-30.0, -30.0)),
            kinematics=TYPE12_TRAFO,
        ),
        AxisGroup(
            "iiwa",
            tuple(
                _deg(f"iiwa_a{i + 1}", 60.0, 150.0, 0.7 * lim) for i, lim in enumerate(iiwa_limits)
            ),
            (
                (0.0, 20.0, 0.0, -60.0, 0.0, 45.0, 0.0),
                (60.0, 45.0, -30.0, -40.0, 50.0, 60.0, 90.0),
                (-50.0, 30.0, 40.0, -80.0, -60.0, 30.0, -100.0),
                (20.0, 70.0, 10.0, -20.0, 30.0, 75.0, 45.0),
            ),
            kinematics=IIWA_TRAFO,
        ),
        AxisGroup(
            "pos",
            (_deg("pos_tilt", 90.0, 180.0, 60.0), _deg("pos_turn", 90.0, 180.0)),
            ((0.0, 0.0), (30.0, 120.0), (-40.0, 240.0), (0.0, 360.0)),
        ),
    ]


class _Cycle:
    """A group's demo cycle as a function of time: move, dwell, next move, ... forever."""

    def __init__(self, group: AxisGroup) -> None:
        v = np.array([a.v_max for a in group.axes])
        acc = np.array([a.a_max for a in group.axes])
        targets = [np.asarray(t, dtype=np.float64) for t in group.targets]
        self.moves: list[TrapezoidMove] = []
        starts = [0.0]
        for i, start in enumerate(targets):
            move = plan_movej(start, targets[(i + 1) % len(targets)], v, acc)
            self.moves.append(move)
            starts.append(starts[-1] + move.duration + group.dwell_s)
        self.starts = np.array(starts[:-1])
        self.period_s = starts[-1]

    def positions(self, t: float) -> Array:
        """Positions at unix time ``t`` (the cycle is anchored at t = 0)."""
        phase = t % self.period_s
        i = int(np.searchsorted(self.starts, phase, side="right")) - 1
        # Past a move's end its profile holds the target: that is the dwell.
        pos: Array = self.moves[i].position(phase - self.starts[i])
        return pos


@dataclass(frozen=True)
class _Commanded:
    """A commanded move, the dwell at its target, the way back and where the cycle resumes."""

    t0: float
    move: TrapezoidMove
    back_t0: float
    """When the group leaves the target for its first demo target."""
    back: TrapezoidMove
    resume_t: float
    """When the demo cycle starts again (its phase 0 is at this time)."""

    def positions(self, t: float, cycle: _Cycle) -> Array:
        """Positions at unix time ``t`` (the demo cycle again from ``resume_t`` on)."""
        if t < self.back_t0:
            pos: Array = self.move.position(t - self.t0)
        elif t < self.resume_t:
            pos = self.back.position(t - self.back_t0)
        else:
            pos = cycle.positions(t - self.resume_t)
        return pos


def many_axes(count: int) -> list[AxisGroup]:
    """``count`` more axes (``big<k>_a<j>``) in groups of six: a big controller, for load tests."""
    names = [f"big{k // 6}_a{k % 6}" for k in range(count)]
    return [
        AxisGroup(
            f"big{g}",
            tuple(_deg(name, 60.0, 200.0, 90.0) for name in names[g * 6 : g * 6 + 6]),
            (tuple(0.0 for _ in names[g * 6 : g * 6 + 6]),),
        )
        for g in range((count + 5) // 6)
    ]


class Machine:
    """All simulated axes, by group, plus a clock that tests can replace.

    ``hold_s``: how long a group holds a commanded pose (unless commanded
    again) before it returns to its demo cycle.
    """

    def __init__(
        self,
        groups: Sequence[AxisGroup] | None = None,
        clock: Callable[[], float] = time.time,
        *,
        hold_s: float = HOLD_S,
        lag_s: float = 0.0,
    ) -> None:
        self.groups = {g.name: g for g in (demo_groups() if groups is None else groups)}
        self.axes = {a.name: a for g in self.groups.values() for a in g.axes}
        if len(self.axes) != sum(len(g.axes) for g in self.groups.values()):
            raise ValueError("axis names must be unique across groups")
        self._group_of = {a.name: g.name for g in self.groups.values() for a in g.axes}
        self._cycles = {name: _Cycle(g) for name, g in self.groups.items()}
        self._commanded: dict[str, _Commanded] = {}
        self._lock = threading.Lock()
        self.clock = clock
        if hold_s < 0.0:
            raise ValueError(f"hold_s must not be negative, not {hold_s}")
        self.hold_s = hold_s
        """How long a commanded pose is held before the demo cycle resumes (s)."""
        if lag_s < 0.0:
            raise ValueError(f"lag_s must not be negative, not {lag_s}")
        self.lag_s = lag_s
        """How far the actual positions trail the setpoints (s)."""

    def now(self) -> float:
        """Current time of the simulation (unix s)."""
        return float(self.clock())

    def group_positions(self, group: str, t: float | None = None) -> Array:
        """Actual positions of ``group``'s axes at ``t`` (default now), in axis order."""
        t = self.now() if t is None else t
        return self.group_setpoints(group, t - self.lag_s)

    def group_setpoints(self, group: str, t: float | None = None) -> Array:
        """Setpoints (the planned positions) of ``group``'s axes at ``t`` (default now)."""
        t = self.now() if t is None else t
        commanded = self._commanded.get(group)
        if commanded is not None:
            return commanded.positions(t, self._cycles[group])
        return self._cycles[group].positions(t)

    def snapshot(self, t: float | None = None, *, setpoints: bool = False) -> dict[str, float]:
        """Every axis's actual position (or setpoint) at one instant ``t`` (default now)."""
        t = self.now() if t is None else t
        at = self.group_setpoints if setpoints else self.group_positions
        out: dict[str, float] = {}
        for name, group in self.groups.items():
            for axis, value in zip(group.axes, at(name, t), strict=True):
                out[axis.name] = float(value)
        return out

    def position(self, axis: str, t: float | None = None, *, setpoint: bool = False) -> float:
        """Actual position (or setpoint) of ``axis`` at ``t`` (default now); KeyError if unknown."""
        group = self._group_of[axis]
        index = [a.name for a in self.groups[group].axes].index(axis)
        at = self.group_setpoints if setpoint else self.group_positions
        return float(at(group, t)[index])

    def command(self, group: str, target: Sequence[float], t: float | None = None) -> float:
        """Move ``group`` to ``target`` (one value per axis) from where it is at ``t``.

        Returns the move's duration (s); raises ValueError outside an axis's
        range. The move starts from rest: a mock need not blend into the
        current motion. ``hold_s`` after it ends, the group moves back to its
        first demo target and resumes its cycle.
        """
        axes = self.groups[group].axes
        goal = np.asarray(target, dtype=np.float64)
        if goal.shape != (len(axes),):
            raise ValueError(f"group {group} has {len(axes)} axes, got {goal.size} values")
        for axis, value in zip(axes, goal, strict=True):
            if not axis.lo <= value <= axis.hi:
                raise ValueError(f"{axis.name}: {value} outside [{axis.lo}, {axis.hi}]")
        t = self.now() if t is None else t
        v = np.array([a.v_max for a in axes])
        acc = np.array([a.a_max for a in axes])
        first = np.asarray(self.groups[group].targets[0], dtype=np.float64)
        with self._lock:
            move = plan_movej(self.group_setpoints(group, t), goal, v, acc)
            back_t0 = t + move.duration + self.hold_s
            back = plan_movej(goal, first, v, acc)
            # Arrive, dwell as at every demo target, then the cycle's first move starts.
            resume_t = back_t0 + back.duration + self.groups[group].dwell_s
            self._commanded[group] = _Commanded(t, move, back_t0, back, resume_t)
        return move.duration

    def command_axis(self, axis: str, target: float, t: float | None = None) -> float:
        """Move one axis to ``target``; the other axes of its group hold their positions."""
        group = self._group_of[axis]
        t = self.now() if t is None else t
        goal = self.group_setpoints(group, t).copy()
        goal[[a.name for a in self.groups[group].axes].index(axis)] = target
        return self.command(group, goal.tolist(), t)

    def resume_demo(self, group: str) -> None:
        """Return ``group`` to its demo cycle at once (it jumps to where the cycle is now)."""
        self._commanded.pop(group, None)

    def group_of(self, axis: str) -> str:
        """The group an axis belongs to."""
        return self._group_of[axis]


__all__ = [
    "HOLD_S",
    "UNITS",
    "AxisGroup",
    "Machine",
    "SimAxis",
    "Trafo",
    "Unit",
    "demo_groups",
    "many_axes",
]
