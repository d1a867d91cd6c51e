"""World model of MotionPlus axis groups (Universal Robots' Axis Group API), without a controller.

Frames: ``"base"`` is the robot's base frame and the world frame of this
model. A group's base frame is fixed in it; each axis frame sits at its
zero-position ``pose`` in its parent frame (the group base or another axis of
the group) and then turns about its local +Z (type 0, rotary, rad) or moves
along it (type 1, linear, m). Poses given to and returned by the API-named
methods are UR pose vectors ``[x, y, z, rx, ry, rz]`` (m, axis-angle rad).
Position arrays are ordered by axis index, as in the API.

Time is explicit: ``axis_group_movej`` and ``axis_group_speedj`` plan a
profile (:mod:`.motion`) and ``advance(dt)`` moves the actual positions along
it. Every rule of the API that a call breaks raises ``ValueError`` naming it.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from typing import Any

import numpy as np
import numpy.typing as npt

from ._axis_chain import AxisChain, build_axis_chain
from ._axis_rules import (
    AXIS_INDICES,
    BASE_FRAME,
    MAX_GROUPS,
    ROTARY,
    UNLIMITED,
    AxisRecord,
    GroupRecord,
    check_axis_type,
    check_fraction,
    check_limits,
    check_pose,
    check_positive,
)
from ._pose_vector import matrix_from_pose_vector, pose_vector_from_matrix
from .motion import SpeedMove, TrapezoidMove, plan_movej, plan_speedj

Array = npt.NDArray[np.float64]
BoolArray = npt.NDArray[np.bool_]


class WorldModel:
    """Axis groups and their external axes, the MotionPlus ``axis_group_*`` API in Python."""

    def __init__(self) -> None:
        self._groups: dict[str, GroupRecord] = {}
        self._axes: dict[str, AxisRecord] = {}

    # -- lookup -----------------------------------------------------------------------------

    def _group(self, name: str) -> GroupRecord:
        if name not in self._groups:
            raise ValueError(f"axis group {name!r} does not exist")
        return self._groups[name]

    def _axis(self, name: str) -> AxisRecord:
        if name not in self._axes:
            raise ValueError(f"axis {name!r} does not exist")
        return self._axes[name]

    def _check_new_name(self, name: str) -> None:
        if not name:
            raise ValueError("the name cannot be an empty string")
        if name == BASE_FRAME or name in self._groups or name in self._axes:
            raise ValueError(f"names of world model objects must be unique: {name!r} is taken")

    def _check_idle(self, group: GroupRecord) -> None:
        if group.motion is not None:
            raise ValueError(f"axis group {group.name!r} is under control of a motion command")

    def _sized(self, group: GroupRecord, values: npt.ArrayLike, what: str) -> Array:
        arr = np.array(values, dtype=np.float64).reshape(-1)
        if arr.size != len(group.axes):
            raise ValueError(
                f"the size of {what} ({arr.size}) must match the number of axes "
                f"attached to axis group {group.name!r} ({len(group.axes)})"
            )
        if not np.all(np.isfinite(arr)):
            raise ValueError(f"{what} must be finite")
        return arr

    # -- configuring ------------------------------------------------------------------------

    def axis_group_add(self, name: str, pose: npt.ArrayLike, ref_frame: str = BASE_FRAME) -> None:
        """Add group ``name`` with its base at ``pose`` (UR pose vector) in ``ref_frame``.

        ``ref_frame`` is any frame of the model at its current positions; the
        group stays attached to the world (base) frame where that puts it.
        """
        self._check_new_name(name)
        if len(self._groups) >= MAX_GROUPS:
            raise ValueError(f"at most {MAX_GROUPS} axis groups can be added to the world model")
        local = matrix_from_pose_vector(check_pose(pose, "pose"))
        world = self.frame_pose(ref_frame) @ local
        self._groups[name] = GroupRecord(name, pose_vector_from_matrix(world))

    def axis_group_delete(self, name: str) -> None:
        """Delete group ``name`` and all its axes."""
        group = self._group(name)
        self._check_idle(group)
        for axis_name in group.axes:
            del self._axes[axis_name]
        del self._groups[name]

    def axis_group_add_axis(
        self,
        group_name: str,
        name: str,
        parent: str,
        pose: npt.ArrayLike,
        type: int,
        v_limit: float,
        a_limit: float,
        q_limits: Sequence[float] | None = None,
        axis_index: int | None = None,
    ) -> None:
        """Attach axis ``name`` to ``parent`` (``""`` or ``group_name``: the group base).

        ``pose``: zero-position pose in the parent frame (UR pose vector).
        ``type``: 0 rotary (about +Z, rad), 1 linear (along +Z, m). ``v_limit``
        (rad/s or m/s) and ``a_limit`` (rad/s^2 or m/s^2) positive. ``q_limits``
        [lower, upper] (default practically infinite). ``axis_index`` in [0, 5]
        and free; by default the lowest free index. Positions start at 0.
        """
        group = self._group(group_name)
        self._check_idle(group)
        self._check_new_name(name)
        if parent == name:
            raise ValueError(f"axis {name!r} cannot be its own parent: closed chains are refused")
        if parent not in ("", group_name) and parent not in group.axes:
            raise ValueError(f"parent axis {parent!r} must exist in axis group {group_name!r}")
        limits = check_limits([-UNLIMITED, UNLIMITED] if q_limits is None else q_limits, False)
        index = self._free_index(axis_index)
        self._axes[name] = group.axes[name] = AxisRecord(
            name=name,
            group=group_name,
            parent="" if parent == group_name else parent,
            pose=check_pose(pose, "pose"),
            type=check_axis_type(type),
            v_limit=check_positive(v_limit, "v_limit"),
            a_limit=check_positive(a_limit, "a_limit"),
            q_limits=limits,
            index=index,
        )
        group.chain = None

    def _free_index(self, axis_index: int | None, own: AxisRecord | None = None) -> int:
        taken = {a.index for a in self._axes.values() if a is not own}
        if axis_index is None:
            free = [i for i in AXIS_INDICES if i not in taken]
            if not free:
                raise ValueError("every axis index in [0, 5] is occupied")
            return free[0]
        if isinstance(axis_index, bool) or axis_index not in AXIS_INDICES:
            raise ValueError(f"axis_index must be in range of [0, 5], got {axis_index!r}")
        if axis_index in taken:
            raise ValueError(f"axis_index {axis_index} is already occupied by an existing axis")
        return int(axis_index)

    def axis_group_update_axis(
        self,
        name: str,
        pose: npt.ArrayLike | None = None,
        type: int | None = None,
        v_limit: float | None = None,
        a_limit: float | None = None,
        q_limits: Sequence[float] | None = None,
        axis_index: int | None = None,
    ) -> None:
        """Update the given properties of axis ``name``; ``q_limits=[]`` removes the limits.

        Everything is checked before anything changes.
        """
        axis = self._axis(name)
        group = self._groups[axis.group]
        self._check_idle(group)
        new_pose = axis.pose if pose is None else check_pose(pose, "pose")
        new_type = axis.type if type is None else check_axis_type(type)
        new_v = axis.v_limit if v_limit is None else check_positive(v_limit, "v_limit")
        new_a = axis.a_limit if a_limit is None else check_positive(a_limit, "a_limit")
        new_limits = axis.q_limits if q_limits is None else check_limits(q_limits, True)
        new_index = axis.index if axis_index is None else self._free_index(axis_index, axis)
        axis.pose, axis.type, axis.v_limit, axis.a_limit = new_pose, new_type, new_v, new_a
        axis.q_limits, axis.index = new_limits, new_index
        group.chain = None

    # -- querying ---------------------------------------------------------------------------

    def axis_group_get_axis_index(self, axis_name: str) -> int:
        """Index of ``axis_name`` in the target and actual position arrays."""
        return self._axis(axis_name).index

    def axis_group_get_axis_name(self, axis_index: int) -> str:
        """Name of the axis at ``axis_index``."""
        for axis in self._axes.values():
            if axis.index == axis_index:
                return axis.name
        raise ValueError(f"no axis has axis_index {axis_index!r}")

    def _members(self, group_name: str) -> list[AxisRecord]:
        if group_name == "":
            return sorted(self._axes.values(), key=lambda a: a.index)
        return self._group(group_name).ordered()

    def axis_group_get_target_positions(self, group_name: str = "") -> Array:
        """Target positions (rad or m) in axis-index order; ``""``: every external axis."""
        return np.array([a.target for a in self._members(group_name)], dtype=np.float64)

    def axis_group_get_actual_positions(self, group_name: str = "") -> Array:
        """Actual positions (rad or m) in axis-index order; ``""``: every external axis."""
        return np.array([a.actual for a in self._members(group_name)], dtype=np.float64)

    def is_moving(self, group_name: str) -> bool:
        """True while a movej or speedj of the group has not come to rest."""
        return self._group(group_name).motion is not None

    # -- moving -----------------------------------------------------------------------------

    def axis_group_offset_positions(self, group_name: str, offset: npt.ArrayLike) -> None:
        """Shift target and actual positions by ``offset`` (axis-index order), in software only."""
        group = self._group(group_name)
        shift = self._sized(group, offset, "offset")
        for axis, delta in zip(group.ordered(), shift, strict=True):
            axis.target += float(delta)
            axis.actual += float(delta)
        if group.motion is not None:
            group.shift = group.shift + shift

    def axis_group_movej(self, group_name: str, q: npt.ArrayLike, a: float, v: float) -> None:
        """Start a synchronized trapezoidal move to ``q`` (axis-index order, rad or m).

        ``a`` and ``v`` in (0, 1] scale each axis's ``a_limit`` and ``v_limit``.
        Targets beyond ``q_limits`` are set to the nearest limit. Targets jump
        to ``q`` at once; ``advance`` moves the actual positions. The move
        starts at rest from the actual positions, replacing any active one.
        """
        group = self._group(group_name)
        goal = self._sized(group, q, "q")
        a_frac, v_frac = check_fraction(a, "a"), check_fraction(v, "v")
        axes = group.ordered()
        lo = np.array([ax.q_limits[0] for ax in axes])
        hi = np.array([ax.q_limits[1] for ax in axes])
        goal = np.clip(goal, lo, hi)
        move = plan_movej(
            self.axis_group_get_actual_positions(group_name),
            goal,
            v_frac * np.array([ax.v_limit for ax in axes]),
            a_frac * np.array([ax.a_limit for ax in axes]),
        )
        for axis, value in zip(axes, goal, strict=True):
            axis.target = float(value)
        self._start(group, move)

    def axis_group_speedj(
        self, group_name: str, qd: npt.ArrayLike, a: float, t: float = -1.0
    ) -> None:
        """Ramp to velocities ``qd`` (axis-index order, rad/s or m/s) and hold them.

        ``a`` in (0, 1] scales each axis's ``a_limit``; ``qd`` beyond ``v_limit``
        is set to the limit. ``t >= 0``: stop after ``t`` seconds; ``t < 0``: hold
        until the next command (``qd = 0`` stops). The ramp starts from the
        current velocity; targets follow the actual positions.
        """
        group = self._group(group_name)
        velocity = self._sized(group, qd, "qd")
        a_frac = check_fraction(a, "a")
        axes = group.ordered()
        v_lim = np.array([ax.v_limit for ax in axes])
        current = np.zeros(len(axes))
        if group.motion is not None:
            current = group.motion.velocity(group.elapsed)
        move = plan_speedj(
            self.axis_group_get_actual_positions(group_name),
            np.clip(velocity, -v_lim, v_lim),
            a_frac * np.array([ax.a_limit for ax in axes]),
            t,
            qd0=current,
        )
        self._start(group, move)

    def _start(self, group: GroupRecord, move: TrapezoidMove | SpeedMove) -> None:
        group.motion, group.elapsed = move, 0.0
        group.shift = np.zeros(len(group.axes))
        if move.duration <= 0.0:
            group.motion = None

    def advance(self, dt: float) -> None:
        """Let ``dt`` seconds pass: every active motion moves its group's actual positions.

        A movej that has arrived leaves actual equal to target exactly; during a
        speedj the targets follow the actual positions.
        """
        if not (math.isfinite(dt) and dt >= 0.0):
            raise ValueError(f"dt must be a finite, non-negative number of seconds, got {dt!r}")
        for group in self._groups.values():
            if group.motion is None:
                continue
            group.elapsed += dt
            done = group.elapsed >= group.motion.duration
            now = group.motion.position(min(group.elapsed, group.motion.duration)) + group.shift
            for axis, value in zip(group.ordered(), now, strict=True):
                if isinstance(group.motion, SpeedMove):
                    axis.target = float(value)
                axis.actual = axis.target if done else float(value)
            if done:
                group.motion = None

    # -- kinematics -------------------------------------------------------------------------

    def _chain(self, group: GroupRecord) -> AxisChain:
        if group.chain is None:
            axes = group.ordered()
            slot = {ax.name: k for k, ax in enumerate(axes)}
            group.chain = build_axis_chain(
                matrix_from_pose_vector(group.pose),
                matrix_from_pose_vector(np.array([ax.pose for ax in axes]).reshape(-1, 6)),
                [slot[ax.parent] if ax.parent else -1 for ax in axes],
                [ax.type == ROTARY for ax in axes],
                [ax.q_limits[0] for ax in axes],
                [ax.q_limits[1] for ax in axes],
            )
        return group.chain

    def link_poses(self, group_name: str, q: npt.ArrayLike) -> tuple[Array, BoolArray]:
        """World (base) poses ``(..., n + 1, 4, 4)`` of the group frame, then each axis frame.

        ``q``: ``(..., n)`` positions (rad or m) in axis-index order; axis frames
        come in the same order, after their joint motion. ``ok`` ``(...)``: every
        position finite and within its ``q_limits``. Hot path: batch-first, the
        constant parts precomputed once per configuration change.
        """
        return self._chain(self._group(group_name)).link_poses(q)

    def frame_pose(self, name: str) -> Array:
        """4x4 world (base) pose of ``"base"``, a group base or an axis, at actual positions."""
        if name == BASE_FRAME:
            return np.eye(4)
        if name in self._groups:
            return matrix_from_pose_vector(self._groups[name].pose)
        axis = self._axis(name)
        group = self._groups[axis.group]
        poses, _ = self.link_poses(group.name, self.axis_group_get_actual_positions(group.name))
        pose: Array = poses[1 + group.ordered().index(axis)]
        return pose

    def params(self, group_name: str) -> dict[str, Any]:
        """JSON-able description of a group, enough for a client to redo the FK.

        ``pose``: group base in the world (base) frame; per axis, in axis-index
        order: ``parent`` (``""``: group base), zero-position ``pose`` in the
        parent frame (UR pose vectors, m and rad), ``type`` (0 rotary about +Z,
        1 linear along +Z), limits (rad or m, per s, per s^2) and ``axis_index``.
        """
        group = self._group(group_name)
        return {
            "name": group.name,
            "pose": [float(x) for x in group.pose],
            "axes": [
                {
                    "name": ax.name,
                    "parent": ax.parent,
                    "pose": [float(x) for x in ax.pose],
                    "type": ax.type,
                    "v_limit": ax.v_limit,
                    "a_limit": ax.a_limit,
                    "q_limits": [ax.q_limits[0], ax.q_limits[1]],
                    "axis_index": ax.index,
                }
                for ax in group.ordered()
            ],
        }
