"""Turn a sample into poses once, then into each protocol's bytes once, for every viewer."""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np
import orjson

from ..cell import Robot
from ..kinematics import pose7_from_matrix
from ..protocol import (
    FLAG_OK,
    FLAG_SETPOINT,
    FRAMES_HEADER,
    FRAMES_KIND,
    FRAMES_VERSION,
    ROBOT_HEADER,
)
from .types import Array, BoolArray, RobotSample

# orjson rather than json: it serialises numpy arrays directly and is ~10x
# faster, and this runs 50-100 times a second per robot.
_OPTS = orjson.OPT_SERIALIZE_NUMPY
_NO_FLOATS = np.zeros(0)
_NO_LINKS = _NO_FLOATS.reshape(0, 7)
_NO_TCP = np.zeros(7)
_F4 = np.dtype("<f4")
MAX_ERROR_BYTES = 1024
"""Error texts are cut to this many bytes on the wire (protocol 2's field is 16 bits)."""


@dataclass(slots=True)  # not frozen: made per robot and sample; a frozen init costs 1.5 µs more
class SetpointFrame:
    """The setpoint's joints (SI) and poses, computed beside the actual ones."""

    joints: Array
    links: Array
    """``(n_links, 7)``."""
    tcp: Array
    """``(7,)``."""


@dataclass(slots=True)  # not frozen: made per robot and sample; a frozen init costs 1.5 µs more
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
    return compute_frames([(robot, sample)])[0]


def compute_frames(jobs: Sequence[tuple[Robot, RobotSample]]) -> list[RobotFrame]:
    """``compute_frame`` of many robots: one kinematics call per kinematic model, not per robot.

    Robots that share a model (the cell loader gives identical kinematics tables
    one instance) go through it in one batch, their setpoints included. A single
    robot's sample pays numpy's cost per call more than the arithmetic: batched,
    the arms of a plant cost a fraction each (bench/sample_path.py).
    """
    frames: list[RobotFrame | None] = [None] * len(jobs)
    models: dict[tuple[int, bool], list[tuple[int, Array]]] = {}
    for i, (robot, sample) in enumerate(jobs):
        if sample.error is None and sample.values is not None:
            model = (id(robot.kinematics), robot.tcp_is_last_link)
            models.setdefault(model, []).append((i, sample.values))
        else:
            frames[i] = RobotFrame(
                robot, sample.seq, sample.t_source, None, _NO_LINKS, _NO_FLOATS, sample.error
            )
    for members in models.values():
        computed = _same_model([(*jobs[i], values) for i, values in members])
        for (i, _), frame in zip(members, computed, strict=True):
            frames[i] = frame
    return frames  # type: ignore[return-value]  # every slot is filled above


def _same_model(jobs: list[tuple[Robot, RobotSample, Array]]) -> list[RobotFrame]:
    """Frames of robots sharing one kinematics, every sample read: actual rows, then setpoints."""
    rows = [robot.to_si(values) for robot, _, values in jobs]
    ghosts = [(k, s.setpoints) for k, (_, s, _) in enumerate(jobs) if s.setpoints is not None]
    rows += [jobs[k][0].to_si(setpoints) for k, setpoints in ghosts]
    model = jobs[0][0]
    if len(rows) == 1:  # an idle process's turn: the families' faster path for one configuration
        one = model.poses(rows[0])
        link_poses, tcp_poses, reached = one[0][None], one[1][None], np.asarray(one[2])[None]
    else:
        link_poses, tcp_poses, reached = model.poses(np.stack(rows))
    links, tcp = _pose7_where(link_poses, tcp_poses, reached, model.tcp_is_last_link)
    setpoint_row = {k: len(jobs) + n for n, (k, _) in enumerate(ghosts)}
    frames = []
    for k, (robot, sample, values) in enumerate(jobs):
        q = rows[k]
        if not reached[k]:
            error = f"unreachable posture: joints {np.round(values, 3).tolist()}"
            frames.append(
                RobotFrame(robot, sample.seq, sample.t_source, q, _NO_LINKS, _NO_FLOATS, error)
            )
            continue
        setpoint = None
        if (row := setpoint_row.get(k)) is not None and reached[row]:
            setpoint = SetpointFrame(rows[row], links[row], tcp[row])
        frames.append(
            RobotFrame(robot, sample.seq, sample.t_source, q, links[k], tcp[k], None, setpoint)
        )
    return frames


def _pose7_where(
    link_poses: Array, tcp_poses: Array, reached: BoolArray, tcp_is_last_link: bool
) -> tuple[Array, Array]:
    """Wire poses ``(m, n_links, 7)`` and ``(m, 7)``; rows not ``reached`` are left zero."""
    if reached.all():  # the usual case: every row in one conversion, no selection
        links = pose7_from_matrix(link_poses)
        return links, links[:, -1] if tcp_is_last_link else pose7_from_matrix(tcp_poses)
    links = np.zeros(link_poses.shape[:-2] + (7,))
    tcp = np.zeros((len(reached), 7))
    links[reached] = pose7_from_matrix(link_poses[reached])
    tcp[reached] = links[reached, -1] if tcp_is_last_link else pose7_from_matrix(tcp_poses[reached])
    return links, tcp


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
    header = (FRAMES_KIND, FRAMES_VERSION, len(frames), seq & 0xFFFFFFFF, t_source, t_sent)
    parts = [FRAMES_HEADER.pack(*header)]
    for index, frame in frames:
        joints = frame.joints if frame.joints is not None else _NO_FLOATS
        error = b"" if frame.error is None else _cut(frame.error.encode("utf-8"))
        links = frame.links if frame.ok else _NO_FLOATS
        tcp = frame.tcp if frame.ok else _NO_TCP
        sp = frame.setpoint if frame.ok else None
        flags = (FLAG_OK if frame.ok else 0) | (FLAG_SETPOINT if sp is not None else 0)
        parts.append(ROBOT_HEADER.pack(index, flags, len(joints), len(links), len(error)))
        parts.append(_float32s(joints, links, tcp))
        parts.append(error)
        if sp is not None:
            parts.append(_float32s(sp.joints, sp.links, sp.tcp))
    return b"".join(parts)


def _float32s(joints: Array, links: Array, tcp: Array) -> bytes:
    """Joints, link poses and TCP pose as one run of little-endian float32."""
    floats = np.concatenate([joints, links.reshape(-1), tcp], dtype=_F4, casting="same_kind")
    return floats.tobytes()


def _cut(text: bytes) -> bytes:
    """At most MAX_ERROR_BYTES, cut on a character boundary."""
    if len(text) <= MAX_ERROR_BYTES:
        return text
    return text[:MAX_ERROR_BYTES].decode("utf-8", "ignore").encode("utf-8")
