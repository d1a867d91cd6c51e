"""The forward-kinematics kernels behind ``UrdfChain``: one per batch regime, same results.

* ``BatchKernel`` (large batches) and ``ScalarKernel`` (one configuration) run
  the same ``_program``; ``SmallBatchKernel`` multiplies stacked 4x4
  joint transforms, which has the least overhead for a few hundred samples.
* ``BatchKernel``: the columns of every buffer are ``(3, samples)`` arrays, so
  each operation is a few long contiguous NumPy passes; samples go through in
  blocks of ``BLOCK`` so the buffers stay in cache until they are written out.
* ``ScalarKernel``: one configuration on Python floats. A NumPy call costs
  about a microsecond, more than a whole joint in plain arithmetic, so the
  program is turned into straight-line Python source once (constants folded,
  zero terms dropped, one line per matrix entry) and compiled; a call is then a
  few microseconds.

All three return frames as 4x4 poses in the root-link frame (m, rad).
"""

from __future__ import annotations

import math
import struct
from collections.abc import Callable

import numpy as np
import numpy.typing as npt

from .._trig import CosSin
from ._program import Buf, Lin, Out, Program, Slide, Turn, Vec
from ._tree import Tree

Array = npt.NDArray[np.float64]
BLOCK = 4096  # samples per pass: the buffers and the frames being built stay in cache
_PAD = 8  # doubles after each row of the frames being built (see ``BatchKernel.__call__``)

_BOTTOM = np.array([0.0, 0.0, 0.0, 1.0])


class BatchKernel:
    """Frames ``(m, n_frames, 4, 4)`` of configurations ``(m, n)`` by column passes."""

    def __init__(self, prog: Program) -> None:
        self.prog = prog
        rows = prog.rows
        self._turn_rows = [i for i, row in enumerate(rows) if row.revolute]
        self._slide_rows = [i for i, row in enumerate(rows) if not row.revolute]
        # Where a row's values land: index into the cos/sin rows or into the slide rows.
        self._row_at = {r: k for k, r in enumerate(self._turn_rows)}
        self._row_at.update({r: k for k, r in enumerate(self._slide_rows)})
        self._turn_src = np.array([rows[r].source for r in self._turn_rows], dtype=np.intp)
        self._turn_mul = np.array([rows[r].multiplier for r in self._turn_rows])[:, None]
        self._turn_off = np.array([rows[r].offset for r in self._turn_rows])[:, None]
        self._slide_src = np.array([rows[r].source for r in self._slide_rows], dtype=np.intp)
        self._slide_mul = np.array([rows[r].multiplier for r in self._slide_rows])[:, None]
        self._slide_off = np.array([rows[r].offset for r in self._slide_rows])[:, None]
        self._turn_pick, self._slide_pick = _pick(self._turn_src), _pick(self._slide_src)
        self._turn_offset = bool(self._turn_off.any())
        self._consts: dict[Vec, Array] = {}
        # A buffer written out unchanged lives in its first output column: no copy.
        home: dict[int, tuple[int, int]] = {}
        for op in prog.ops:
            if isinstance(op, Out) and isinstance(op.src, Buf) and op.src.sign > 0.0:
                home.setdefault(op.src.index, (op.frame, op.col))
        self._home = home
        self._const_outs = [
            op for op in prog.ops if isinstance(op, Out) and not isinstance(op.src, Buf)
        ]
        self._ops = [
            op
            for op in prog.ops
            if not isinstance(op, Out)
            or (isinstance(op.src, Buf) and home.get(op.src.index) != (op.frame, op.col))
        ]

    def _const(self, vec: Vec) -> Array:
        found = self._consts.get(vec)
        if found is None:
            found = self._consts[vec] = np.array(vec).reshape(3, 1)
        return found

    def _rows(self, q: Array, rows: Array, cos_sin: CosSin) -> None:
        """Per sample of ``q`` ``(b, n)``: cos and sin of every turn, every slide's value.

        ``rows`` is ``(4, max(turns, slides), b)``: cos, sin, slide value, and
        the turns' angles.
        """
        k = self._turn_src.size
        cos, sin, slide, angle = rows[0, :k], rows[1, :k], rows[2], rows[3, :k]
        np.multiply(_joint_rows(q, self._turn_pick), self._turn_mul, out=angle)
        if self._turn_offset:
            angle += self._turn_off
        cos_sin(angle, cos, sin)
        if self._slide_src.size:
            value = slide[: self._slide_src.size]
            np.multiply(_joint_rows(q, self._slide_pick), self._slide_mul, out=value)
            value += self._slide_off

    def __call__(self, q: Array) -> Array:
        prog = self.prog
        m = q.shape[0]
        out = np.empty((m, prog.n_frames, 16))
        # Every block is ``b`` wide, the last one overlapping the one before,
        # so the views below are made once.
        b = min(m, BLOCK)
        store = np.empty((prog.n_slots + 1, 3, b + _PAD))[:, :, :b]  # the last slot is scratch
        rows = np.empty((4, max(self._turn_src.size, self._slide_src.size), b))
        cos_sin = CosSin((self._turn_src.size, b))
        # Frames are put together column by column in cache, as rows of
        # ``soa[frame, 4 * row + col, sample]``, then transposed into the result
        # one block at a time. The padding keeps the rows off the same cache
        # sets; without it that transpose runs 3x slower.
        soa = np.empty((prog.n_frames, 16, b + _PAD))[:, :, :b]
        soa[:, 12:] = _BOTTOM[:, None]
        for const in self._const_outs:
            soa[const.frame, const.col : 12 : 4] = np.asarray(const.src)[:, None]
        bufs = [
            soa[self._home[i][0], self._home[i][1] : 12 : 4]
            if i in self._home
            else store[prog.slots[i]]
            for i in range(prog.n_buffers)
        ]
        for start in (*range(0, m - b, b), m - b):
            self._rows(q[start : start + b], rows, cos_sin)
            self._block(bufs, store[-1], rows[:3], soa)
            np.copyto(out[start : start + b], soa.transpose(2, 0, 1))
        return out.reshape(m, prog.n_frames, 4, 4)

    def _block(self, bufs: list[Array], tmp: Array, rows: Array, soa: Array) -> None:
        """Run the program on one block: ``rows`` from ``_rows``, frames into ``soa``."""
        cos, sin, slide = rows
        for op in self._ops:
            if isinstance(op, Turn):
                k = self._row_at[op.row]
                c, s = cos[k], sin[k]
                u, v = self._operand(bufs, op.u), self._operand(bufs, op.v)
                du, dv = bufs[op.dst_u], bufs[op.dst_v]
                np.multiply(u, c, out=du)
                np.multiply(v, s, out=tmp)
                du += tmp
                np.multiply(v, c, out=dv)
                np.multiply(u, s, out=tmp)
                dv -= tmp
            elif isinstance(op, Out):  # a copy, or a negated one
                assert isinstance(op.src, Buf)
                view = soa[op.frame, op.col : 12 : 4]
                if op.src.sign > 0.0:
                    np.copyto(view, bufs[op.src.index])
                else:
                    np.negative(bufs[op.src.index], out=view)
            elif isinstance(op, Lin):
                dst = bufs[op.dst]
                _lin(dst, [(wt, bufs[i]) for wt, i in op.terms], tmp)
                if op.const is not None:
                    dst += self._const(op.const)
            else:  # Slide
                dst = bufs[op.dst]
                value = slide[self._row_at[op.row]]
                np.multiply(self._operand(bufs, op.axis), value, out=dst)
                dst += self._operand(bufs, op.p)

    def _operand(self, bufs: list[Array], x: int | Vec) -> Array:
        return bufs[x] if isinstance(x, int) else self._const(x)


def _pick(columns: npt.NDArray[np.intp]) -> slice | npt.NDArray[np.intp]:
    """``columns`` as a slice where they are consecutive (the usual case): a view, no gather."""
    if columns.size and np.array_equal(columns, np.arange(columns[0], columns[0] + columns.size)):
        return slice(int(columns[0]), int(columns[0]) + columns.size)
    return columns


def _joint_rows(q: Array, pick: slice | npt.NDArray[np.intp]) -> Array:
    """Columns ``pick`` of ``q`` ``(b, n)`` as rows ``(k, b)``."""
    return q.T[pick] if isinstance(pick, slice) else q[:, pick].T


def _lin(dst: Array, terms: list[tuple[float, Array]], tmp: Array) -> None:
    """``dst = sum(weight * column)``; unit weights add without a multiplication."""
    (first_w, first), rest = terms[0], terms[1:]
    if first_w == 1.0:
        np.copyto(dst, first)
    elif first_w == -1.0:
        np.negative(first, out=dst)
    else:
        np.multiply(first, first_w, out=dst)
    for weight, col in rest:
        if weight == 1.0:
            dst += col
        elif weight == -1.0:
            dst -= col
        else:
            np.multiply(col, weight, out=tmp)
            dst += tmp


Expr = float | str
"""A matrix entry in generated code: a constant, or the name of a local variable."""


class _Source:
    """Straight-line Python for one configuration, built a line at a time."""

    def __init__(self) -> None:
        self.lines: list[str] = []
        self.count = 0

    def value(self, terms: list[tuple[float, tuple[Expr, ...]]]) -> Expr:
        """``sum(weight * product(factors))`` as a constant, an existing name or a new local."""
        const = 0.0
        merged: dict[tuple[str, ...], float] = {}
        for weight, factors in terms:
            variables: list[str] = []
            for factor in factors:
                if isinstance(factor, str):
                    variables.append(factor)
                else:
                    weight *= factor
            if weight == 0.0:
                continue
            if not variables:
                const += weight
            else:
                key = tuple(variables)
                merged[key] = merged.get(key, 0.0) + weight
        parts = [(w, names) for names, w in merged.items() if w != 0.0]
        if not parts:
            return const
        if const == 0.0 and len(parts) == 1 and parts[0][0] == 1.0 and len(parts[0][1]) == 1:
            return parts[0][1][0]
        code = ""
        for weight, names in parts:
            product = "*".join(names)
            if weight == 1.0:
                code += f" + {product}"
            elif weight == -1.0:
                code += f" - {product}"
            else:
                code += f" + {weight!r}*{product}"
        if const != 0.0:
            code += f" + {const!r}"
        name = f"e{self.count}"
        self.count += 1
        self.lines.append(f"    {name} = {code.strip().removeprefix('+ ')}")
        return name


def _entry_code(value: Expr, sign: float) -> str:
    if isinstance(value, str):
        return value if sign > 0.0 else f"-{value}"
    return repr(sign * value)


class ScalarKernel:
    """Frames ``(n_frames, 4, 4)`` of one configuration (a list of floats), by generated code."""

    def __init__(self, prog: Program) -> None:
        src = _Source()
        params = [f"q{i}" for i in range(prog.n_joints)]
        rows: list[tuple[Expr, Expr]] = []
        for r, row in enumerate(prog.rows):
            angle = src.value([(row.multiplier, (f"q{row.source}",)), (row.offset, ())])
            if row.revolute:
                arg = _entry_code(angle, 1.0)
                src.lines.append(f"    c{r} = cos({arg}); s{r} = sin({arg})")
                rows.append((f"c{r}", f"s{r}"))
            else:
                rows.append((angle, 0.0))
        entries: dict[int, list[Expr]] = {}

        def col(x: int | Vec) -> list[Expr]:
            return entries[x] if isinstance(x, int) else list(x)

        out: list[str] = ["0.0", "0.0", "0.0", "1.0"] * 4 * prog.n_frames
        for op in prog.ops:
            if isinstance(op, Turn):
                c, s = rows[op.row]
                u, v = col(op.u), col(op.v)
                entries[op.dst_u] = [
                    src.value([(1.0, (c, u[r])), (1.0, (s, v[r]))]) for r in range(3)
                ]
                entries[op.dst_v] = [
                    src.value([(1.0, (c, v[r])), (-1.0, (s, u[r]))]) for r in range(3)
                ]
            elif isinstance(op, Lin):
                const = op.const or (0.0, 0.0, 0.0)
                entries[op.dst] = [
                    src.value([(w, (entries[i][r],)) for w, i in op.terms] + [(const[r], ())])
                    for r in range(3)
                ]
            elif isinstance(op, Slide):
                t, p, a = rows[op.row][0], col(op.p), col(op.axis)
                entries[op.dst] = [src.value([(1.0, (p[r],)), (1.0, (t, a[r]))]) for r in range(3)]
            else:  # Out
                values, sign = (
                    (entries[op.src.index], op.src.sign)
                    if isinstance(op.src, Buf)
                    else (list(op.src), 1.0)
                )
                for r in range(3):
                    out[16 * op.frame + 4 * r + op.col] = _entry_code(values[r], sign)
        body = "\n".join(src.lines)
        code = f"def frames({', '.join(params)}):\n{body}\n    return pack({', '.join(out)})\n"
        # Packing the doubles straight into bytes is the cheapest way into an array.
        pack = struct.Struct(f"{len(out)}d").pack
        namespace: dict[str, object] = {"cos": math.cos, "sin": math.sin, "pack": pack}
        exec(compile(code, "<urdf forward kinematics>", "exec"), namespace)  # noqa: S102
        self.source = code
        self._frames: Callable[..., bytes] = namespace["frames"]  # type: ignore[assignment]
        self._shape = (prog.n_frames, 4, 4)

    def __call__(self, q: list[float]) -> Array:
        return np.frombuffer(bytearray(self._frames(*q))).reshape(self._shape)


def _cross_matrix(a: Array) -> Array:
    return np.array([[0.0, -a[2], a[1]], [a[2], 0.0, -a[0]], [-a[1], a[0], 0.0]])


class SmallBatchKernel:
    """Frames ``(m, n_frames, 4, 4)`` of configurations ``(m, n)`` by stacked 4x4 products.

    Each joint's transform is ``u * A + v * B + C`` with constant 4x4 parts:
    ``u, v`` are the cos and sin of a revolute joint's angle (Rodrigues:
    ``R = c (I - a a^T) + s [a]x + a a^T``) or a prismatic joint's value and 0.
    """

    def __init__(self, tree: Tree, outputs: list[int]) -> None:
        self._links = tree.needed(outputs)
        at = {link: k for k, link in enumerate(self._links)}
        self._outputs = [at[link] for link in outputs]
        self._parent = [at.get(tree.links[i].parent, -1) for i in self._links]
        n = len(self._links)
        parts = np.zeros((3, n, 4, 4))
        self._source = np.zeros(n, dtype=np.intp)
        self._multiplier, self._offset = np.zeros(n), np.zeros(n)
        self._revolute = np.zeros(n, dtype=bool)
        for k, i in enumerate(self._links):
            link = tree.links[i]
            a = link.axis
            move = np.zeros((3, 4, 4))
            if link.kind == "revolute":
                move[0, :3, :3] = np.eye(3) - np.outer(a, a)
                move[1, :3, :3] = _cross_matrix(a)
                move[2, :3, :3] = np.outer(a, a)
                move[2, 3, 3] = 1.0
            elif link.kind == "prismatic":
                move[0, :3, 3] = a
                move[2] = np.eye(4)
            else:
                move[2] = np.eye(4)
            parts[:, k] = link.origin @ move
            if link.source >= 0:
                self._source[k] = link.source
                self._multiplier[k], self._offset[k] = link.multiplier, link.offset
            self._revolute[k] = link.kind == "revolute"
        self._a, self._b, self._c = parts

    def __call__(self, q: Array) -> Array:
        m = q.shape[0]
        value = np.take(q, self._source, axis=1) if q.shape[1] else np.zeros((m, self._source.size))
        value = value * self._multiplier + self._offset
        u = np.where(self._revolute, np.cos(value), value)[..., None, None]
        v = np.where(self._revolute, np.sin(value), 0.0)[..., None, None]
        joint = u * self._a + v * self._b + self._c
        frames = np.empty((m, len(self._links), 4, 4))
        for k, parent in enumerate(self._parent):
            if parent < 0:
                frames[:, k] = joint[:, k]
            else:
                np.matmul(frames[:, parent], joint[:, k], out=frames[:, k])
        return frames[:, self._outputs]
