"""A robot of the cell: its kinematics, its joints' data-layer nodes, its meshes."""

from __future__ import annotations

from dataclasses import dataclass
from functools import cached_property
from typing import Any, Literal, Protocol

import numpy as np
import numpy.typing as npt

from ..protocol import JointInfo, LinkInfo, RobotInfo

Array = npt.NDArray[np.float64]
BoolArray = npt.NDArray[np.bool_]

DEG = np.pi / 180.0
MM = 1e-3
UNIT_SCALE = {"deg": DEG, "rad": 1.0, "mm": MM, "m": 1.0}
"""Data-layer unit -> SI factor; the only place degrees and millimetres become SI."""


class Kinematics(Protocol):
    """What the stream needs from a kinematic family (see ``server.kinematics``)."""

    def link_poses(self, q: Array) -> tuple[Array, BoolArray]: ...
    def forward(self, q: Array) -> tuple[Array, BoolArray]: ...
    def inverse(self, pose: Array, q_ref: Array | None = None) -> tuple[Array, BoolArray]: ...
    def params(self) -> dict[str, Any]: ...


@dataclass(frozen=True)
class Joint:
    """One joint: its name, the data-layer node it is read from, and that node's unit."""

    name: str
    node: str
    source_unit: Literal["deg", "rad", "mm", "m"]

    @property
    def si_unit(self) -> Literal["rad", "m"]:
        """``rad`` for rotary joints, ``m`` for linear ones."""
        return "rad" if self.source_unit in ("deg", "rad") else "m"


@dataclass(frozen=True)
class Robot:
    """A robot placed in the cell at ``base`` ([x, y, z, qx, qy, qz, qw], world frame, Z up)."""

    name: str
    family: Literal["type12", "dh", "axis_group"]
    kinematics: Kinematics
    joints: tuple[Joint, ...]
    link_names: tuple[str, ...]
    base: tuple[float, ...] = (0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 1.0)
    tcp_is_last_link: bool = False
    """True where the TCP is the last link frame, so it need not be computed twice."""

    def poses(self, q: Array) -> tuple[Array, Array, BoolArray]:
        """Link poses ``(..., n, 4, 4)``, TCP ``(..., 4, 4)`` and ``ok`` for joints ``q`` (SI)."""
        links, ok = self.kinematics.link_poses(q)
        if self.tcp_is_last_link:
            return links, links[..., -1, :, :], ok
        tcp, ok_tcp = self.kinematics.forward(q)
        return links, tcp, ok & ok_tcp

    @cached_property
    def nodes(self) -> tuple[str, ...]:
        """Data-layer nodes of the joints, in joint order."""
        return tuple(j.node for j in self.joints)

    @cached_property
    def to_si(self) -> Array:
        """Per-joint factors turning data-layer values into SI units."""
        return np.array([UNIT_SCALE[j.source_unit] for j in self.joints])

    def info(self) -> RobotInfo:
        """The robot as announced in ``hello``."""
        return RobotInfo(
            name=self.name,
            kinematics=self.family,
            params=self.kinematics.params(),
            joints=[JointInfo(name=j.name, unit=j.si_unit) for j in self.joints],
            links=[LinkInfo(name=n, mesh=f"/assets/{self.name}/{n}.glb") for n in self.link_names],
            base=list(self.base),
        )
