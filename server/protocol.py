"""Every message of the viewer WebSocket protocol, in one file (protocols 1 and 2).

These models are the contract: ``docs/protocol.md`` describes them, the frame
encoder's output is validated against them in tests, and the fields that
``static/`` reads are checked against them so the page and server cannot drift.
Frames are encoded by hand in ``stream.frames`` (hot path); these models are
not instantiated per sample. Protocol 2 sends the same frames as one binary
message per source and sample, laid out by the structs at the end of this file.
"""

from __future__ import annotations

import struct
from dataclasses import dataclass
from typing import Literal

import numpy as np
import numpy.typing as npt
from pydantic import BaseModel, ConfigDict

PROTOCOL_VERSION = 1
"""What a viewer gets unless it asks for more (the ``linkview.2`` WebSocket subprotocol)."""
PROTOCOLS = {"linkview.2": 2}
"""WebSocket subprotocol -> protocol version."""

Pose7 = list[float]
"""[x, y, z, qx, qy, qz, qw]: metres in the robot base frame (Z up), unit quaternion."""


class _Message(BaseModel):
    model_config = ConfigDict(extra="forbid", frozen=True)


class JointInfo(_Message):
    name: str
    unit: Literal["rad", "m"]
    limits: list[float] | None = None
    """[lower, upper] in ``unit``; None: unlimited."""
    node: str = ""
    """The data-layer node the joint reads."""
    source_unit: Literal["deg", "rad", "mm", "m"] = "rad"
    """The node's unit: SI value = (node value x scale + offset) converted from it."""
    scale: float = 1.0
    offset: float = 0.0
    setpoint: str | None = None
    """The node of the joint's setpoint; frames then carry the setpoint pose too."""


class LinkInfo(_Message):
    name: str
    mesh: str | None
    """URL of the link's glTF binary (origin = link frame); None: nothing to draw for it.

    Where no link of a robot has a mesh, the page draws ball-and-stick stand-ins.
    """


class RobotInfo(_Message):
    name: str
    kinematics: Literal["type12", "dh", "axis_group", "urdf"]
    source: str
    """The data source whose samples drive this robot."""
    commandable: bool = False
    """True where the server accepts moves for it (embedded mock or --allow-commands)."""
    hold_s: float | None = None
    """Seconds its embedded mock holds a commanded pose before the demo cycle resumes
    (None: a real controller, which does what it is told)."""
    params: dict[str, object]
    """What a client needs to redo the forward kinematics (SI units)."""
    joints: list[JointInfo]
    links: list[LinkInfo]
    base: Pose7
    """Where the robot base sits in the cell (world frame, Z up)."""
    warnings: list[str] = []
    """What its description holds that cannot be shown as written (a missing mesh, a
    floating joint drawn fixed); the robot runs all the same."""


class SourceStatus(_Message):
    name: str
    url: str
    mock: bool = False
    """True for an embedded mock data layer."""
    state: Literal["connecting", "connected", "stale", "error"]
    error: str | None
    warning: str | None = None
    """A standing caveat that does not stop the stream, e.g. the device's clock is behind."""
    device: str | None = None
    """What the device says of itself, e.g. a robot's mode and safety mode (a protective stop)."""
    halted: str | None = None
    """While the device holds its robots still, why, in words ("protective stop"): each of its
    robots' cards shows it."""
    last_sample_age_s: float | None
    overloaded: str | None = None
    """While this process makes fewer frames than the source sends: "overloaded: N of M
    samples processed, R frames/s per robot" (every robot moves, at that reduced rate)."""


class Hello(_Message):
    type: Literal["hello"]
    protocol: int
    session: str
    robots: list[RobotInfo]


class SetpointPose(_Message):
    """The pose the controller commands (its setpoint), beside the actual one."""

    joints: list[float]
    """Setpoint joint values in SI units, in hello order."""
    links: list[Pose7]
    tcp: Pose7


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
    setpoint: SetpointPose | None = None
    """Only for robots whose joints name a setpoint node, and only when both poses are ok."""


class Status(_Message):
    type: Literal["status"]
    sources: list[SourceStatus]


class CellNotice(_Message):
    type: Literal["cell"]
    path: str | None
    """The cell file being shown."""
    error: str | None
    """Why the file as it is on disk now could not be loaded (the last good cell still runs)."""


class NearLinks(_Message):
    """Two links of different robots that come within the distance of interest."""

    robots: tuple[str, str]
    links: tuple[int, int]
    """Link indices, as in each robot's ``hello`` links."""
    link_names: tuple[str, str]
    distance_m: float
    """Between the links' convex hulls; 0 when they touch or interpenetrate."""


class Clearance(_Message):
    type: Literal["clearance"]
    within_m: float
    """Pairs closer than this are listed."""
    robots: list[str]
    """The robots measured (those with meshes and a pose now)."""
    near: list[NearLinks]
    """The closest pair of links of each pair of robots within ``within_m``, nearest first."""


MESSAGE_TYPES: dict[str, type[_Message]] = {
    "hello": Hello,
    "frame": Frame,
    "status": Status,
    "cell": CellNotice,
    "clearance": Clearance,
}


# -- protocol 2: one binary message per source and sample (little-endian, no padding) ----------

FRAMES_KIND = 1
FRAMES_VERSION = 3
"""3: joint_count is a u16 (version 2's u8 held at most 255 joints; humanoids have more)."""
FRAMES_HEADER = struct.Struct("<BBHIdd")
"""kind = 1, version = 3, robot_count, seq, t_source, t_sent (unix s): 24 bytes."""
ROBOT_HEADER = struct.Struct("<HBxHHH")
"""robot_index (hello order), flags, a zero byte, joint_count, link_count, error_bytes: 10 bytes.

Then ``f32 joints[joint_count]``, ``f32 links[link_count * 7]``, ``f32 tcp[7]``
and ``error_bytes`` of UTF-8 error text. Where ok is 0, link_count is 0. With
``FLAG_SETPOINT``, the setpoint follows in the same layout: ``f32
joints[joint_count]``, ``f32 links[link_count * 7]``, ``f32 tcp[7]``.
"""
FLAG_OK = 1
"""The robot has poses."""
FLAG_SETPOINT = 2
"""The setpoint pose follows the error text (only together with FLAG_OK)."""

F32 = npt.NDArray[np.float32]


@dataclass(frozen=True)
class RobotFrame2:
    """One robot's part of a protocol-2 frames message (SI units, base frame)."""

    robot_index: int
    ok: bool
    joints: F32
    links: F32
    """``(link_count, 7)``: x, y, z, qx, qy, qz, qw."""
    tcp: F32
    error: str | None
    setpoint: Setpoint2 | None = None


@dataclass(frozen=True)
class Setpoint2:
    """The setpoint pose of a robot in a protocol-2 frames message (SI units, base frame)."""

    joints: F32
    links: F32
    """``(link_count, 7)``."""
    tcp: F32


@dataclass(frozen=True)
class Frames2:
    """A decoded protocol-2 frames message."""

    seq: int
    t_source: float
    t_sent: float
    robots: list[RobotFrame2]


def frames_layout(data: bytes) -> tuple[int, int, float, float, list[RobotLayout]]:
    """Where each robot's part of a protocol-2 frames message lies; ValueError if not one.

    Returns seq, robot count, t_source, t_sent and each robot's layout; it reads
    only the headers, so checking a message that arrived from elsewhere (a
    cluster's broker) costs a few struct reads per robot.
    """
    if len(data) < FRAMES_HEADER.size:
        raise ValueError(f"{len(data)} bytes is shorter than the frames header")
    kind, version, count, seq, t_source, t_sent = FRAMES_HEADER.unpack_from(data, 0)
    if (kind, version) != (FRAMES_KIND, FRAMES_VERSION):
        raise ValueError(f"not a protocol-2 frames message (kind {kind}, version {version})")
    at, robots = FRAMES_HEADER.size, list[RobotLayout]()
    for _ in range(count):
        if at + ROBOT_HEADER.size > len(data):
            raise ValueError(f"{count} robots announced, the message ends after {len(robots)}")
        index, flags, n_joints, n_links, n_error = ROBOT_HEADER.unpack_from(data, at)
        robot = RobotLayout(index, flags, n_joints, n_links, n_error, at + ROBOT_HEADER.size)
        at = robot.end
        if at > len(data):
            raise ValueError(f"robot {index}'s part runs past the end of the message")
        robots.append(robot)
    if at != len(data):
        raise ValueError(f"{len(data) - at} bytes left over after {count} robots")
    return seq, count, t_source, t_sent, robots


@dataclass(frozen=True)
class RobotLayout:
    """One robot's header in a protocol-2 frames message, and where its floats begin."""

    robot_index: int
    flags: int
    joint_count: int
    link_count: int
    error_bytes: int
    at: int

    @property
    def pose_bytes(self) -> int:
        """Bytes of one pose: joints, links and TCP as float32."""
        return 4 * (self.joint_count + 7 * self.link_count + 7)

    @property
    def end(self) -> int:
        """Where the next robot's header begins."""
        setpoint = self.pose_bytes if self.flags & FLAG_SETPOINT else 0
        return self.at + self.pose_bytes + self.error_bytes + setpoint


def decode_frames(data: bytes) -> Frames2:
    """Decode a protocol-2 frames message; raises ValueError if it is not one."""
    seq, _, t_source, t_sent, layout = frames_layout(data)
    robots = []
    for part in layout:
        at = part.at
        joints, links, tcp = _pose_floats(data, at, part.joint_count, part.link_count)
        at += part.pose_bytes
        error = data[at : at + part.error_bytes].decode("utf-8") if part.error_bytes else None
        at += part.error_bytes
        setpoint = None
        if part.flags & FLAG_SETPOINT:
            setpoint = Setpoint2(*_pose_floats(data, at, part.joint_count, part.link_count))
        robots.append(
            RobotFrame2(
                robot_index=part.robot_index,
                ok=bool(part.flags & FLAG_OK),
                joints=joints,
                links=links,
                tcp=tcp,
                error=error,
                setpoint=setpoint,
            )
        )
    return Frames2(seq, t_source, t_sent, robots)


def _pose_floats(data: bytes, at: int, n_joints: int, n_links: int) -> tuple[F32, F32, F32]:
    """Joints, links ``(n_links, 7)`` and TCP read from ``data`` at ``at``."""
    floats = np.frombuffer(data, "<f4", n_joints + 7 * n_links + 7, at)
    links = floats[n_joints : n_joints + 7 * n_links].reshape(n_links, 7)
    return floats[:n_joints], links, floats[n_joints + 7 * n_links :]
