"""Records and argument rules of the axis-group world model (MotionPlus Axis Group API); private.

Each check raises ``ValueError`` with a message that names the API's rule.
Units: rad (rotary) or m (linear); poses are UR pose vectors [x, y, z, rx, ry, rz].
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass, field

import numpy as np
import numpy.typing as npt

from ._axis_chain import AxisChain
from .motion import SpeedMove, TrapezoidMove

Array = npt.NDArray[np.float64]

MAX_GROUPS = 6
AXIS_INDICES = range(6)
UNLIMITED = 1e300
BASE_FRAME = "base"
ROTARY, LINEAR = 0, 1


@dataclass(eq=False)
class AxisRecord:
    """One external axis: configuration and current positions (rad or m)."""

    name: str
    group: str
    parent: str  # "" is the group base
    pose: Array
    type: int
    v_limit: float
    a_limit: float
    q_limits: tuple[float, float]
    index: int
    target: float = 0.0
    actual: float = 0.0


@dataclass(eq=False)
class GroupRecord:
    """One axis group: world pose, axes, the active motion and the cached FK."""

    name: str
    pose: Array  # world pose vector
    axes: dict[str, AxisRecord] = field(default_factory=dict)  # insertion order: parents first
    motion: TrapezoidMove | SpeedMove | None = None
    elapsed: float = 0.0
    shift: Array = field(default_factory=lambda: np.zeros(0))  # offsets applied mid-motion
    chain: AxisChain | None = None

    def ordered(self) -> list[AxisRecord]:
        """The axes in axis-index order."""
        return sorted(self.axes.values(), key=lambda a: a.index)


def check_pose(pose: npt.ArrayLike, what: str) -> Array:
    p = np.array(pose, dtype=np.float64)
    if p.shape != (6,) or not np.all(np.isfinite(p)):
        raise ValueError(f"{what} must be a finite pose [x, y, z, rx, ry, rz], got {pose!r}")
    return p


def check_positive(value: float, what: str) -> float:
    v = float(value)
    if not (math.isfinite(v) and v > 0.0):
        raise ValueError(f"{what} must be positive, got {value!r}")
    return v


def check_fraction(value: float, what: str) -> float:
    v = float(value)
    if not 0.0 < v <= 1.0:
        raise ValueError(f"{what} must be in range of (0, 1], got {value!r}")
    return v


def check_axis_type(value: int) -> int:
    if isinstance(value, bool) or value not in (ROTARY, LINEAR):
        raise ValueError(f"type can only be 0 (rotary) or 1 (linear), got {value!r}")
    return int(value)


def check_limits(q_limits: Sequence[float], allow_empty: bool) -> tuple[float, float]:
    if allow_empty and len(q_limits) == 0:
        return (-UNLIMITED, UNLIMITED)
    if len(q_limits) != 2:
        sizes = "0 or 2" if allow_empty else "2"
        raise ValueError(f"the size of q_limits must be {sizes}, got {len(q_limits)}")
    lo, hi = float(q_limits[0]), float(q_limits[1])
    if not lo < hi:
        raise ValueError(f"the lower limit must be less than the upper limit, got [{lo}, {hi}]")
    return (lo, hi)
