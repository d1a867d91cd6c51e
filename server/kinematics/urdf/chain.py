"""Robots described as a URDF joint tree: revolute, continuous, prismatic, fixed and mimic joints.

Frame: the root link; every pose is a 4x4 homogeneous matrix in that frame.
Units: metres for prismatic joints and lengths, radians for revolute and
continuous joints. Conventions are URDF's: a link's frame is its parent's,
moved by the joint origin and then by the joint's motion about (revolute,
continuous) or along (prismatic) the joint axis, given in that joint frame.
A mimic joint takes ``multiplier * q_other + offset``. Joint values are given
for the movable, non-mimic joints, in the order the description lists them.

This module is pure numpy; ``server.urdf`` reads files into a ``UrdfTree``.
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np
import numpy.typing as npt

from .. import _numeric_ik
from .._batch import finite_rows
from . import _tree
from ._kernels import BatchKernel, ScalarKernel, SmallBatchKernel
from ._program import compile_frames
from .description import UrdfTree

Array = npt.NDArray[np.float64]
BoolArray = npt.NDArray[np.bool_]
# Below this many configurations, stacked 4x4 products beat the column kernel.
_LARGE_BATCH = 256


class _Kernels:
    """The frames of some links by the kernel that suits the batch size."""

    def __init__(self, tree: _tree.Tree, outputs: list[int]) -> None:
        program = compile_frames(tree, outputs)
        self.one = ScalarKernel(program)
        self._small = SmallBatchKernel(tree, outputs)
        self._large = BatchKernel(program)

    def batch(self, q: Array) -> Array:
        """Frames ``(m, n_frames, 4, 4)`` of configurations ``(m, n)``."""
        return self._small(q) if q.shape[0] < _LARGE_BATCH else self._large(q)


class UrdfChain:
    """Forward and inverse kinematics of a ``UrdfTree`` (m, rad; see the module doc).

    ``tip`` names the link ``forward`` and ``inverse`` work on; by default the
    deepest link (most joints from the root; the first in ``link_names`` on a tie).
    """

    def __init__(self, tree: UrdfTree, tip: str | None = None) -> None:
        self._tree = _tree.build(tree)
        links = self._tree.links
        self.n_joints: int = len(self._tree.joint_names)
        self.joint_names: tuple[str, ...] = self._tree.joint_names
        """Movable, non-mimic joints in description order: the order of ``q``."""
        self.joint_types: tuple[str, ...] = self._tree.joint_types
        self.joint_units: tuple[str, ...] = tuple(
            "m" if kind == "prismatic" else "rad" for kind in self.joint_types
        )
        self.link_names: tuple[str, ...] = self._tree.names()
        """Every link, root first, a parent always before its children."""
        limits = self._tree.limits.copy()
        limits.flags.writeable = False
        self.limits: Array = limits
        """``(n, 2)`` lower, upper (rad or m); continuous joints have -inf, +inf."""
        if tip is None:
            deepest = max(link.depth for link in links)
            tip = next(link.name for link in links if link.depth == deepest)
        self.tip: str = tip
        tip_index = self._tree.index(tip)
        self._all = _Kernels(self._tree, list(range(len(links))))
        self._tip = _Kernels(self._tree, [tip_index])
        self._init_inverse(self._tree.path(tip_index))

    def _init_inverse(self, path: list[int]) -> None:
        """What ``inverse`` needs: the joints that move the tip, and their Jacobian's pieces."""
        links = self._tree.links
        moving = [i for i in path if links[i].kind in ("revolute", "prismatic")]
        self._active = np.array(sorted({links[i].source for i in moving}), dtype=np.intp)
        self._path = _Kernels(self._tree, path)
        at = {link: k for k, link in enumerate(path)}
        self._moving_at = np.array([at[i] for i in moving], dtype=np.intp)
        self._moving_axes = np.array([links[i].axis for i in moving]).reshape(-1, 3)
        self._moving_revolute = np.array([links[i].kind == "revolute" for i in moving])
        # d(joint value)/d(active q): the mimic multipliers, one row per active joint.
        spread = np.zeros((self._active.size, len(moving)))
        for j, i in enumerate(moving):
            spread[np.searchsorted(self._active, links[i].source), j] = links[i].multiplier
        self._spread = spread

    def params(self) -> dict[str, Any]:
        """Joint names, types, units and limits (None where unlimited), link names and tip."""
        return {
            "joint_names": list(self.joint_names),
            "joint_types": list(self.joint_types),
            "joint_units": list(self.joint_units),
            "limits": [
                [x if math.isfinite(x) else None for x in row] for row in self.limits.tolist()
            ],
            "link_names": list(self.link_names),
            "tip": self.tip,
        }

    def _joints(self, q: npt.ArrayLike) -> Array:
        arr = np.asarray(q, dtype=np.float64)
        if arr.ndim == 0 or arr.shape[-1] != self.n_joints:
            raise ValueError(f"q must have shape (..., {self.n_joints}), got {arr.shape}")
        return arr

    def _run(self, q: npt.ArrayLike, kernels: _Kernels) -> tuple[Array, BoolArray]:
        arr = self._joints(q)
        if arr.ndim == 1:  # the server's hot path: one configuration, no NumPy per joint
            joints = arr.tolist()
            ok = all(map(math.isfinite, joints))
            if not ok:
                joints = [x if math.isfinite(x) else 0.0 for x in joints]
            return kernels.one(joints), np.array(ok)
        arr, ok_rows = finite_rows(arr)
        lead = arr.shape[:-1]
        frames = kernels.batch(arr.reshape(math.prod(lead), self.n_joints))
        return frames.reshape(lead + frames.shape[1:]), ok_rows

    def link_poses(self, q: npt.ArrayLike) -> tuple[Array, BoolArray]:
        """Every link's pose ``(..., n_links, 4, 4)`` in the root-link frame, ``link_names`` order.

        ``q`` is ``(..., n)`` (rad, m). ``ok`` is False where a joint is not
        finite; such joints are taken as 0 so the poses stay finite.
        """
        return self._run(q, self._all)

    def forward(self, q: npt.ArrayLike) -> tuple[Array, BoolArray]:
        """The tip link's pose ``(..., 4, 4)`` in the root-link frame.

        ``q`` is ``(..., n)`` (rad, m); ``ok`` as in ``link_poses``.
        """
        poses, ok = self._run(q, self._tip)
        return poses[..., 0, :, :], ok

    def _model(self, q_active: Array) -> tuple[Array, Array]:
        """Tip poses ``(m, 4, 4)`` and transposed Jacobians ``(m, k, 6)`` over the active joints."""
        q = np.zeros((q_active.shape[0], self.n_joints))
        q[:, self._active] = q_active
        frames = self._path.batch(q)
        tip = frames[:, -1]
        joint_frames = frames[:, self._moving_at]
        # Each moving joint's axis and position in the root frame.
        axes = (joint_frames[..., :3, :3] @ self._moving_axes[..., None])[..., 0]
        lever = tip[:, None, :3, 3] - joint_frames[..., :3, 3]
        rev = self._moving_revolute[:, None]
        linear = np.where(rev, np.cross(axes, lever), axes)
        twists = np.concatenate([linear, np.where(rev, axes, 0.0)], axis=-1)
        return tip, self._spread @ twists

    def inverse(
        self, pose: npt.ArrayLike, q_ref: npt.ArrayLike | None = None, limited: bool = True
    ) -> tuple[Array, BoolArray]:
        """Joints ``(..., n)`` (rad, m) within the limits that put the tip on ``pose``.

        ``limited=False`` ignores the limits: where is a pose reached at all.

        ``pose`` is ``(..., 4, 4)`` in the root-link frame.

        Numerical: damped least squares from ``q_ref`` and seeded random starts
        over the joints that move the tip (see ``_numeric_ik``); among the
        solutions found, the one nearest ``q_ref`` ``(..., n)`` is returned.
        Joints that do not move the tip keep ``q_ref``. ``ok`` is False where no
        start converged (pose error below 1e-10, m and rad) or the input is not
        finite; there ``q`` is ``q_ref`` clipped to the limits (or mid-range,
        0 for continuous joints).
        """
        lim = self.limits
        if not limited:  # where it is reached at all, whatever the limits say
            lim = _numeric_ik.unlimited(lim)
        todo = _numeric_ik.batch(pose, q_ref, lim, self._joints)
        lead, flat_target, ref, finite = todo.lead, todo.targets, todo.ref, todo.finite
        q = todo.start
        ok = np.zeros(len(q), dtype=bool)
        act = self._active
        if finite.any() and act.size:
            types = np.array(self.joint_types)[act]
            solved, ok[finite] = _numeric_ik.solve_model(
                self._model,
                lim[act],
                flat_target[finite],
                None if ref is None else ref[finite][:, act],
                periodic=types == "continuous",
            )
            rows = q[finite]
            rows[:, act] = solved
            q[finite] = rows
        elif finite.any():  # nothing moves the tip: solved only where it already is
            tip, _ = self.forward(q[finite])
            err, rot = _numeric_ik.pose_error(flat_target[finite], tip)
            ok[finite] = (np.linalg.norm(err, axis=-1) < _numeric_ik.TOLERANCE) & (
                rot[:, 0] + rot[:, 4] + rot[:, 8] > 1.0
            )
        return q.reshape(lead + (self.n_joints,)), ok.reshape(lead)
