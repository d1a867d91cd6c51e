"""The simulated machine behind the mock data layer: axes that move smoothly by themselves."""

from __future__ import annotations

import math
import time
from dataclasses import dataclass, field


@dataclass(frozen=True)
class SimAxis:
    """One axis moving as ``centre + amplitude * sin(2 pi t / period + phase)``.

    Values are in the data layer's units: degrees for rotary axes, mm for linear.
    """

    name: str
    unit: str
    centre: float
    amplitude: float
    period_s: float
    phase: float = 0.0

    def position(self, t: float) -> float:
        """Position at unix time ``t``."""
        return self.centre + self.amplitude * math.sin(2 * math.pi * t / self.period_s + self.phase)


def demo_axes() -> list[SimAxis]:
    """Axes of the default cell, chosen to stay inside each robot's reachable workspace."""
    iiwa = [
        SimAxis(f"iiwa_a{i + 1}", "deg", c, a, p, ph)
        for i, (c, a, p, ph) in enumerate(
            [
                (0, 60, 9.0, 0.0),
                (30, 25, 7.0, 0.5),
                (0, 40, 11.0, 1.0),
                (-70, 30, 6.0, 0.2),
                (0, 60, 8.0, 2.0),
                (40, 30, 5.0, 0.7),
                (0, 90, 10.0, 0.0),
            ]
        )
    ]
    return [
        SimAxis("kin12_a0", "deg", 0.0, 25.0, 6.0),
        SimAxis("kin12_a1", "deg", 0.0, 30.0, 4.0, 1.0),
        *iiwa,
        SimAxis("pos_tilt", "deg", 0.0, 45.0, 12.0),
        SimAxis("pos_turn", "deg", 0.0, 180.0, 15.0),
    ]


@dataclass
class Machine:
    """All simulated axes, keyed by name, plus a clock that tests can replace."""

    axes: dict[str, SimAxis] = field(default_factory=lambda: {a.name: a for a in demo_axes()})
    clock: object = time.time

    def now(self) -> float:
        """Current time of the simulation (unix s)."""
        return float(self.clock())  # type: ignore[operator]

    def position(self, axis: str, t: float | None = None) -> float:
        """Position of ``axis`` at ``t`` (default now); KeyError if unknown."""
        return self.axes[axis].position(self.now() if t is None else t)
