"""IndraMotion MLC kinematic Type 12: a planar five-bar parallel mechanism.

As Bosch Rexroth's note "ctrlX CORE: CODESYS SoftMotion" implements it.

Frame: the robot base, Z up; the mechanism moves in the base XY plane (z = 0).
Units: metres and radians. Joint ``a0`` turns link L1, joint ``a1`` turns L5;
both are zero in the note's reference posture, where O, T, E, W form a
parallelogram (E = T + W).

Each link pose puts the link's frame at its pivot with local +X pointing along
the bar, which is how the meshes in ``assets/`` are modelled:

* ``L1``: pivot O, towards T;   * ``L5``: pivot O, towards W;
* ``L4``: pivot W, towards E;   * ``L2``: pivot T, through E to the TCP.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import numpy.typing as npt

from ._rotations import planar_poses, wrap_angle

Array = npt.NDArray[np.float64]
BoolArray = npt.NDArray[np.bool_]

LINK_NAMES: tuple[str, ...] = ("L1", "L5", "L4", "L2")
# The TCP pose at the base orientation, as planar_poses builds it (with rot_z(0)'s -0.0).
_TCP_POSE = planar_poses(np.zeros(2), np.zeros(()))
_BLOCK = 8192  # configurations per pass of ``forward``


def _circle_circle_xy(
    x0: Array, y0: Array, r0: float, x1: Array, y1: Array, r1: float, direction: int
) -> tuple[Array, Array, BoolArray]:
    """``circle_circle_intersection`` on separate x and y arrays (the hot path's form)."""
    dx, dy = x1 - x0, y1 - y0
    dist = np.hypot(dx, dy)
    safe = np.where(dist > 0.0, dist, 1.0)
    cos_t = (dist**2 + r0**2 - r1**2) / (2.0 * safe * r0)
    # The note states 0 < cos < 1; geometrically the circles meet for |cos| <= 1
    # (an obtuse angle at c0 is a valid posture), so that is the test used here.
    ok = (dist > 0.0) & (np.abs(cos_t) <= 1.0)
    cos_t = np.clip(cos_t, -1.0, 1.0)
    sin_t = direction * np.sqrt(1.0 - cos_t**2)
    ux, uy = dx / safe * r0, dy / safe * r0
    x = np.where(ok, x0 + (cos_t * ux - sin_t * uy), x0)
    y = np.where(ok, y0 + (sin_t * ux + cos_t * uy), y0)
    return x, y, ok


def circle_circle_intersection(
    c0: Array, r0: float, c1: Array, r1: float, direction: int
) -> tuple[Array, BoolArray]:
    """One intersection point of two circles, the CODESYS SoftMotion note's appendix 5.1.

    Law of cosines at ``c0``: the point on circle 0 towards ``c1`` is turned by
    ``direction * theta`` (+1 the note's left-hand, -1 its right-hand solution).
    ``ok`` is False where the circles do not meet; there the point is ``c0``,
    never NaN. Centres have shape ``(..., 2)``.
    """
    c0, c1 = np.asarray(c0, dtype=np.float64), np.asarray(c1, dtype=np.float64)
    c0, c1 = np.broadcast_arrays(c0, c1)
    x, y, ok = _circle_circle_xy(c0[..., 0], c0[..., 1], r0, c1[..., 0], c1[..., 1], r1, direction)
    return np.stack([x, y], -1), ok


@dataclass(frozen=True)
class Type12:
    """Type 12 mechanism; link lengths in metres (default: the note's 200/150/100/200/100 mm)."""

    l1: float = 0.2
    l2: float = 0.15
    l3: float = 0.1
    l4: float = 0.2
    l5: float = 0.1

    n_joints = 2
    link_names = LINK_NAMES

    def params(self) -> dict[str, float]:
        """Link lengths (m) keyed as in the note: L1..L5."""
        return {"L1": self.l1, "L2": self.l2, "L3": self.l3, "L4": self.l4, "L5": self.l5}

    def _points_xy(self, q: Array) -> tuple[list[Array], BoolArray]:
        """x and y (m, base XY) of T, W, E and the TCP for joints ``q`` (rad): AxesToCartesian.

        Separate x and y arrays: ``forward`` is a hot batch path and stacking
        pairs costs more than the maths. Non-finite joints are computed as zero
        and reported in ``ok``.
        """
        q = np.asarray(q, dtype=np.float64)
        finite = np.ones(q.shape[:-1], dtype=bool)
        if not np.isfinite(q).all():
            finite = np.asarray(np.isfinite(q).all(axis=-1), dtype=bool)
            q = np.where(finite[..., None], q, 0.0)
        # T at angle a0 + 180 deg and W at a1 + 270 deg (the note), by identities
        # rather than shifted angles: two passes fewer, and exact at the zero posture.
        a0, a1 = q[..., 0], q[..., 1]
        tx, ty = -self.l1 * np.cos(a0), -self.l1 * np.sin(a0)
        wx, wy = self.l5 * np.sin(a1), -self.l5 * np.cos(a1)
        # E: circles (T, L3) and (W, L4), the note's right-hand solution.
        ex, ey, ok = _circle_circle_xy(tx, ty, self.l3, wx, wy, self.l4, -1)
        ok &= finite
        scale = self.l2 / self.l3
        tcp_x, tcp_y = tx + (ex - tx) * scale, ty + (ey - ty) * scale
        return [tx, ty, wx, wy, ex, ey, tcp_x, tcp_y], ok

    def forward(self, q: Array) -> tuple[Array, BoolArray]:
        """TCP poses ``(..., 4, 4)`` for joints ``q`` of shape ``(..., 2)`` (rad).

        The TCP keeps the base orientation (the note sets a zero rotation).
        ``ok`` is False where the links cannot close or a joint is not finite;
        the pose there is finite but meaningless.
        """
        joints = np.asarray(q, dtype=np.float64)
        flat = joints.reshape(-1, 2)
        pose = np.empty((flat.shape[0], 4, 4))
        pose[...] = _TCP_POSE
        ok = np.empty(flat.shape[0], dtype=bool)
        # Blocks keep the temporaries small and in cache; a whole-batch pass
        # spends more time in page faults and memory traffic than in the maths.
        for start in range(0, flat.shape[0], _BLOCK):
            stop = start + _BLOCK
            xy, ok[start:stop] = self._points_xy(flat[start:stop])
            pose[start:stop, 0, 3] = xy[6]
            pose[start:stop, 1, 3] = xy[7]
        lead = joints.shape[:-1]
        return pose.reshape(lead + (4, 4)), ok.reshape(lead)

    def link_poses(self, q: Array) -> tuple[Array, BoolArray]:
        """Poses ``(..., 4, 4, 4)`` of L1, L5, L4, L2 (``LINK_NAMES`` order) for joints ``q``."""
        (tx, ty, wx, wy, ex, ey, _, _), ok = self._points_xy(q)
        zero = np.zeros_like(tx)
        pivots = np.stack([zero, zero, zero, zero, wx, wy, tx, ty], -1).reshape(tx.shape + (4, 2))
        heading = np.arctan2(
            np.stack([ty, wy, ey - wy, ey - ty], -1), np.stack([tx, wx, ex - wx, ex - tx], -1)
        )
        return planar_poses(pivots, heading), ok

    def inverse(self, pose: Array, q_ref: Array | None = None) -> tuple[Array, BoolArray]:
        """Joints ``(..., 2)`` (rad, in [-pi, pi)) putting the TCP at ``pose`` ``(..., 4, 4)``.

        ``q_ref`` is accepted for a uniform interface and not used: the note's
        branch choices give one solution.

        The note's CartesianToAxes: T from circles (O, L1) and (TCP, L2) with the
        right-hand branch, E on the bar, W from circles (O, L5) and (E, L4)
        with the left-hand branch. Only the XY position is used.
        """
        tcp = np.asarray(pose, dtype=np.float64)[..., :2, 3]
        origin = np.zeros_like(tcp)
        t, ok_t = circle_circle_intersection(origin, self.l1, tcp, self.l2, -1)
        e = t + (tcp - t) * (self.l3 / self.l2)
        w, ok_w = circle_circle_intersection(origin, self.l5, e, self.l4, 1)
        a0 = wrap_angle(np.arctan2(t[..., 1], t[..., 0]) - np.pi)
        a1 = wrap_angle(np.arctan2(w[..., 1], w[..., 0]) - 1.5 * np.pi)
        ok = ok_t & ok_w & np.isfinite(tcp).all(axis=-1)
        return np.stack([a0, a1], -1), ok
