"""Forward and inverse kinematics of a cell robot, in SI units (the KUKA LBR arm tutorial's
Transformation service).

The web layer calls these; they hold the per-family choices (which inverse,
which solutions to list) so that routes stay free of kinematics.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..kinematics import (
    DHChain,
    LBRiiwa,
    UrdfChain,
    configuration_names,
    matrix_from_pose7,
    pose7_from_matrix,
    rpy_from_matrix,
)
from .axis_group import AxisGroupKinematics
from .robot import Array, BoolArray, Robot

_LIMITED_SOLVERS = (DHChain, UrdfChain, AxisGroupKinematics)
"""Numerical inverses that keep within the limits (the LBR iiwa's analytic one lists all)."""


class TransformInputError(ValueError):
    """The request does not fit the robot (wrong number of joints, not finite)."""


@dataclass(frozen=True)
class ForwardResult:
    """TCP poses ``[x, y, z, qx, qy, qz, qw]`` (m), the tutorial's roll-pitch-yaw (rad), ``ok``.

    ``links``, when asked for, holds every link's pose per row (hello order, base frame).
    """

    tcp: list[list[float]]
    rpy: list[list[float]]
    ok: list[bool]
    links: list[list[list[float]]] | None = None


@dataclass(frozen=True)
class InverseResult:
    """Joint solutions (SI), whether each is within limits, the chosen one, and ``ok``."""

    solutions: list[list[float]]
    configurations: list[str]
    """Each solution's configuration, by name (``configuration_names``)."""
    within_limits: list[bool]
    best: list[float] | None
    ok: bool
    error: str | None


def _joint_rows(robot: Robot, joints: list[list[float]]) -> Array:
    n = len(robot.joints)
    if any(len(row) != n for row in joints):
        raise TransformInputError(f"{robot.name} has {n} joints; each row must hold {n} values")
    q = np.asarray(joints, dtype=np.float64).reshape(len(joints), n)
    if not np.isfinite(q).all():
        raise TransformInputError("joint values must be finite numbers")
    return q


def forward(robot: Robot, joints: list[list[float]], links: bool = False) -> ForwardResult:
    """TCP pose (and, if ``links``, every link's pose) of each joint row (rad or m)."""
    q = _joint_rows(robot, joints)
    if links:
        link_poses, tcp, ok = robot.poses(q)
    else:
        tcp, ok = robot.kinematics.forward(q)
    rpy = rpy_from_matrix(tcp[..., :3, :3])
    good = np.asarray(ok, dtype=bool)
    return ForwardResult(
        tcp=[p if g else [] for p, g in zip(pose7_from_matrix(tcp).tolist(), good, strict=True)],
        rpy=[r if g else [] for r, g in zip(rpy.tolist(), good, strict=True)],
        ok=good.tolist(),
        links=None
        if not links
        else [
            p if g else []
            for p, g in zip(pose7_from_matrix(link_poses).tolist(), good, strict=True)
        ],
    )


def inverse(
    robot: Robot, tcp: list[float], joints_ref: list[float] | None, all_solutions: bool
) -> InverseResult:
    """Joints putting the TCP on ``tcp`` ``[x, y, z, qx, qy, qz, qw]``, nearest ``joints_ref``."""
    pose7 = np.asarray(tcp, dtype=np.float64)
    if pose7.shape != (7,) or not np.isfinite(pose7).all():
        raise TransformInputError("tcp must be 7 finite numbers [x, y, z, qx, qy, qz, qw]")
    if np.linalg.norm(pose7[3:]) < 1e-9:
        raise TransformInputError("tcp quaternion must not be zero")
    n = len(robot.joints)
    ref = np.zeros(n) if joints_ref is None else _joint_rows(robot, [joints_ref])[0]
    pose = matrix_from_pose7(pose7)
    kin = robot.kinematics
    best, reached = kin.inverse(pose, ref)
    ok = bool(reached)
    # Every family is judged by the cell's limits here, whatever its solver heeded.
    solutions: Array = best[None][: int(ok)]
    if isinstance(kin, LBRiiwa) and (all_solutions or not ok or not _within(robot, best)):
        # The eight analytic configurations, also to tell "outside the limits" from "out of reach".
        found = kin.inverse_all(pose, ref[2])
        solutions = found.q[found.reached]
    within = _within(robot, solutions)
    if ok and not _within(robot, best):
        inside = solutions[within]  # another configuration may reach it within the limits
        if len(inside):
            best = inside[np.argmin(np.abs(inside - ref).sum(axis=-1))]
        else:
            ok = False
    if not ok and not len(solutions) and isinstance(kin, _LIMITED_SOLVERS):
        # These solve within the limits; without them, a pose they miss may be reached.
        free, reached_free = kin.inverse(pose, ref, limited=False)
        if bool(reached_free):
            solutions, within = free[None], _within(robot, free[None])
    if not ok:
        error = "reached only outside the joint limits" if len(solutions) else "out of reach"
        names = configuration_names(kin, solutions) if len(solutions) else []
        return InverseResult(solutions.tolist(), names, within.tolist(), None, False, error)
    if not all_solutions:
        solutions, within = best[None], np.ones(1, dtype=bool)
    names = configuration_names(kin, solutions)
    return InverseResult(solutions.tolist(), names, within.tolist(), best.tolist(), True, None)


def _within(robot: Robot, q: Array) -> BoolArray:
    """Whether joints ``q`` (..., n) are within ``robot``'s limits (1e-9 of slack: round-off)."""
    lo, hi = robot.limits[:, 0], robot.limits[:, 1]
    inside: BoolArray = np.all((q >= lo - 1e-9) & (q <= hi + 1e-9), axis=-1)
    return inside
