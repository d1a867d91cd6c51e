"""Numerical inverse for axis groups whose axes form one chain of rotary axes.

Frame: the world (base) frame of the ``WorldModel``; units m and rad. Each
axis turns about the z of its own frame, which is exactly Craig's (modified)
DH arrangement of ``link_poses`` frames, so the damped-least-squares solver of
the DH chains serves here unchanged.
"""

from __future__ import annotations

import numpy as np
import numpy.typing as npt

from . import _numeric_ik
from .axis_group import WorldModel

Array = npt.NDArray[np.float64]
BoolArray = npt.NDArray[np.bool_]


def serial_rotary_inverse(
    world: WorldModel,
    group: str,
    pose: npt.ArrayLike,
    q_ref: npt.ArrayLike | None = None,
    limited: bool = True,
) -> tuple[Array, BoolArray]:
    """Positions ``(..., n)`` (rad, axis-index order) putting the last axis frame on ``pose``.

    ``pose``: ``(..., 4, 4)`` world poses. Among converged solutions the one
    nearest ``q_ref`` wins. ``ok`` is False where no start converged (a group
    with fewer than six axes reaches only poses on its own manifold).
    ``limited=False`` ignores the axes' limits (to tell a pose reached only
    outside them from one out of reach). Raises ValueError for groups that are
    not a single chain of rotary axes.
    """
    params = world.params(group)
    axes = params["axes"]
    chained = all(ax["parent"] == (axes[i - 1]["name"] if i else "") for i, ax in enumerate(axes))
    if not axes or not chained or any(ax["type"] != 0 for ax in axes):
        raise ValueError(f"axis group {group!r}: inverse needs one chain of rotary axes")
    limits = np.array([ax["q_limits"] for ax in axes], dtype=np.float64)
    if not limited:
        limits = _numeric_ik.unlimited(limits)
    target = np.asarray(pose, dtype=np.float64)
    lead = target.shape[:-2]
    ref = (
        None
        if q_ref is None
        else np.broadcast_to(np.asarray(q_ref, dtype=np.float64), lead + (len(axes),)).reshape(
            -1, len(axes)
        )
    )

    def frames_of(q: Array) -> Array:
        frames, _ = world.link_poses(group, q)
        return frames

    q, ok = _numeric_ik.solve(frames_of, True, limits, target.reshape(-1, 4, 4), ref)
    return q.reshape(lead + (len(axes),)), ok.reshape(lead)
