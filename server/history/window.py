"""Poses for a stretch of history, recomputed with the batch kinematics (no pose is stored).

Runs off the event loop (a thread): a minute of a 7-axis arm is some
milliseconds of numpy, ten minutes of ten robots a second or more.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Literal

import numpy as np
import numpy.typing as npt

from ..cell import Robot
from ..kinematics import pose7_from_matrix
from .ring import Array, Rows

Poses = Literal["links", "tcp", "none"]
BoolArray = npt.NDArray[np.bool_]
UNREADABLE = "a joint node could not be read (see the marks)"
UNREACHABLE = "unreachable posture"
REASONS = ("", UNREADABLE, UNREACHABLE)


@dataclass(frozen=True)
class RobotWindow:
    """One robot over a window: joints (SI) per sample, and its poses where asked for."""

    robot: Robot
    index: int
    """Position in ``hello.robots``."""
    joints: Array
    """``(n, joints)`` rad or m; NaN where not read."""
    ok: BoolArray
    """``(n,)`` the sample was read and (with poses) the posture is reachable."""
    tcp: Array | None
    """``(n, 7)`` [x, y, z, qx, qy, qz, qw] base frame, zeros where not ok; None unless asked."""
    links: Array | None
    """``(n, links, 7)`` base frame, zeros where not ok; None unless ``poses == "links"``."""
    errors: list[tuple[int, str]]
    """``(first row, why)`` for each run of rows that are not ok."""


def robot_window(
    robot: Robot, index: int, rows: Rows, column: dict[str, int], poses: Poses
) -> RobotWindow:
    """``robot``'s part of ``rows`` (node values of its source), with poses if asked."""
    raw = rows.values[:, [column[n] for n in robot.nodes]]
    readable = np.isfinite(raw).all(axis=1)
    joints = robot.to_si(raw)
    ok: BoolArray = np.array(readable, dtype=bool)
    reason = np.where(readable, 0, 1).astype(np.int8)  # an index into REASONS
    tcp = links = None
    if poses != "none":
        n, count = len(rows), len(robot.link_names)
        link_poses = np.zeros((n, count, 7))
        tcp_poses = np.zeros((n, 7))
        if readable.any():
            matrices, tcp_matrix, reachable = robot.poses(joints[readable])
            at = np.flatnonzero(readable)
            good = at[np.asarray(reachable, dtype=bool)]
            bad = at[~np.asarray(reachable, dtype=bool)]
            link7 = pose7_from_matrix(matrices[np.asarray(reachable, dtype=bool)])
            link_poses[good] = link7
            if robot.tcp_is_last_link:
                tcp_poses[good] = link7[:, -1]
            else:
                tcp_poses[good] = pose7_from_matrix(tcp_matrix[np.asarray(reachable, dtype=bool)])
            ok[bad] = False
            reason[bad] = 2
        tcp = tcp_poses
        links = link_poses if poses == "links" else None
    return RobotWindow(robot, index, joints, ok, tcp, links, _runs(ok, reason))


def _runs(ok: BoolArray, reason: npt.NDArray[np.int8]) -> list[tuple[int, str]]:
    """Where each run of failing rows starts, with its reason."""
    runs: list[tuple[int, str]] = []
    previous = 0
    for i in np.flatnonzero(~ok).tolist():
        code = int(reason[i])
        if i == 0 or ok[i - 1] or code != previous:
            runs.append((i, REASONS[code]))
        previous = code
    return runs


def source_window(
    robots: list[tuple[int, Robot]], rows: Rows, column: dict[str, int], poses: Poses
) -> list[RobotWindow]:
    """Every robot of a source over ``rows``: ``(hello index, robot)`` pairs in, windows out."""
    return [robot_window(robot, index, rows, column, poses) for index, robot in robots]
