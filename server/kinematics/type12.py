"""IndraMotion kinematic Type 12: a planar five-bar parallel mechanism (seed 000).

Frame: the robot base, Z up; the mechanism moves in the base XY plane (z = 0).
Units: metres and radians. Joint ``a0`` turns link L1, joint ``a1`` turns L5;
both are zero in the seed's reference posture, where O, T, E, W form a
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

from ._rotations import planar_poses

Array = npt.NDArray[np.float64]
BoolArray = npt.NDArray[np.bool_]

LINK_NAMES: tuple[str, ...] = ("L1", "L5", "L4", "L2")


def circle_circle_intersection(
    c0: Array, r0: float | Array, c1: Array, r1: float | Array, direction: int
) -> tuple[Array, BoolArray]:
    """One intersection point of two circles, seed 000 appendix 5.1.

    Law of cosines at ``c0``: the point on circle 0 towards ``c1`` is turned by
    ``direction * theta`` (+1 the seed's left-hand, -1 its right-hand solution).
    ``ok`` is False where the circles do not meet; there the point is ``c0``,
    never NaN. Centres have shape ``(..., 2)``.
    """
    d = c1 - c0
    dist = np.hypot(d[..., 0], d[..., 1])
    safe = np.where(dist > 0.0, dist, 1.0)
    cos_t = (dist**2 + r0**2 - r1**2) / (2.0 * safe * r0)
    # The seed states 0 < cos < 1; geometrically the circles meet for |cos| <= 1
    # (an obtuse angle at c0 is a valid posture), so that is the test used here.
    ok = (dist > 0.0) & (np.abs(cos_t) <= 1.0)
    cos_t = np.clip(cos_t, -1.0, 1.0)
    sin_t = direction * np.sqrt(1.0 - cos_t**2)
    u = d / safe[..., None] * np.asarray(r0)[..., None]
    point = np.stack(
        [cos_t * u[..., 0] - sin_t * u[..., 1], sin_t * u[..., 0] + cos_t * u[..., 1]], -1
    )
    return np.where(ok[..., None], c0 + point, c0), ok


def _wrap(angle: Array) -> Array:
    """Angles wrapped to [-pi, pi)."""
    return (angle + np.pi) % (2.0 * np.pi) - np.pi


@dataclass(frozen=True)
class Type12:
    """Type 12 mechanism; link lengths in metres (default: the seed's 200/150/100/200/100 mm)."""

    l1: float = 0.2
    l2: float = 0.15
    l3: float = 0.1
    l4: float = 0.2
    l5: float = 0.1

    n_joints = 2
    link_names = LINK_NAMES

    def params(self) -> dict[str, float]:
        """Link lengths (m) keyed as in the seed: L1..L5."""
        return {"L1": self.l1, "L2": self.l2, "L3": self.l3, "L4": self.l4, "L5": self.l5}

    def _points(self, q: Array) -> tuple[Array, Array, Array, Array, BoolArray]:
        """Points T, W, E and the TCP (m, base XY) for joints ``q`` (rad), seed AxesToCartesian."""
        q = np.asarray(q, dtype=np.float64)
        ang_t = q[..., 0] + np.pi
        ang_w = q[..., 1] + 1.5 * np.pi
        t = self.l1 * np.stack([np.cos(ang_t), np.sin(ang_t)], -1)
        w = self.l5 * np.stack([np.cos(ang_w), np.sin(ang_w)], -1)
        e, ok = circle_circle_intersection(t, self.l3, w, self.l4, -1)
        ok &= np.isfinite(q).all(axis=-1)
        tcp = t + (e - t) * (self.l2 / self.l3)
        return t, w, e, tcp, ok

    def forward(self, q: Array) -> tuple[Array, BoolArray]:
        """TCP poses ``(..., 4, 4)`` for joints ``q`` of shape ``(..., 2)`` (rad).

        The TCP keeps the base orientation (the seed sets a zero rotation).
        """
        _, _, _, tcp, ok = self._points(q)
        return planar_poses(tcp, np.zeros(tcp.shape[:-1])), ok

    def link_poses(self, q: Array) -> tuple[Array, BoolArray]:
        """Poses ``(..., 4, 4, 4)`` of L1, L5, L4, L2 (``LINK_NAMES`` order) for joints ``q``."""
        t, w, e, _, ok = self._points(q)
        origin = np.zeros_like(t)
        pivots = np.stack([origin, origin, w, t], -2)
        tips = np.stack([t, w, e, e], -2)
        d = tips - pivots
        return planar_poses(pivots, np.arctan2(d[..., 1], d[..., 0])), ok

    def inverse(self, pose: Array) -> tuple[Array, BoolArray]:
        """Joints ``(..., 2)`` (rad, in [-pi, pi)) putting the TCP at ``pose`` ``(..., 4, 4)``.

        Seed CartesianToAxes: T from circles (O, L1) and (TCP, L2) with the
        right-hand branch, E on the bar, W from circles (O, L5) and (E, L4)
        with the left-hand branch. Only the XY position is used.
        """
        tcp = np.asarray(pose, dtype=np.float64)[..., :2, 3]
        origin = np.zeros_like(tcp)
        t, ok_t = circle_circle_intersection(origin, self.l1, tcp, self.l2, -1)
        e = t + (tcp - t) * (self.l3 / self.l2)
        w, ok_w = circle_circle_intersection(origin, self.l5, e, self.l4, 1)
        a0 = _wrap(np.arctan2(t[..., 1], t[..., 0]) - np.pi)
        a1 = _wrap(np.arctan2(w[..., 1], w[..., 0]) - 1.5 * np.pi)
        ok = ok_t & ok_w & np.isfinite(tcp).all(axis=-1)
        return np.stack([a0, a1], -1), ok
