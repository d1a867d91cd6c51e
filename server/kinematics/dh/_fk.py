"""Forward-kinematics kernels behind ``DHChain``: one per batch regime, same results.

All three return every frame of the chain (base first, flange last) as 4x4
poses in the base frame, metres and radians. Each joint's transform is split
into the moves of its convention, applied to the frame's columns:

* standard (Denavit-Hartenberg): ``Rz(theta) Tz(d) Tx(a) Rx(alpha)``;
* modified (Craig): ``Rx(alpha) Tx(a) Rz(theta) Tz(d)``, with ``a`` and
  ``alpha`` of row ``i`` being Craig's ``a_{i-1}``, ``alpha_{i-1}``.

``one_config`` runs on Python floats (a NumPy call costs about a microsecond,
more than a whole joint here); ``small_batch`` multiplies stacked 4x4 matrices;
``large_batch`` works on structure-of-arrays columns, contiguous over samples,
in cache-sized blocks that it transposes into the result (see its doc).
"""

from __future__ import annotations

import math
from array import array
from dataclasses import dataclass

import numpy as np
import numpy.typing as npt

from .._rotations import snap_unit
from .._trig import CosSin

Array = npt.NDArray[np.float64]

_IDENTITY = np.eye(4)
BLOCK = 4096  # samples per pass of ``large_batch``; its buffers then fit in L2/L3
_PAD = 8  # doubles after each buffer row: rows 32 KiB apart would share one L1 cache set


@dataclass(frozen=True)
class ChainConstants:
    """Per-joint constants of a chain, precomputed once (lengths in m, angles in rad)."""

    modified: bool
    d: tuple[float, ...]
    a: tuple[float, ...]
    theta_offset_array: Array
    joints: tuple[tuple[float, float, float, float, float], ...]  # offset, cos/sin alpha, a, d
    cos_alpha: tuple[float, ...]
    sin_alpha: tuple[float, ...]
    # Joint transform as c * cos_part + s * sin_part + fixed_part, shape (n, 4, 4).
    cos_part: Array
    sin_part: Array
    fixed_part: Array


def chain_constants(
    d: Array, a: Array, alpha: Array, theta_offset: Array, modified: bool
) -> ChainConstants:
    """Precompute what every kernel needs from the DH table."""
    ca = tuple(snap_unit(math.cos(x)) for x in alpha.tolist())
    sa = tuple(snap_unit(math.sin(x)) for x in alpha.tolist())
    n = len(ca)
    rz_cos = np.diag([1.0, 1.0, 0.0, 0.0])
    rz_sin = np.zeros((4, 4))
    rz_sin[0, 1], rz_sin[1, 0] = -1.0, 1.0
    rz_fixed = np.diag([0.0, 0.0, 1.0, 1.0])
    parts = np.zeros((3, n, 4, 4))
    for i in range(n):
        tz = np.eye(4)
        tz[2, 3] = d[i]
        x_move = np.array(
            [
                [1.0, 0.0, 0.0, a[i]],
                [0.0, ca[i], -sa[i], 0.0],
                [0.0, sa[i], ca[i], 0.0],
                [0.0, 0.0, 0.0, 1.0],
            ]
        )
        before, after = (x_move, tz) if modified else (np.eye(4), tz @ x_move)
        for k, rz in enumerate((rz_cos, rz_sin, rz_fixed)):
            parts[k, i] = before @ rz @ after
    return ChainConstants(
        modified=modified,
        d=tuple(d.tolist()),
        a=tuple(a.tolist()),
        theta_offset_array=theta_offset,
        joints=tuple(zip(theta_offset.tolist(), ca, sa, a.tolist(), d.tolist(), strict=True)),
        cos_alpha=ca,
        sin_alpha=sa,
        cos_part=parts[0],
        sin_part=parts[1],
        fixed_part=parts[2],
    )


def one_config(k: ChainConstants, q: list[float]) -> Array:
    """Frames ``(n + 1, 4, 4)`` of one configuration ``q`` (rad), on Python floats.

    The running frame is twelve locals (rotation columns x, y, z and origin p,
    row by row); each move updates only the columns it touches, and a quarter
    turn about x (most arms' alphas) only swaps y and z with a sign. The two
    conventions are two loops because a branch per move costs as much as a move.
    """
    r00, r01, r02, p0 = 1.0, 0.0, 0.0, 0.0
    r10, r11, r12, p1 = 0.0, 1.0, 0.0, 0.0
    r20, r21, r22, p2 = 0.0, 0.0, 1.0, 0.0
    out = [r00, r01, r02, p0, r10, r11, r12, p1, r20, r21, r22, p2, 0.0, 0.0, 0.0, 1.0]
    cos, sin = math.cos, math.sin
    if k.modified:
        for qi, (off, ca, sa, ai, di) in zip(q, k.joints, strict=True):
            if ca == 0.0:  # Rx(alpha), a quarter turn
                r01, r02, r11, r12, r21, r22 = (
                    sa * r02,
                    -sa * r01,
                    sa * r12,
                    -sa * r11,
                    sa * r22,
                    -sa * r21,
                )
            else:
                r01, r02 = ca * r01 + sa * r02, ca * r02 - sa * r01
                r11, r12 = ca * r11 + sa * r12, ca * r12 - sa * r11
                r21, r22 = ca * r21 + sa * r22, ca * r22 - sa * r21
            if ai:  # Tx(a)
                p0 += ai * r00
                p1 += ai * r10
                p2 += ai * r20
            c, s = cos(qi + off), sin(qi + off)  # Rz(theta)
            r00, r01 = c * r00 + s * r01, c * r01 - s * r00
            r10, r11 = c * r10 + s * r11, c * r11 - s * r10
            r20, r21 = c * r20 + s * r21, c * r21 - s * r20
            if di:  # Tz(d)
                p0 += di * r02
                p1 += di * r12
                p2 += di * r22
            out += (r00, r01, r02, p0, r10, r11, r12, p1, r20, r21, r22, p2, 0.0, 0.0, 0.0, 1.0)
    else:
        for qi, (off, ca, sa, ai, di) in zip(q, k.joints, strict=True):
            c, s = cos(qi + off), sin(qi + off)  # Rz(theta)
            r00, r01 = c * r00 + s * r01, c * r01 - s * r00
            r10, r11 = c * r10 + s * r11, c * r11 - s * r10
            r20, r21 = c * r20 + s * r21, c * r21 - s * r20
            if di:  # Tz(d)
                p0 += di * r02
                p1 += di * r12
                p2 += di * r22
            if ai:  # Tx(a)
                p0 += ai * r00
                p1 += ai * r10
                p2 += ai * r20
            if ca == 0.0:  # Rx(alpha), a quarter turn
                r01, r02, r11, r12, r21, r22 = (
                    sa * r02,
                    -sa * r01,
                    sa * r12,
                    -sa * r11,
                    sa * r22,
                    -sa * r21,
                )
            else:
                r01, r02 = ca * r01 + sa * r02, ca * r02 - sa * r01
                r11, r12 = ca * r11 + sa * r12, ca * r12 - sa * r11
                r21, r22 = ca * r21 + sa * r22, ca * r22 - sa * r21
            out += (r00, r01, r02, p0, r10, r11, r12, p1, r20, r21, r22, p2, 0.0, 0.0, 0.0, 1.0)
    return np.frombuffer(array("d", out)).reshape(-1, 4, 4)


def small_batch(k: ChainConstants, q: Array) -> Array:
    """Frames ``(m, n + 1, 4, 4)`` of configurations ``q`` ``(m, n)`` by stacked 4x4 products."""
    theta = q + k.theta_offset_array
    c, s = np.cos(theta)[..., None, None], np.sin(theta)[..., None, None]
    joint = c * k.cos_part + s * k.sin_part + k.fixed_part
    m, n = q.shape
    out = np.empty((m, n + 1, 4, 4))
    out[:, 0] = _IDENTITY
    out[:, 1] = joint[:, 0]
    for i in range(1, n):
        np.matmul(out[:, i], joint[:, i], out=out[:, i + 1])
    return out


def _turn(
    u: Array,
    v: Array,
    c: Array | float,
    s: Array | float,
    out_u: Array,
    out_v: Array,
    tmp: Array,
) -> None:
    """Columns turned in their plane: ``out_u = c u + s v``, ``out_v = c v - s u``.

    ``out_v`` may be ``u``.
    """
    if isinstance(c, float) and c == 0.0:  # a quarter turn: swap with a sign
        np.multiply(v, s, out=out_u)
        np.multiply(u, -s, out=out_v)
        return
    if isinstance(c, float) and c == 1.0:  # no turn
        out_u[...] = u
        out_v[...] = v
        return
    np.multiply(u, c, out=out_u)
    np.multiply(v, s, out=tmp)
    out_u += tmp
    np.multiply(u, s, out=tmp)
    np.multiply(v, c, out=out_v)
    out_v -= tmp


def _shift(p: Array, length: float, axis: Array, out: Array, tmp: Array) -> None:
    """Origin moved along a column: ``out = p + length * axis`` (``out`` may be ``p``)."""
    if length == 0.0:
        if out is not p:
            out[...] = p
        return
    np.multiply(axis, length, out=tmp)
    np.add(p, tmp, out=out)


def large_batch(k: ChainConstants, q: Array, flange_only: bool = False) -> Array:
    """Frames ``(m, n + 1, 4, 4)`` of configurations ``q`` ``(m, n)``, for large ``m``.

    With ``flange_only`` the result is the flange alone, ``(m, 4, 4)``.

    Written for speed on 100 000 configurations, whose 102 MB of frames cost
    about as much to write as to compute. The folds below only move exact
    operations (signs, factors of +-1), so the rounding is that of the plain
    column updates:

    * Samples go through in blocks of ``BLOCK``; a block's frames are built in
      ``soa[frame, 4 * row + col, sample]``, all 16 entries with the constant
      ones preset, so each update is a pass over data in cache and the result
      is written once, by one transposing copy per block.
    * A NumPy call on these strided views costs about 2 us of its own plus
      its passes over memory, so a joint is as few calls as possible: the
      turn by the joint angle updates two columns at once on pair views,
      ``[x, y] [c, c] + [y, x] [s, -s]``, and with a quarter turn about x
      (most arms) that turn's sign and swap are folded into the coefficients.
    * Cos and sin come from ``CosSin``, per block (in cache): about twice as
      fast as any libm call, which NumPy makes one element at a time here.
    * The last block overlaps the one before instead of being shorter, so
      every block has the same width and the views are made once.
    """
    m, n = q.shape
    b = min(m, BLOCK)
    soa = np.empty((n + 1, 16, b + _PAD))[:, :, :b]
    soa[...] = _IDENTITY.reshape(16, 1)  # the base frame, and every frame's bottom row
    # Each frame's rows 0-2 as (3, 4, b): row, column (x, y, z, p), sample.
    frames = soa[:, :12].reshape(n + 1, 3, 4, b)
    x, y, z, p = (frames[:, :, col] for col in range(4))
    xy, yx, xz, yp = (
        frames[:, :, cols]
        for cols in (slice(0, 2), slice(1, None, -1), slice(0, None, 2), slice(1, None, 2))
    )
    # Standard convention with a quarter turn about x: [x', z'] = [x, y] [c, -sa c] + [y, x]
    # [s, sa s] and [y', p'] = z [sa, d] + [0, p]; otherwise [x', y_theta] with [c, c], [s, -s].
    quarter = [not k.modified and ca == 0.0 for ca in k.cos_alpha]
    sa_fold = [sa if fold else 0.0 for fold, sa in zip(quarter, k.sin_alpha, strict=True)]
    kc = np.array([-sa if sa else 1.0 for sa in sa_fold])[:, None]
    ks = np.array([sa if sa else -1.0 for sa in sa_fold])[:, None]
    y_and_p = [np.array([[sa], [d]]) for sa, d in zip(k.sin_alpha, k.d, strict=True)]
    offset = bool(k.theta_offset_array.any())
    t = np.empty((n, b))
    cos_sin = CosSin((n, b))
    cos, sin = np.empty((2, 2, n, b))  # [c, kc c] and [s, ks s] of every joint
    tmp = np.empty((3, 2, b))
    tm = tmp[:, 0]
    out = np.empty((m, 16) if flange_only else (m, n + 1, 16))
    for start in (*range(0, m - b, b), m - b):
        theta = q[start : start + b].T
        if offset:
            theta = np.add(theta, k.theta_offset_array[:, None], out=t)
        cos_sin(theta, cos[0], sin[0])
        np.multiply(cos[0], kc, out=cos[1])
        np.multiply(sin[0], ks, out=sin[1])
        for i in range(n):
            ca, sa, a, d, j = k.cos_alpha[i], k.sin_alpha[i], k.a[i], k.d[i], i + 1
            if k.modified:  # Rx(alpha) Tx(a) Rz(theta) Tz(d)
                _turn(y[i], z[i], ca, sa, y[j], z[j], tm)
                _shift(p[i], a, x[i], p[j], tm)
                np.copyto(x[j], x[i])
                np.multiply(yx[j], sin[:, i], out=tmp)
                np.multiply(xy[j], cos[:, i], out=xy[j])
                xy[j] += tmp
                _shift(p[j], d, z[j], p[j], tm)
                continue
            # Standard: Rz(theta) Tz(d) Tx(a) Rx(alpha).
            np.multiply(yx[i], sin[:, i], out=tmp)
            np.multiply(xy[i], cos[:, i], out=xz[j])
            xz[j] += tmp
            if quarter[i]:
                np.multiply(z[i][:, None], y_and_p[i], out=yp[j])
                p[j] += p[i]
                _shift(p[j], a, x[j], p[j], tm)
            else:  # y turned by theta waits in z'
                _shift(p[i], d, z[i], p[j], tm)
                _shift(p[j], a, x[j], p[j], tm)
                _turn(z[j], z[i], ca, sa, y[j], z[j], tm)
        if flange_only:
            np.copyto(out[start : start + b], soa[n].T)
        else:
            np.copyto(out[start : start + b], soa.transpose(2, 0, 1))
    if flange_only:
        return out.reshape(m, 4, 4)
    return out.reshape(m, n + 1, 4, 4)
