"""A robot's joint tree as URDF describes it: the input of ``UrdfChain``.

Frames: each joint's ``origin`` is in its parent link's frame; lengths in
metres, angles in radians. Plain data, checked when a ``UrdfChain`` is built.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Literal

import numpy as np
import numpy.typing as npt

Array = npt.NDArray[np.float64]
JointType = Literal["revolute", "continuous", "prismatic", "fixed"]


@dataclass(frozen=True)
class UrdfMimic:
    """URDF ``<mimic>``: this joint's value is ``multiplier * q[joint] + offset`` (rad or m)."""

    joint: str
    multiplier: float = 1.0
    offset: float = 0.0


@dataclass(frozen=True, eq=False)
class UrdfJoint:
    """One joint: ``origin`` (4x4, m) places the joint frame in the parent link frame at q = 0.

    ``axis`` is in the joint frame (need not be unit length). ``limits`` is
    (lower, upper) in rad or m; required for revolute and prismatic joints that
    do not mimic another, ignored for continuous ones.
    """

    name: str
    type: JointType
    parent: str
    child: str
    origin: Array = field(default_factory=lambda: np.eye(4))
    axis: tuple[float, float, float] = (1.0, 0.0, 0.0)
    limits: tuple[float, float] | None = None
    mimic: UrdfMimic | None = None


@dataclass(frozen=True)
class UrdfTree:
    """A robot's joint tree as URDF describes it: link names, and joints in document order."""

    links: tuple[str, ...]
    joints: tuple[UrdfJoint, ...]
