"""History rows to encoded Foxglove messages ``(topic, log time ns, bytes)``, in time order.

Poses come from the batch kinematics over the whole batch (``history.window``);
this runs in the recorder's thread, never per sample on the event loop.
"""

from __future__ import annotations

import numpy as np

from ..history import Mark, NewRows, robot_window
from .messages import (
    LOG_TOPIC,
    TF_TOPIC,
    RobotFrames,
    joints_json,
    joints_topic,
    link_transforms,
    log_message,
    nanoseconds,
)

Encoded = tuple[str, int, bytes]
MARK_LEVELS = {"error": "error", "stale": "warning", "live": "info", "reload": "info"}


def encode_batch(
    sources: list[NewRows], marks: list[Mark], frames: dict[str, RobotFrames]
) -> list[Encoded]:
    """Every message of a drain of the histories, sorted by log time."""
    out: list[Encoded] = []
    for source in sources:
        out += encode_source(source, frames)
        if source.lost:
            t = float(source.rows.t[0]) if len(source.rows) else 0.0
            text = f"{source.lost} samples were not recorded (the recorder fell behind)"
            out.append((LOG_TOPIC, nanoseconds(t), log_message(t, "warning", source.name, text)))
    for mark in marks:
        level = MARK_LEVELS[mark.kind]
        text = f"{mark.kind}: {mark.text}"
        out.append(
            (
                LOG_TOPIC,
                nanoseconds(mark.t),
                log_message(mark.t, level, mark.source or "linkview", text),
            )
        )
    out.sort(key=lambda m: m[1])
    return out


def encode_source(source: NewRows, frames: dict[str, RobotFrames]) -> list[Encoded]:
    """The transforms, joints and robot errors of one source's rows."""
    rows = source.rows
    if len(rows) == 0:
        return []
    out: list[Encoded] = []
    times = [nanoseconds(t) for t in rows.t.tolist()]
    seqs = rows.seq.tolist()
    for index, robot in source.robots:
        window = robot_window(robot, index, rows, source.column, "links")
        names = frames.get(robot.name) or RobotFrames(robot)
        ok = np.flatnonzero(window.ok).tolist()
        assert window.links is not None and window.tcp is not None
        for k, data in zip(
            ok, link_transforms(names, rows.t[ok], window.links[ok], window.tcp[ok]), strict=True
        ):
            out.append((TF_TOPIC, times[k], data))
        topic = joints_topic(robot.name)
        readable = np.isfinite(window.joints).all(axis=1)
        joints = window.joints.tolist()
        for k in np.flatnonzero(readable).tolist():
            out.append((topic, times[k], joints_json(names, seqs[k], float(rows.t[k]), joints[k])))
        for k, why in window.errors:
            t = float(rows.t[k])
            out.append((LOG_TOPIC, times[k], log_message(t, "warning", robot.name, why)))
    return out
