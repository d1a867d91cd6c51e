"""Turn a sample into poses once, then into each protocol's bytes once, for every viewer."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import orjson

from ..cell import Robot
from ..kinematics import pose7_from_matrix
from ..protocol import FLAG_OK, FLAG_SETPOINT, FRAMES_HEADER, FRAMES_KIND, ROBOT_HEADER
from .types import Array, RobotSample

# orjson rather than json: it serialises numpy arrays directly and is ~10x
# faster, and this runs 50-100 times a second per robot.
_OPTS = orjson.OPT_SERIALIZE_NUMPY
_NO_FLOATS = np.zeros(0)
_NO_TCP = np.zeros(7)
MAX_ERROR_BYTES = 1024
"""Error texts are cut to this many bytes on the wire (protocol 2's field is 16 bits)."""


@dataclass(frozen=True)
class SetpointFrame:
    """The setpoint's joints (SI) and poses, computed beside the actual ones."""

    joints: Array
    links: Array
    """``(n_links, 7)``."""
    tcp: Array
    """``(7,)``."""


@dataclass(frozen=True)
class RobotFrame:
    """One robot's poses for one sample (SI, base frame), or why there are none."""

    robot: Robot
    seq: int
    t_source: float
    joints: Array | None
    """Joint values (rad or m) in hello order; None when the sample could not be read."""
    links: Array
    """``(n_links, 7)`` poses [x, y, z, qx, qy, qz, qw]; empty unless ``ok``."""
    tcp: Array
    """``(7,)``; empty unless ``ok``."""
    error: str | None
    setpoint: SetpointFrame | None = None
    """Only where the robot reads setpoints, and only when both poses are ok."""

    @property
    def ok(self) -> bool:
        """True when the frame holds poses."""
        return self.error is None


def compute_frame(robot: Robot, sample: RobotSample) -> RobotFrame:
    """Poses of every link and the TCP for ``sample`` (and for its setpoints, if it has them)."""
    error = sample.error
    q: Array | None = None
    links: Array = _NO_FLOATS.reshape(0, 7)
    tcp: Array = _NO_FLOATS
    setpoint: SetpointFrame | None = None
    if error is None and sample.values is not None:
        q = robot.to_si(sample.values)
        if sample.setpoints is None:
            link_poses, tcp_pose, reached = robot.poses(q)
            ok = bool(reached)
            if ok:
                links = pose7_from_matrix(link_poses)
                tcp = links[-1] if robot.tcp_is_last_link else pose7_from_matrix(tcp_pose)
        else:
            links, tcp, ok, setpoint = _with_setpoint(robot, q, robot.to_si(sample.setpoints))
        if not ok:
            error = f"unreachable posture: joints {np.round(sample.values, 3).tolist()}"
    return RobotFrame(robot, sample.seq, sample.t_source, q, links, tcp, error, setpoint)


def _with_setpoint(
    robot: Robot, q: Array, q_set: Array
) -> tuple[Array, Array, bool, SetpointFrame | None]:
    """Actual links, TCP and ok, and the setpoint's frame (None if unreachable) in one batch."""
    both = np.stack([q, q_set])  # one call into the kinematics, not two
    link_poses, tcp_pose, ok = robot.poses(both)
    if not bool(ok[0]):
        return _NO_FLOATS.reshape(0, 7), _NO_FLOATS, False, None
    links = pose7_from_matrix(link_poses)
    tcp = links[:, -1] if robot.tcp_is_last_link else pose7_from_matrix(tcp_pose)
    setpoint = SetpointFrame(q_set, links[1], tcp[1]) if bool(ok[1]) else None
    return links[0], tcp[0], True, setpoint


def encode_json(frame: RobotFrame, t_sent: float) -> str:
    """The protocol-1 ``frame`` message of one robot."""
    message = {
        "type": "frame",
        "robot": frame.robot.name,
        "seq": frame.seq,
        "t_source": frame.t_source,
        "t_sent": t_sent,
        "joints": frame.joints if frame.joints is not None else [],
        "links": frame.links if frame.ok else [],
        "tcp": frame.tcp if frame.ok else [],
        "ok": frame.ok,
        "error": frame.error,
    }
    if frame.setpoint is not None:  # robots without setpoints send no key at all
        sp = frame.setpoint
        message["setpoint"] = {"joints": sp.joints, "links": sp.links, "tcp": sp.tcp}
    return orjson.dumps(message, option=_OPTS).decode()


def encode_binary(
    frames: list[tuple[int, RobotFrame]], seq: int, t_source: float, t_sent: float
) -> bytes:
    """The protocol-2 frames message of one source's sample: ``(hello index, frame)`` pairs."""
    parts = [FRAMES_HEADER.pack(FRAMES_KIND, 2, len(frames), seq & 0xFFFFFFFF, t_source, t_sent)]
    for index, frame in frames:
        joints = frame.joints if frame.joints is not None else _NO_FLOATS
        error = b"" if frame.error is None else _cut(frame.error.encode("utf-8"))
        links = frame.links if frame.ok else _NO_FLOATS
        tcp = frame.tcp if frame.ok else _NO_TCP
        sp = frame.setpoint if frame.ok else None
        flags = (FLAG_OK if frame.ok else 0) | (FLAG_SETPOINT if sp is not None else 0)
        parts.append(ROBOT_HEADER.pack(index, flags, len(joints), len(links), len(error)))
        floats = np.concatenate([joints, links.reshape(-1), tcp]).astype("<f4")
        parts.append(floats.tobytes())
        parts.append(error)
        if sp is not None:
            floats = np.concatenate([sp.joints, sp.links.reshape(-1), sp.tcp]).astype("<f4")
            parts.append(floats.tobytes())
    return b"".join(parts)


def _cut(text: bytes) -> bytes:
    """At most MAX_ERROR_BYTES, cut on a character boundary."""
    if len(text) <= MAX_ERROR_BYTES:
        return text
    return text[:MAX_ERROR_BYTES].decode("utf-8", "ignore").encode("utf-8")
