"""KUKA LBR iiwa: a 7-axis ``DHChain`` with the KUKA LBR arm tutorial's geometric inverse.

Frame: the robot base, Z up along joint 1; poses are the flange in that frame.
Units: metres and radians. Convention: standard DH (``DHChain``), with
``d = (d_base, 0, d_upper, 0, d_fore, 0, d_flange)``, ``a = 0`` and
``alpha = (-90, 90, 90, -90, -90, 90, 0)`` degrees.

The inverse follows that tutorial's geometric method. Joints 1-3 form a spherical
shoulder S, joints 5-7 a spherical wrist W = flange - d_flange * z_flange.
With the redundant joint 3 held, the elbow angle comes from the law of cosines
on |SW|, joints 1 and 2 from the direction of SW, and joints 5-7 from the
remaining rotation, which is Z-Y-Z Euler angles. Three binary choices give the
eight configurations, numbered ``k = 4 * arm + 2 * elbow + wrist``:

* ``arm``: the wrist centre lies on the +x (0) or -x (1) side of frame 1
  (with joint 3 at 0, the tutorial's joint 1 and joint 1 + pi);
* ``elbow``: joint 4 is positive (0) or negative (1);
* ``wrist``: joint 6 is positive (0) or negative (1).

Near a straight elbow with the wrist centre on the base axis, joints 1 and 4
rest on square roots of rounding errors (about 1e-8 rad); there ``reached``
can be False for all eight, and ``inverse`` falls back to the numerical solver.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import numpy.typing as npt

from .._rotations import wrap_angle
from .chain import DHChain

Array = npt.NDArray[np.float64]
BoolArray = npt.NDArray[np.bool_]

REACH_TOLERANCE = 1e-9  # m for position, and per rotation-matrix entry
# Below this |sin(joint 6)| the wrist is singular: only joint 5 +- joint 7 is
# defined, and (as in the tutorial) both get half of it.
WRIST_SINGULAR = 1e-12


@dataclass(frozen=True)
class IiwaSolutions:
    """The eight configurations of ``LBRiiwa.inverse_all``, ordered ``4 * arm + 2 * elbow + wrist``.

    ``q``: ``(..., 8, 7)`` rad, each joint wrapped to [-pi, pi).
    ``reached``: ``(..., 8)``, the configuration puts the flange on the pose
    (checked by forward kinematics to ``REACH_TOLERANCE``).
    ``within_limits``: ``(..., 8)``, every joint lies within the joint limits.
    """

    q: Array
    reached: BoolArray
    within_limits: BoolArray


class LBRiiwa(DHChain):
    """A KUKA LBR iiwa with link lengths in metres and limits ``(7, 2)`` rad (see module doc)."""

    def __init__(
        self, d_base: float, d_upper: float, d_fore: float, d_flange: float, limits: Array
    ) -> None:
        super().__init__(
            d=[d_base, 0.0, d_upper, 0.0, d_fore, 0.0, d_flange],
            a=np.zeros(7),
            alpha=np.radians([-90.0, 90.0, 90.0, -90.0, -90.0, 90.0, 0.0]),
            limits=limits,
        )
        self.d_base, self.d_upper, self.d_fore, self.d_flange = d_base, d_upper, d_fore, d_flange

    def _arm(self, wrist: Array, q3: Array) -> tuple[Array, Array, Array, BoolArray]:
        """Joints 1, 2, 4 ``(b, 2 arm, 2 elbow)`` placing the wrist centre (m, base frame)."""
        du, df = self.d_upper, self.d_fore
        sw = wrist - np.array([0.0, 0.0, self.d_base])
        # Law of cosines on the shoulder-upper arm-forearm triangle.
        cos4 = (np.einsum("bi,bi->b", sw, sw) - du * du - df * df) / (2.0 * du * df)
        feasible = np.abs(cos4) <= 1.0 + 1e-12
        q4 = np.arccos(np.clip(cos4, -1.0, 1.0))[:, None] * np.array([1.0, -1.0])  # (b, elbow)
        s4 = np.sin(q4)
        c3, s3 = np.cos(q3)[:, None], np.sin(q3)[:, None]
        # Shoulder-to-wrist in frame 2: v = (-df c3 s4, -df s3 s4, du + df c4). Joint 2
        # turns (vx, vz) onto (u, sw_z), with u the horizontal reach left once joint 1
        # has lined up (u, vy) with (sw_x, sw_y): u = +-sqrt(|sw_xy|^2 - vy^2).
        vx, vy, vz = -df * c3 * s4, -df * s3 * s4, du + df * cos4[:, None]
        u_squared = sw[:, 0, None] ** 2 + sw[:, 1, None] ** 2 - vy * vy
        feasible = feasible[:, None] & (u_squared >= -1e-12)
        u = np.sqrt(np.maximum(u_squared, 0.0))[:, None, :] * np.array([1.0, -1.0])[:, None]
        q2 = np.arctan2(vz, vx)[:, None, :] - np.arctan2(sw[:, 2, None, None], u)
        q1 = np.arctan2(sw[:, 1], sw[:, 0])[:, None, None] - np.arctan2(vy[:, None], u)
        q4 = np.broadcast_to(q4[:, None, :], q1.shape)
        return q1, q2, q4, np.broadcast_to(feasible[:, None, :], q1.shape)

    def inverse_all(self, pose: npt.ArrayLike, q3: npt.ArrayLike) -> IiwaSolutions:
        """All eight configurations reaching flange poses ``(..., 4, 4)``, joint 3 held at ``q3``.

        ``q3`` (rad) broadcasts against the poses' leading axes.
        """
        target = np.asarray(pose, dtype=np.float64)
        lead = target.shape[:-2]
        flat = target.reshape(-1, 4, 4)
        b = flat.shape[0]
        q3_flat = np.broadcast_to(np.asarray(q3, dtype=np.float64), lead).reshape(b)
        rot = flat[:, :3, :3]
        wrist = flat[:, :3, 3] - self.d_flange * rot[:, :, 2]
        q1, q2, q4, feasible = self._arm(wrist, q3_flat)

        # Frame 4's orientation for the four arm/elbow choices, then R_47 = R_04^T R.
        q = np.zeros((b, 2, 2, 2, 7))  # (pose, arm, elbow, wrist, joint)
        q[..., 0] = q1[..., None]
        q[..., 1] = q2[..., None]
        q[..., 2] = q3_flat[:, None, None, None]
        q[..., 3] = q4[..., None]
        frame4 = self._frames(q[:, :, :, 0].reshape(-1, 7))[:, 4, :3, :3].reshape(b, 2, 2, 3, 3)
        m = np.swapaxes(frame4, -1, -2) @ rot[:, None, None]
        # atan2 rather than the tutorial's acos: acos(m22) loses half the digits near 0.
        q6 = np.arctan2(np.hypot(m[..., 0, 2], m[..., 1, 2]), m[..., 2, 2])[..., None]
        q6 = q6 * np.array([1.0, -1.0])
        sign = np.sign(np.sin(q6))
        m = m[..., None, :, :]
        # R_47 = Rz(q5) Ry(q6) Rz(q7).
        q5 = np.arctan2(sign * m[..., 1, 2], sign * m[..., 0, 2])
        singular = np.abs(np.sin(q6)) < WRIST_SINGULAR
        if singular.any():  # the tutorial: joints 5 and 7 share the turn, +pi each on the flip
            flipped = np.cos(q6) < 0.0  # only q5 - q7 defined there
            total = np.arctan2(
                np.where(flipped, -1.0, 1.0) * m[..., 1, 0],
                np.where(flipped, -1.0, 1.0) * m[..., 0, 0],
            )
            q5 = np.where(singular, 0.5 * total + np.array([0.0, np.pi]), q5)
        c5, s5, c6, s6 = np.cos(q5), np.sin(q5), np.cos(q6), np.sin(q6)
        # Joint 7 from Rz(q7) = Ry(-q6) Rz(-q5) R_47, so it absorbs any error in q5.
        q7 = np.arctan2(
            c5 * m[..., 1, 0] - s5 * m[..., 0, 0],
            c6 * (c5 * m[..., 0, 0] + s5 * m[..., 1, 0]) - s6 * m[..., 2, 0],
        )
        q[..., 4], q[..., 5], q[..., 6] = q5, q6, q7
        q8 = wrap_angle(q).reshape(b, 8, 7)

        reached_pose, finite = self.forward(q8)
        error = np.abs(reached_pose - flat[:, None]).max(axis=(-1, -2))
        reached = (
            np.broadcast_to(feasible[..., None], (b, 2, 2, 2)).reshape(b, 8)
            & (error <= REACH_TOLERANCE)
            & finite
        )
        return IiwaSolutions(
            q=q8.reshape(lead + (8, 7)),
            reached=reached.reshape(lead + (8,)),
            within_limits=self.within_limits(q8).reshape(lead + (8,)),
        )

    def configuration_flags(self, q: npt.ArrayLike) -> npt.NDArray[np.int64]:
        """``(arm, elbow, wrist)`` flags ``(..., 3)`` of joints ``q`` ``(..., 7)`` rad.

        The module doc's flags, read off the joints (so also for a solution the
        numerical solver found): ``4 * arm + 2 * elbow + wrist`` is its index in
        ``inverse_all``. ``arm`` is 1 where the wrist centre lies behind joint 1
        (on the -x side of frame 1), ``elbow`` where joint 4 is negative,
        ``wrist`` where joint 6 is negative (KUKA's status bits, in another order).
        """
        joints = np.asarray(q, dtype=np.float64)
        flange, _ = self.forward(joints)
        wrist = flange[..., :3, 3] - self.d_flange * flange[..., :3, 2]
        ahead = np.cos(joints[..., 0]) * wrist[..., 0] + np.sin(joints[..., 0]) * wrist[..., 1]
        flags = np.stack([ahead < 0.0, joints[..., 3] < 0.0, joints[..., 5] < 0.0], axis=-1)
        return flags.astype(np.int64)

    def inverse(
        self, pose: npt.ArrayLike, q_ref: npt.ArrayLike | None = None, limited: bool = True
    ) -> tuple[Array, BoolArray]:
        """Joints ``(..., 7)`` rad putting the flange on ``pose`` ``(..., 4, 4)``, near ``q_ref``.

        Joint 3 is held at ``q_ref[..., 2]``; among the reached configurations
        within the limits, the tutorial's quality function picks the one with the
        smallest sum of |q - q_ref| (``q_ref`` wrapped to [-pi, pi)). Where
        none qualifies, the numerical ``DHChain.inverse`` (all seven joints
        free) takes over; ``ok`` is False where that fails too. ``limited=False``
        is the numerical inverse without limits (``inverse_all`` lists them all).
        """
        if not limited:
            return super().inverse(pose, q_ref, limited=False)
        target = np.asarray(pose, dtype=np.float64)
        lead = target.shape[:-2]
        ref = np.zeros(7) if q_ref is None else np.asarray(q_ref, dtype=np.float64)
        ref = np.broadcast_to(ref, lead + (7,))
        sol = self.inverse_all(target, ref[..., 2])
        usable = sol.reached & sol.within_limits
        cost = np.abs(sol.q - wrap_angle(ref)[..., None, :]).sum(axis=-1)
        best = np.argmin(np.where(usable, cost, np.inf), axis=-1)
        q = np.take_along_axis(sol.q, best[..., None, None], axis=-2)[..., 0, :]
        ok = np.array(usable.any(axis=-1))
        if not ok.all():
            missing = ~ok
            q_num, ok_num = DHChain.inverse(self, target[missing], ref[missing])
            q[missing], ok[missing] = q_num, ok_num
        return q, ok


def iiwa7() -> LBRiiwa:
    """The KUKA LBR iiwa 7 R800: flange 1.266 m above the base at zero joints."""
    limits_deg = np.array([170.0, 120.0, 170.0, 120.0, 170.0, 120.0, 175.0])
    limits = np.radians(np.stack([-limits_deg, limits_deg], axis=-1))
    return LBRiiwa(d_base=0.34, d_upper=0.40, d_fore=0.40, d_flange=0.126, limits=limits)
