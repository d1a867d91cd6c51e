"""Forward kinematics of one axis group, with its constant parts folded in (hot path).

Frames: the world is the robot's base frame. Slot 0 of the result is the
group's base frame; slot ``k + 1`` is the ``k``-th axis in axis-index order,
after its joint motion: ``T_axis = T_parent @ T_zero @ J(q)`` where ``T_zero``
is the axis's zero-position pose in its parent frame and ``J`` turns about
(type 0, rotary, rad) or moves along (type 1, linear, m) the local +Z.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import numpy.typing as npt

Array = npt.NDArray[np.float64]
BoolArray = npt.NDArray[np.bool_]
IntArray = npt.NDArray[np.intp]


@dataclass(frozen=True, eq=False)
class AxisChain:
    """Precomputed FK of one group; build it with :func:`build_axis_chain`.

    An axis's local pose ``T_zero @ Rz(angle) @ Tz(shift)`` is split into
    ``const_part + cos(angle) * cos_part + sin(angle) * sin_part + shift *
    shift_part``, each ``(n, 4, 4)`` and already premultiplied by the group pose
    for axes on the group base, so those need no product at run time.
    ``levels``: for each deeper depth, the result slots of its axes and of their
    parents (plain ints for a single axis, which index faster); one batched
    product per level. ``lower``, ``upper``: finite position limits.
    """

    group_pose: Array
    const_part: Array
    cos_part: Array
    sin_part: Array
    shift_part: Array
    rotary: BoolArray
    linear: BoolArray
    lower: Array
    upper: Array
    levels: tuple[tuple[IntArray | int, IntArray | int], ...]
    any_rotary: bool
    any_linear: bool

    @property
    def n_axes(self) -> int:
        """Number of axes in the group."""
        return int(self.rotary.size)

    def link_poses(self, q: npt.ArrayLike) -> tuple[Array, BoolArray]:
        """World poses ``(..., n + 1, 4, 4)`` of the group frame and each axis frame.

        ``q``: ``(..., n)`` axis positions (rad or m) in axis-index order.
        ``ok`` ``(...)``: every position finite and within its ``q_limits``.
        Non-finite positions are computed as 0 so the poses stay finite.
        """
        qa = np.asarray(q, dtype=np.float64)
        n = self.n_axes
        if qa.ndim == 0 or qa.shape[-1] != n:
            raise ValueError(f"q must have shape (..., {n}) in axis-index order, got {qa.shape}")
        # The limits are finite, so NaN and +-inf fail these comparisons too.
        # ndarray.all is a few microseconds faster than np.all on small inputs.
        ok: BoolArray = np.asarray(((qa >= self.lower) & (qa <= self.upper)).all(axis=-1))
        if not ok.all():
            qa = np.where(np.isfinite(qa), qa, 0.0)
        out = np.empty(qa.shape[:-1] + (n + 1, 4, 4))
        out[..., 0, :, :] = self.group_pose
        local = out[..., 1:, :, :]
        if self.any_rotary:
            angle = qa * self.rotary if self.any_linear else qa
            np.multiply(np.cos(angle)[..., None, None], self.cos_part, out=local)
            local += np.sin(angle)[..., None, None] * self.sin_part
            local += self.const_part
        else:
            local[...] = self.const_part + self.cos_part
        if self.any_linear:
            shift = qa * self.linear if self.any_rotary else qa
            local += shift[..., None, None] * self.shift_part
        for child, parent in self.levels:
            out[..., child, :, :] = out[..., parent, :, :] @ out[..., child, :, :]
        return out, ok


def build_axis_chain(
    group_pose: Array,
    zero_poses: Array,
    parents: list[int],
    rotary: list[bool],
    lower: list[float],
    upper: list[float],
) -> AxisChain:
    """Fold the constant parts of a group's chain.

    ``group_pose``: 4x4 world pose of the group base. ``zero_poses``:
    ``(n, 4, 4)`` in axis-index order. ``parents[k]``: position in that order of
    axis ``k``'s parent, or -1 for the group base. The parents must form a tree.
    """
    n = len(parents)
    depth = [0] * n
    for k in range(n):
        seen: set[int] = set()
        j = k
        while parents[j] >= 0:
            if j in seen:
                raise ValueError("the axes form a closed chain")
            seen.add(j)
            j = parents[j]
            depth[k] += 1
    zero_local = np.array(zero_poses, dtype=np.float64).reshape(n, 4, 4)
    for k in range(n):
        if parents[k] < 0:
            zero_local[k] = group_pose @ zero_local[k]
    const_part = zero_local.copy()
    const_part[:, :, :2] = 0.0
    cos_part = np.zeros_like(zero_local)
    cos_part[:, :, :2] = zero_local[:, :, :2]
    # Column 0 of T @ Rz gains sin * col 1 and column 1 loses sin * col 0.
    sin_part = np.zeros_like(zero_local)
    sin_part[:, :, 0] = zero_local[:, :, 1]
    sin_part[:, :, 1] = -zero_local[:, :, 0]
    shift_part = np.zeros_like(zero_local)
    shift_part[:, :, 3] = zero_local[:, :, 2]
    levels: list[tuple[IntArray | int, IntArray | int]] = []
    for d in range(1, max(depth, default=0) + 1):
        members = [k for k in range(n) if depth[k] == d]
        if len(members) == 1:
            levels.append((members[0] + 1, parents[members[0]] + 1))
        else:
            levels.append(
                (
                    np.array([k + 1 for k in members], dtype=np.intp),
                    np.array([parents[k] + 1 for k in members], dtype=np.intp),
                )
            )
    rot = np.array(rotary, dtype=np.bool_).reshape(n)
    biggest = np.finfo(np.float64).max
    return AxisChain(
        group_pose=np.array(group_pose, dtype=np.float64),
        const_part=const_part,
        cos_part=cos_part,
        sin_part=sin_part,
        shift_part=shift_part,
        rotary=rot,
        linear=~rot,
        lower=np.clip(np.array(lower, dtype=np.float64), -biggest, biggest),
        upper=np.clip(np.array(upper, dtype=np.float64), -biggest, biggest),
        levels=tuple(levels),
        any_rotary=bool(rot.any()),
        any_linear=not bool(rot.all()),
    )
