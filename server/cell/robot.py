"""A robot of the cell: its kinematics, its joints' data-layer nodes, its meshes (all SI)."""

from __future__ import annotations

from dataclasses import dataclass
from functools import cached_property
from pathlib import Path
from typing import Any, Literal, Protocol

import numpy as np
import numpy.typing as npt

from ..protocol import JointInfo, LinkInfo, RobotInfo

Array = npt.NDArray[np.float64]
BoolArray = npt.NDArray[np.bool_]

Family = Literal["type12", "dh", "axis_group", "urdf"]
SourceUnit = Literal["deg", "rad", "mm", "m"]

DEG = np.pi / 180.0
MM = 1e-3
UNIT_SCALE: dict[str, float] = {"deg": DEG, "rad": 1.0, "mm": MM, "m": 1.0}
"""Data-layer unit -> SI factor; with the cell file, the only place degrees and mm become SI."""


class Kinematics(Protocol):
    """What the stream needs from a kinematic family (see ``server.kinematics``)."""

    def link_poses(self, q: Array) -> tuple[Array, BoolArray]: ...
    def forward(self, q: Array) -> tuple[Array, BoolArray]: ...
    def inverse(self, pose: Array, q_ref: Array | None = None) -> tuple[Array, BoolArray]: ...
    def params(self) -> dict[str, Any]: ...


@dataclass(frozen=True)
class Joint:
    """One joint: its data-layer node, how node values become SI, and its limits (SI)."""

    name: str
    node: str
    source_unit: SourceUnit
    scale: float = 1.0
    offset: float = 0.0
    limits: tuple[float, float] | None = None
    """[lower, upper] in rad or m; None: unlimited."""
    setpoint: str | None = None
    """Node of the joint's setpoint (interpolated position), mapped as ``node`` is."""
    unit_from_device: bool = False
    """The cell leaves the unit out: the source converts the node's own (OPC UA's
    EngineeringUnits) into ``source_unit``."""

    @property
    def si_unit(self) -> Literal["rad", "m"]:
        """``rad`` for rotary joints, ``m`` for linear ones."""
        return "rad" if self.source_unit in ("deg", "rad") else "m"

    def to_si(self, value: float) -> float:
        """A node value in SI: ``(value * scale + offset)`` converted from the node's unit."""
        return (value * self.scale + self.offset) * UNIT_SCALE[self.source_unit]

    def from_si(self, value: float) -> float:
        """The node value that stands for ``value`` (rad or m); inverse of ``to_si``."""
        return (value / UNIT_SCALE[self.source_unit] - self.offset) / self.scale


@dataclass(frozen=True)
class Robot:
    """A robot placed in the cell at ``base`` ([x, y, z, qx, qy, qz, qw], world frame, Z up)."""

    name: str
    family: Family
    kinematics: Kinematics
    joints: tuple[Joint, ...]
    link_names: tuple[str, ...]
    source: str = "demo"
    base: tuple[float, ...] = (0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 1.0)
    meshes: tuple[Path | None, ...] = ()
    """Per link, its GLB file (link frame, Z up); None where the page draws a stand-in."""
    tcp_is_last_link: bool = False
    """True where the TCP is the last link frame, so it need not be computed twice."""
    command_node: str = ""
    """Node taking ``{"axsPos": [...]}`` (node units) for a synchronised move."""
    demo_targets: tuple[tuple[float, ...], ...] = ()
    """Positions (node units) an embedded mock cycles through; empty: drawn within limits."""
    warnings: tuple[str, ...] = ()
    """What its description holds that cannot be shown as written (a missing mesh, ...)."""

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
    def setpoint_nodes(self) -> tuple[str, ...]:
        """Data-layer nodes of the joints' setpoints in joint order; empty when it has none."""
        return tuple(j.setpoint for j in self.joints if j.setpoint is not None)

    @cached_property
    def followed(self) -> tuple[str, ...]:
        """Every node this robot reads: the joints', then their setpoints'."""
        return self.nodes + self.setpoint_nodes

    @cached_property
    def _affine(self) -> tuple[Array, Array]:
        factor = np.array([UNIT_SCALE[j.source_unit] for j in self.joints])
        gain = np.array([j.scale for j in self.joints]) * factor
        return gain, np.array([j.offset for j in self.joints]) * factor

    def to_si(self, values: Array) -> Array:
        """Joint values ``(..., n)`` read from the nodes, in SI (rad or m)."""
        gain, bias = self._affine
        return values * gain + bias

    def from_si(self, q: Array) -> Array:
        """Node values ``(..., n)`` standing for joints ``q`` (SI); inverse of ``to_si``."""
        gain, bias = self._affine
        return (q - bias) / gain

    @cached_property
    def limits(self) -> Array:
        """Joint limits ``(n, 2)`` in SI; +-inf where a joint has none."""
        return np.array([j.limits or (-np.inf, np.inf) for j in self.joints], dtype=np.float64)

    def mesh_url(self, link: int) -> str | None:
        """Where the page fetches link ``link``'s mesh (cache-busted by content), if it has one."""
        path = self.meshes[link] if link < len(self.meshes) else None
        if path is None:
            return None
        return f"/meshes/{self.name}/{link}.glb?v={_content_tag(path)}"

    def info(self, commandable: bool = False, hold_s: float | None = None) -> RobotInfo:
        """The robot as announced in ``hello``."""
        return RobotInfo(
            name=self.name,
            kinematics=self.family,
            source=self.source,
            commandable=commandable,
            hold_s=hold_s,
            params=self.kinematics.params(),
            joints=[
                JointInfo(
                    name=j.name,
                    unit=j.si_unit,
                    limits=list(j.limits) if j.limits else None,
                    node=j.node,
                    source_unit=j.source_unit,
                    scale=j.scale,
                    offset=j.offset,
                    setpoint=j.setpoint,
                )
                for j in self.joints
            ],
            links=[LinkInfo(name=n, mesh=self.mesh_url(i)) for i, n in enumerate(self.link_names)],
            base=list(self.base),
            warnings=list(self.warnings),
        )


def _content_tag(path: Path) -> str:
    """A short tag that changes when the file does (size and mtime; no read per hello)."""
    stat = path.stat()
    return f"{stat.st_size:x}{stat.st_mtime_ns:x}"[-12:]
