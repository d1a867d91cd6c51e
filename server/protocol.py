"""Every message of the viewer WebSocket protocol, in one file (protocol 1).

These models are the contract: ``docs/protocol.md`` describes them, the frame
encoder's output is validated against them in tests, and the fields that
``static/`` reads are checked against them so the page and server cannot drift.
Frames are encoded by hand in ``stream.frames`` (hot path); these models are
not instantiated per sample.
"""

from __future__ import annotations

from typing import Literal

from pydantic import BaseModel, ConfigDict

PROTOCOL_VERSION = 1

Pose7 = list[float]
"""[x, y, z, qx, qy, qz, qw]: metres in the robot base frame (Z up), unit quaternion."""


class _Message(BaseModel):
    model_config = ConfigDict(extra="forbid", frozen=True)


class JointInfo(_Message):
    name: str
    unit: Literal["rad", "m"]


class LinkInfo(_Message):
    name: str
    mesh: str
    """URL of the link's glTF binary; its origin is the link frame."""


class RobotInfo(_Message):
    name: str
    kinematics: Literal["type12", "dh", "axis_group"]
    params: dict[str, object]
    """What a client needs to redo the forward kinematics (SI units)."""
    joints: list[JointInfo]
    links: list[LinkInfo]
    base: Pose7
    """Where the robot base sits in the cell (world frame, Z up)."""


class SourceStatus(_Message):
    name: str
    url: str
    state: Literal["connecting", "connected", "error"]
    error: str | None
    warning: str | None = None
    """A standing caveat that does not stop the stream, e.g. the device's clock is behind."""
    last_sample_age_s: float | None


class Hello(_Message):
    type: Literal["hello"]
    protocol: int
    session: str
    robots: list[RobotInfo]


class Frame(_Message):
    type: Literal["frame"]
    robot: str
    seq: int
    t_source: float
    """Unix time (s) the data layer sampled the joints."""
    t_sent: float
    """Unix time (s) the server encoded this frame."""
    joints: list[float]
    """Joint values in SI units (rad or m), in hello order."""
    links: list[Pose7]
    """One pose per link, in hello order."""
    tcp: Pose7
    ok: bool
    error: str | None
    """Why the sample could not be turned into poses; the page keeps the last good pose."""


class Status(_Message):
    type: Literal["status"]
    sources: list[SourceStatus]


MESSAGE_TYPES: dict[str, type[_Message]] = {"hello": Hello, "frame": Frame, "status": Status}
