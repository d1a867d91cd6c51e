"""What ``load_urdf`` returns: a robot's kinematics and, per link, what it looks like.

Frames are link frames (m, rad), Z up as everywhere in linkview; a visual's
``origin`` places its geometry in its link's frame, as URDF's ``<visual><origin>``.
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np
import numpy.typing as npt

from server.kinematics.urdf import UrdfChain

Array = npt.NDArray[np.float64]


class UrdfError(Exception):
    """A robot description that cannot be used; the message says what is wrong and where."""


@dataclass(frozen=True)
class MeshGeometry:
    """A mesh file (STL, OBJ or DAE), scaled per axis before its visual origin applies."""

    path: Path
    scale: tuple[float, float, float] = (1.0, 1.0, 1.0)
    uri: str = ""  # as written in the URDF, for messages


@dataclass(frozen=True)
class BoxGeometry:
    """A box centred on the visual origin; ``size`` are its x, y, z edge lengths (m)."""

    size: tuple[float, float, float]


@dataclass(frozen=True)
class CylinderGeometry:
    """A cylinder along the visual origin's z, centred on it (m)."""

    radius: float
    length: float


@dataclass(frozen=True)
class SphereGeometry:
    """A sphere centred on the visual origin (m)."""

    radius: float


@dataclass(frozen=True)
class CapsuleGeometry:
    """A cylinder of ``length`` along the visual origin's z with half-spheres on its ends (m)."""

    radius: float
    length: float


@dataclass(frozen=True)
class StandInGeometry:
    """What is drawn for a mesh that cannot be: a ball on the link frame, sticks to ``ends``.

    ``ends`` are the link's child joint origins (m, link frame), so the stand-in
    spans the link as the missing mesh would have.
    """

    ends: tuple[tuple[float, float, float], ...] = ()


Geometry = (
    MeshGeometry
    | BoxGeometry
    | CylinderGeometry
    | SphereGeometry
    | CapsuleGeometry
    | StandInGeometry
)


@dataclass(frozen=True, eq=False)
class Visual:
    """One ``<visual>`` of a link: geometry placed by ``origin`` (4x4) in the link frame.

    ``rgba`` is the URDF material's colour (sRGB, 0-1), None if it gives none.
    """

    origin: Array
    geometry: Geometry
    rgba: tuple[float, float, float, float] | None = None


def stand_in(
    ends: tuple[tuple[float, float, float], ...],
    rgba: tuple[float, float, float, float] | None = None,
) -> Visual:
    """A stand-in visual on a link frame, with sticks to ``ends`` (m, link frame)."""
    return Visual(np.eye(4), StandInGeometry(ends), rgba)


@dataclass(frozen=True, eq=False)
class UrdfRobot:
    """A loaded URDF: its kinematics and every link's visuals (empty for links without any)."""

    name: str
    path: Path
    chain: UrdfChain
    visuals: Mapping[str, tuple[Visual, ...]]
    warnings: tuple[str, ...] = ()
    """What was read but cannot be shown as written (missing meshes, floating joints, ...)."""
    ends: Mapping[str, tuple[tuple[float, float, float], ...]] = field(default_factory=dict)
    """Per link, its child joint origins (m, link frame): where a stand-in's sticks go."""

    def stand_in(self, link: str, rgba: tuple[float, float, float, float] | None = None) -> Visual:
        """The visual drawn in place of a mesh of ``link`` that cannot be read."""
        return stand_in(self.ends.get(link, ()), rgba)

    @property
    def joint_names(self) -> tuple[str, ...]:
        """Movable, non-mimic joints in document order: the order joint values arrive in."""
        return self.chain.joint_names

    @property
    def joint_units(self) -> tuple[str, ...]:
        """``"rad"`` or ``"m"`` per joint."""
        return self.chain.joint_units

    @property
    def limits(self) -> Array:
        """``(n, 2)`` lower, upper per joint (rad or m); continuous joints -inf, +inf."""
        return self.chain.limits

    @property
    def link_names(self) -> tuple[str, ...]:
        """Every link, root first, the order of ``chain.link_poses``."""
        return self.chain.link_names
