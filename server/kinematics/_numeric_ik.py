"""Numerical inverse kinematics for any serial chain: damped least squares.

``solve_model`` takes any model giving tip poses and Jacobians (revolute and
prismatic joints alike); ``solve`` is its form for revolute DH chains, whose
Jacobian comes from the frames.

Levenberg-Marquardt with damping after Sugihara (``lambda = g |e|^2 + w``,
``e`` the pose error), joint limits enforced by clipping after each step.
Every target is tried from several starts at once, rows of one batch: the
caller's reference configuration first, then random configurations drawn
within the limits. Every ``RESTART_EVERY`` iterations, a start that is still
far from its target, or has not at least quartered its squared error since the
last check (stuck at a local minimum or a limit), is replaced by a fresh
random one. The generator is seeded, so a call's result depends only on its arguments.

Pose error is taken in the base frame: position in metres, rotation as
``sin(angle) * axis`` of the turn from the current flange orientation to the
target's (the rotation vector, in rad, as it converges).
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass

import numpy as np
import numpy.typing as npt

from ._batch import all_along_last
from ._rotations import wrap_angle

Array = npt.NDArray[np.float64]
BoolArray = npt.NDArray[np.bool_]

STARTS = 8
RESTART_EVERY = 15
MAX_ITERATIONS = 300
TOLERANCE = 1e-10  # on the pose error's norm, position (m) and rotation (rad) together
# Flat indices into a 3x3: rot[_SKEW_A] - rot[_SKEW_B] is 2 sin(angle) axis.
_SKEW_A, _SKEW_B = [7, 2, 3], [5, 6, 1]
# (z r^T) flattened, times this, is z x r.
_LEVI_CIVITA = np.zeros((9, 3))
_LEVI_CIVITA[[5, 6, 1], [0, 1, 2]] = 1.0
_LEVI_CIVITA[[7, 2, 3], [0, 1, 2]] = -1.0
# w (m^2, rad^2): keeps the step defined at singular configurations, yet small
# enough that nearly singular directions (sigma ~ 1e-6) still converge.
DAMPING_FLOOR = 1e-12
DAMPING_GAIN = 0.1  # g: Sugihara's 0.5 damps the first, far-off steps more than needed
RESTART_ABOVE = 1e-3  # a start whose error is still above this at a restart check is redrawn
RESTART_PROGRESS = 0.25  # ... and so is one whose squared error shrank by less than this factor


@dataclass(frozen=True)
class Batch:
    """Inverse-kinematics inputs flattened to rows, with where to start and what to skip.

    ``start`` is ``q_ref`` clipped to the limits (mid-range without it; 0 for
    unlimited joints): what rows that cannot be solved keep.
    """

    lead: tuple[int, ...]
    targets: Array
    """``(m, 4, 4)``."""
    ref: Array | None
    """``(m, n)``, or None without ``q_ref``."""
    finite: BoolArray
    """``(m,)``: rows whose target and reference are finite (the only ones solved)."""
    start: Array
    """``(m, n)``, writable."""


def unlimited(limits: Array) -> Array:
    """Limits shaped like ``limits`` ``(n, 2)`` that hold nothing back: (-inf, +inf) each.

    An inverse asked this way says where a pose is reached at all, to tell a pose
    reached only outside the joint limits from one out of reach.
    """
    out: Array = np.full_like(limits, np.inf) * [-1.0, 1.0]
    return out


def batch(
    pose: npt.ArrayLike,
    q_ref: npt.ArrayLike | None,
    limits: Array,
    joints: Callable[[npt.ArrayLike], Array],
) -> Batch:
    """Flatten ``pose`` ``(..., 4, 4)`` and ``q_ref`` ``(..., n)`` (checked by ``joints``)."""
    target = np.asarray(pose, dtype=np.float64)
    if target.shape[-2:] != (4, 4):
        raise ValueError(f"pose must have shape (..., 4, 4), got {target.shape}")
    lead = target.shape[:-2]
    n = limits.shape[0]
    targets = target.reshape(-1, 4, 4)
    ref = None
    if q_ref is not None:
        ref = np.broadcast_to(joints(q_ref), lead + (n,)).reshape(-1, n)
    finite = all_along_last(np.isfinite(targets.reshape(-1, 16)))
    if ref is not None:
        finite &= all_along_last(np.isfinite(ref))
    middle = 0.5 * np.where(np.isfinite(limits), limits, 0.0).sum(axis=1)
    start = np.clip(middle if ref is None else np.nan_to_num(ref), limits[:, 0], limits[:, 1])
    start = np.array(np.broadcast_to(start, (targets.shape[0], n)))
    return Batch(lead, targets, ref, finite, start)


def pose_error(target: Array, pose: Array) -> tuple[Array, Array]:
    """Pose error ``(..., 6)`` in the base frame, and ``(..., 9)`` of ``R_target R_pose^T``.

    The first three entries are target minus pose position (m); the last three
    are ``sin(angle) * axis`` of the rotation ``R_target R_pose^T`` (rad near
    zero). That also vanishes at a half turn, so a zero error counts only where
    the rotation's trace is above 1 (angle below 90 deg): see ``_small_turn``.
    """
    product = target[..., :3, :3] @ pose[..., :3, :3].swapaxes(-1, -2)
    rot = product.reshape(product.shape[:-2] + (9,))
    turn = rot[..., _SKEW_A] - rot[..., _SKEW_B]
    turn *= 0.5
    return np.concatenate([target[..., :3, 3] - pose[..., :3, 3], turn], axis=-1), rot


def _small_turn(rot: Array) -> BoolArray:
    """True where the flat rotations ``(..., 9)`` turn by less than 90 deg."""
    return np.asarray(rot[..., 0] + rot[..., 4] + rot[..., 8] > 1.0)


def _jacobian_t(frames: Array, modified: bool) -> Array:
    """Transposed geometric Jacobians ``(..., n, 6)`` in the base frame from frames
    ``(..., n + 1, 4, 4)``.

    Row ``i`` is joint ``i``'s twist: ``z_i x (p_flange - o_i)`` then ``z_i``.
    In the standard convention joint ``i`` turns about z of frame ``i - 1``; in
    Craig's, about z of frame ``i`` itself.
    """
    axes = frames[..., 1:, :, :] if modified else frames[..., :-1, :, :]
    z = axes[..., :3, 2]
    r = frames[..., -1:, :3, 3] - axes[..., :3, 3]
    # The cross product as one product with the Levi-Civita symbol.
    linear = (z[..., :, None] * r[..., None, :]).reshape(z.shape[:-1] + (9,)) @ _LEVI_CIVITA
    return np.concatenate([linear, z], axis=-1)


Model = Callable[[Array], tuple[Array, Array]]
"""Configurations ``(m, n)`` -> tip poses ``(m, 4, 4)`` and transposed Jacobians ``(m, n, 6)``."""


def solve(
    frames_of: Callable[[Array], Array],
    modified: bool,
    limits: Array,
    target: Array,
    q_ref: Array | None,
    seed: int = 0,
) -> tuple[Array, BoolArray]:
    """Joints ``(b, n)`` (rad) of a revolute DH chain with its flange on ``target`` ``(b, 4, 4)``.

    ``frames_of`` maps configurations ``(m, n)`` to frames ``(m, n + 1, 4, 4)``;
    see ``solve_model`` for the rest.
    """

    def model(q: Array) -> tuple[Array, Array]:
        frames = frames_of(q)
        return frames[:, -1], _jacobian_t(frames, modified)

    return solve_model(model, limits, target, q_ref, seed)


def solve_model(
    model: Model,
    limits: Array,
    target: Array,
    q_ref: Array | None,
    seed: int = 0,
    periodic: BoolArray | None = None,
) -> tuple[Array, BoolArray]:
    """Joints ``(b, n)`` (rad or m) putting ``model``'s tip on ``target`` ``(b, 4, 4)``.

    ``limits`` ``(n, 2)`` may be infinite; random starts are then drawn in
    [-pi, pi] for that joint. ``periodic`` joints (continuous, rad) are kept
    within half a turn of the reference, which changes no pose. Among a
    target's converged starts the one nearest ``q_ref`` (sum of absolute
    differences) wins. Where nothing converged, ``ok`` is False and the joints
    are ``q_ref`` (or the middle of the limits) clipped to the limits.
    """
    b, n = target.shape[0], limits.shape[0]
    finite = np.isfinite(limits)
    lo = np.where(finite[:, 0], limits[:, 0], -np.pi)
    span = np.where(finite[:, 1], limits[:, 1], np.pi) - lo
    rng = np.random.default_rng(seed)
    ref = np.broadcast_to(lo + 0.5 * span, (b, n)) if q_ref is None else q_ref
    result = np.clip(ref, limits[:, 0], limits[:, 1])
    ok = np.zeros(b, dtype=bool)
    wrap = None if periodic is None or not periodic.any() else np.flatnonzero(periodic)

    # Rows are (target, start): every array below has shape (active targets, STARTS, ...).
    active = np.arange(b)
    q = lo + span * rng.random((b, STARTS, n))
    if q_ref is not None:
        q[:, 0] = result
    goal = target[:, None]
    checked = np.full((b, STARTS), np.inf)  # squared error at the last restart check
    eye = np.eye(n)
    for iteration in range(MAX_ITERATIONS):
        tip, jac_t = model(q.reshape(-1, n))
        tip = tip.reshape(q.shape[:2] + (4, 4))
        jac_t = jac_t.reshape(q.shape + (6,))
        err, rot = pose_error(goal, tip)
        square = np.einsum("...i,...i->...", err, err)
        converged = square < TOLERANCE**2
        if converged.any() and (converged := converged & _small_turn(rot)).any():
            done = converged.any(axis=-1)
            cost = np.where(converged, np.abs(q - ref[active, None]).sum(axis=-1), np.inf)[done]
            result[active[done]] = q[done][np.arange(cost.shape[0]), np.argmin(cost, axis=-1)]
            ok[active[done]] = True
            keep = ~done
            active, goal, q, err, square, jac_t, checked = (
                active[keep],
                goal[keep],
                q[keep],
                err[keep],
                square[keep],
                jac_t[keep],
                checked[keep],
            )
            if active.size == 0:
                break
        hessian = jac_t @ jac_t.swapaxes(-1, -2)
        hessian += (DAMPING_GAIN * square + DAMPING_FLOOR)[..., None, None] * eye
        q += np.linalg.solve(hessian, jac_t @ err[..., None])[..., 0]
        np.maximum(q, limits[:, 0], out=q)
        np.minimum(q, limits[:, 1], out=q)
        if wrap is not None:
            centre = ref[active][:, None, wrap]
            q[..., wrap] = centre + wrap_angle(q[..., wrap] - centre)
        if iteration % RESTART_EVERY == RESTART_EVERY - 1:
            # Redraw stuck starts; ones converging, even slowly, keep going.
            stuck = (square > RESTART_ABOVE**2) | (square > RESTART_PROGRESS * checked)
            q[stuck] = lo + span * rng.random((int(stuck.sum()), n))
            checked = np.where(stuck, np.inf, square)
    return result, ok
