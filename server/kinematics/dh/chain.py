"""Serial revolute chains described by a Denavit-Hartenberg table.

Frame: the robot base; every pose is a 4x4 homogeneous matrix in that frame.
Units: metres and radians. Conventions: ``"standard"`` DH, where joint ``i``
contributes ``Rz(theta_i) Tz(d_i) Tx(a_i) Rx(alpha_i)``, or ``"modified"``
(Craig, the KUKA LBR arm tutorial's ``GetTransformationMatrix``), where it contributes
``Rx(alpha_{i-1}) Tx(a_{i-1}) Rz(theta_i) Tz(d_i)``; in that case row ``i`` of
``a`` and ``alpha`` holds Craig's ``a_{i-1}`` and ``alpha_{i-1}``, as in
roboticstoolbox's ``RevoluteMDH``. ``theta_i = q_i + theta_offset_i``.
"""

from __future__ import annotations

import math
from typing import Any, Literal

import numpy as np
import numpy.typing as npt

from .. import _numeric_ik
from .._batch import all_along_last, finite_rows
from . import _fk

Array = npt.NDArray[np.float64]
BoolArray = npt.NDArray[np.bool_]
Convention = Literal["standard", "modified"]

# Below this many configurations, stacked 4x4 products beat the column kernel.
_LARGE_BATCH = 256


def _vector(values: npt.ArrayLike, n: int, name: str) -> Array:
    out = np.array(values, dtype=np.float64).reshape(-1)
    if out.shape != (n,):
        raise ValueError(f"{name} must have {n} entries, got {out.shape[0]}")
    out.flags.writeable = False
    return out


class DHChain:
    """A serial chain of revolute joints from a DH table (m, rad; see the module doc).

    ``d``, ``a``, ``alpha``, ``theta_offset`` have one entry per joint;
    ``limits`` is ``(n, 2)`` rad, lower then upper, or None for no limits.
    """

    def __init__(
        self,
        d: npt.ArrayLike,
        a: npt.ArrayLike,
        alpha: npt.ArrayLike,
        theta_offset: npt.ArrayLike | None = None,
        convention: Convention = "standard",
        limits: npt.ArrayLike | None = None,
    ) -> None:
        if convention not in ("standard", "modified"):
            raise ValueError(f"convention must be 'standard' or 'modified', got {convention!r}")
        n = np.size(d)
        self.n_joints: int = n
        self.convention: Convention = convention
        self.d = _vector(d, n, "d")
        self.a = _vector(a, n, "a")
        self.alpha = _vector(alpha, n, "alpha")
        self.theta_offset = _vector(
            np.zeros(n) if theta_offset is None else theta_offset, n, "theta_offset"
        )
        self.limits: Array | None = None
        if limits is not None:
            lim = np.array(limits, dtype=np.float64)
            if lim.shape != (n, 2) or not np.all(lim[:, 0] <= lim[:, 1]):
                raise ValueError(f"limits must be (n, 2) = ({n}, 2) with lower <= upper")
            lim.flags.writeable = False
            self.limits = lim
        self._k = _fk.chain_constants(
            self.d, self.a, self.alpha, self.theta_offset, convention == "modified"
        )

    def params(self) -> dict[str, Any]:
        """The DH table as JSON-able lists (m, rad), enough for a client to redo the FK."""
        return {
            "d": self.d.tolist(),
            "a": self.a.tolist(),
            "alpha": self.alpha.tolist(),
            "theta_offset": self.theta_offset.tolist(),
            "convention": self.convention,
            "limits": None if self.limits is None else self.limits.tolist(),
        }

    def _frames(self, q: Array) -> Array:
        """Frames ``(m, n + 1, 4, 4)`` of configurations ``(m, n)``, by the faster kernel."""
        if q.shape[0] < _LARGE_BATCH:
            return _fk.small_batch(self._k, q)
        return _fk.large_batch(self._k, q)

    def _joints(self, q: npt.ArrayLike) -> Array:
        arr = np.asarray(q, dtype=np.float64)
        if arr.ndim == 0 or arr.shape[-1] != self.n_joints:
            raise ValueError(f"q must have shape (..., {self.n_joints}), got {arr.shape}")
        return arr

    def link_poses(self, q: npt.ArrayLike) -> tuple[Array, BoolArray]:
        """Base (identity) and every link frame, flange last: ``(..., n + 1, 4, 4)``.

        ``q`` is ``(..., n)`` rad. ``ok`` is False where a joint is not finite;
        such joints are taken as 0 so the poses stay finite.
        """
        arr = self._joints(q)
        if arr.ndim == 1:  # the server's hot path: one configuration, no NumPy per joint
            joints = arr.tolist()
            ok = all(map(math.isfinite, joints))
            if not ok:
                joints = [x if math.isfinite(x) else 0.0 for x in joints]
            return _fk.one_config(self._k, joints), np.array(ok)
        arr, ok_rows = finite_rows(arr)
        lead = arr.shape[:-1]
        flat = arr.reshape(-1, self.n_joints)
        poses = self._frames(flat).reshape(lead + (self.n_joints + 1, 4, 4))
        return poses, ok_rows

    def forward(self, q: npt.ArrayLike) -> tuple[Array, BoolArray]:
        """Flange poses ``(..., 4, 4)`` in the base frame for joints ``q`` ``(..., n)`` rad.

        ``ok`` as in ``link_poses``.
        """
        arr = self._joints(q)
        if arr.ndim > 1 and arr.size >= _LARGE_BATCH * self.n_joints:
            arr, ok_rows = finite_rows(arr)
            flange = _fk.large_batch(self._k, arr.reshape(-1, self.n_joints), flange_only=True)
            return flange.reshape(arr.shape[:-1] + (4, 4)), ok_rows
        poses, ok = self.link_poses(arr)
        return np.ascontiguousarray(poses[..., -1, :, :]), ok

    def joint_limits(self) -> Array:
        """Limits ``(n, 2)`` rad; a chain without limits gets ``[-pi, pi]`` for each joint."""
        if self.limits is not None:
            return self.limits
        return np.tile([-np.pi, np.pi], (self.n_joints, 1))

    def within_limits(self, q: npt.ArrayLike) -> BoolArray:
        """True where every joint of ``q`` ``(..., n)`` lies within the limits (inclusive)."""
        lim = self.joint_limits()
        arr = self._joints(q)
        return all_along_last((arr >= lim[:, 0]) & (arr <= lim[:, 1]))

    def inverse(
        self, pose: npt.ArrayLike, q_ref: npt.ArrayLike | None = None, limited: bool = True
    ) -> tuple[Array, BoolArray]:
        """Joints ``(..., n)`` rad within the limits putting the flange on ``pose`` ``(..., 4, 4)``.

        ``limited=False`` ignores the limits: where is a pose reached at all.

        Numerical (damped least squares from ``q_ref`` and seeded random starts,
        see ``_numeric_ik``); among the solutions found, the one nearest
        ``q_ref`` ``(..., n)`` is returned. ``ok`` is False where no start
        converged (pose error below 1e-10, m and rad) or the input is not
        finite; there ``q`` is ``q_ref`` clipped to the limits (or mid-range).
        """
        lim = self.joint_limits()
        if not limited:  # where it is reached at all, whatever the limits say
            lim = _numeric_ik.unlimited(lim)
        rows = _numeric_ik.batch(pose, q_ref, lim, self._joints)
        q, finite = rows.start, rows.finite
        ok = np.zeros(len(q), dtype=bool)
        if finite.any():
            q[finite], ok[finite] = _numeric_ik.solve(
                self._frames,
                self._k.modified,
                lim,
                rows.targets[finite],
                None if rows.ref is None else rows.ref[finite],
            )
        return q.reshape(rows.lead + (self.n_joints,)), ok.reshape(rows.lead)
