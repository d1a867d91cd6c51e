"""A URDF tree's forward kinematics compiled to a short list of column operations.

A link frame is four columns in the root frame: the x, y, z axes and the
origin. Each column is either a constant 3-vector (the root, and whatever only
fixed joints separate from it) or a buffer of per-sample values with a sign.
Compiling does all the work that does not depend on the joint values once:

* a joint origin whose rotation is a signed permutation (rpy in quarter turns,
  as in most robot descriptions) only renames and re-signs columns: no operation;
* a revolute joint about +-x, +-y or +-z turns two columns in their plane
  (``Turn``), a prismatic one moves the origin along a column (``Slide``);
  any other axis is brought onto z by a constant rotation before and after;
* sums of columns with constant weights (``Lin``) fold constants together.

The batch and single-configuration kernels in ``_kernels`` run the same list,
so they cannot disagree about the kinematics. Buffers are numbered as they are
created; ``Program.slots`` maps them onto as few reusable slots as the
operations' lifetimes allow, so the batch kernel's work set stays in cache.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass, field

import numpy as np
import numpy.typing as npt

from .._rotations import snap_unit
from ._tree import Tree

Array = npt.NDArray[np.float64]
Vec = tuple[float, float, float]

# Columns each principal axis turns, (u, v): u' = c u + s v, v' = c v - s u.
_PLANE = {0: (1, 2), 1: (2, 0), 2: (0, 1)}


@dataclass(frozen=True)
class Buf:
    """Column held in buffer ``index``, times ``sign`` (+-1)."""

    index: int
    sign: float = 1.0


Col = Buf | Vec
"""A frame column: a buffer with a sign, or a constant 3-vector."""


@dataclass(frozen=True)
class Row:
    """Joint value ``multiplier * q[source] + offset``; a turn's sign is in both numbers."""

    source: int
    multiplier: float
    offset: float
    revolute: bool


@dataclass(frozen=True)
class Lin:
    """``dst = const + sum(weight * buffer)``."""

    dst: int
    terms: tuple[tuple[float, int], ...]
    const: Vec | None


@dataclass(frozen=True)
class Turn:
    """``dst_u = c u + s v`` and ``dst_v = c v - s u`` with ``c, s`` of row ``row``'s angle."""

    dst_u: int
    dst_v: int
    u: int | Vec
    v: int | Vec
    row: int


@dataclass(frozen=True)
class Slide:
    """``dst = p + value(row) * axis``."""

    dst: int
    p: int | Vec
    axis: int | Vec
    row: int


@dataclass(frozen=True)
class Out:
    """Write column ``col`` (0-2 axes, 3 origin) of output frame ``frame``."""

    frame: int
    col: int
    src: Col


Op = Lin | Turn | Slide | Out


@dataclass
class Program:
    """Operations computing some link frames of a tree, and where the results go."""

    n_joints: int
    rows: list[Row] = field(default_factory=list)
    ops: list[Op] = field(default_factory=list)
    n_buffers: int = 0
    n_frames: int = 0
    slots: list[int] = field(default_factory=list)  # buffer index -> reusable slot
    n_slots: int = 0

    def buffer(self) -> int:
        self.n_buffers += 1
        return self.n_buffers - 1


def _snap(matrix: Array) -> Array:
    return np.array([snap_unit(x) for x in matrix.reshape(-1).tolist()]).reshape(matrix.shape)


def _combine(prog: Program, terms: Sequence[tuple[float | np.float64, Col]]) -> Col:
    """The column ``sum(weight * column)``, with an operation only where one is needed."""
    const = np.zeros(3)
    weights: dict[int, float] = {}
    for weight_, col in terms:
        weight = float(weight_)  # NumPy scalars would print as np.float64(...) in generated code
        if weight == 0.0:
            continue
        if isinstance(col, Buf):
            weights[col.index] = weights.get(col.index, 0.0) + weight * col.sign
        else:
            const += weight * np.asarray(col)
    weights = {index: w for index, w in weights.items() if w != 0.0}
    vec: Vec = (float(const[0]), float(const[1]), float(const[2]))
    if not weights:
        return vec
    if len(weights) == 1 and not const.any():
        ((index, w),) = weights.items()
        if abs(w) == 1.0:
            return Buf(index, w)
    dst = prog.buffer()
    ordered = sorted(weights.items(), key=lambda item: item[1] == 1.0)  # unit weights last
    prog.ops.append(Lin(dst, tuple((w, i) for i, w in ordered), vec if const.any() else None))
    return Buf(dst)


def _rotate(prog: Program, frame: list[Col], rot: Array, shift: Array) -> list[Col]:
    """``frame @ [[rot, shift], [0, 1]]`` for a constant rotation and translation."""
    axes = [_combine(prog, [(rot[k, j], frame[k]) for k in range(3)]) for j in range(3)]
    origin = _combine(prog, [(1.0, frame[3])] + [(shift[k], frame[k]) for k in range(3)])
    return axes + [origin]


def _unsigned(col: Col) -> tuple[int | Vec, float]:
    """The buffer or constant behind ``col``, and the sign taken out of it."""
    if isinstance(col, Buf):
        return col.index, col.sign
    return col, 1.0


def _axis_onto_z(axis: Array) -> Array:
    """A rotation whose z column is ``axis`` (unit)."""
    helper = np.eye(3)[int(np.argmin(np.abs(axis)))]
    x = np.cross(helper, axis)
    x /= np.linalg.norm(x)
    return np.column_stack([x, np.cross(axis, x), axis])


def _principal(axis: Array) -> tuple[int, float] | None:
    """(index, sign) if ``axis`` is +-x, +-y or +-z, else None."""
    k = int(np.argmax(np.abs(axis)))
    if abs(axis[k]) == 1.0 and np.count_nonzero(axis) == 1:
        return k, float(np.sign(axis[k]))
    return None


def _move(prog: Program, tree: Tree, i: int, frame: list[Col]) -> list[Col]:
    """The child frame of link ``i`` from its parent's ``frame``."""
    link = tree.links[i]
    origin = _snap(link.origin)
    rot, shift = origin[:3, :3], origin[:3, 3]
    if link.kind == "fixed":
        return _rotate(prog, frame, rot, shift)
    principal = _principal(link.axis)
    after = None
    if principal is None and link.kind == "revolute":
        onto_z = _snap(_axis_onto_z(link.axis))
        rot, after, principal = rot @ onto_z, onto_z.T, (2, 1.0)
    out = _rotate(prog, frame, rot, shift)
    if link.kind == "revolute":
        assert principal is not None
        k, sign = principal
        iu, iv = _PLANE[k]
        u, su = _unsigned(out[iu])
        v, sv = _unsigned(out[iv])
        flip = su * sv * sign
        row = len(prog.rows)
        prog.rows.append(
            Row(link.source, float(flip * link.multiplier), float(flip * link.offset), True)
        )
        du, dv = prog.buffer(), prog.buffer()
        prog.ops.append(Turn(du, dv, u, v, row))
        out[iu], out[iv] = Buf(du, su), Buf(dv, sv)
        if after is not None:
            out = _rotate(prog, out, after, np.zeros(3))
    else:  # prismatic: the origin moves along the axis, in the joint frame
        if principal is not None:
            axis_col = out[principal[0]]
            sign = principal[1]
        else:
            axis_col = _combine(prog, [(link.axis[k], out[k]) for k in range(3)])
            sign = 1.0
        a, sa = _unsigned(axis_col)
        p, sp = _unsigned(out[3])
        assert sp == 1.0  # origins are only ever made by Lin and Slide, never negated
        row = len(prog.rows)
        flip = float(sign * sa)
        prog.rows.append(Row(link.source, flip * link.multiplier, flip * link.offset, False))
        dst = prog.buffer()
        prog.ops.append(Slide(dst, p, a, row))
        out[3] = Buf(dst)
    return out


def _allocate(prog: Program) -> None:
    """Map buffers to reusable slots: a slot is free again after its buffer's last read."""
    last_read = [-1] * prog.n_buffers
    for step, op in enumerate(prog.ops):
        for index in _reads(op):
            last_read[index] = step
    slots = [-1] * prog.n_buffers
    free: list[int] = []
    n_slots = 0
    for step, op in enumerate(prog.ops):
        for dst in _writes(op):  # before freeing this op's inputs: a Turn reads both after writing
            if free:
                slots[dst] = free.pop()
            else:
                slots[dst] = n_slots
                n_slots += 1
        for index in set(_reads(op)) | set(_writes(op)):
            if last_read[index] <= step:
                free.append(slots[index])
    prog.slots, prog.n_slots = slots, n_slots


def _reads(op: Op) -> list[int]:
    if isinstance(op, Lin):
        return [index for _, index in op.terms]
    if isinstance(op, Turn):
        return [x for x in (op.u, op.v) if isinstance(x, int)]
    if isinstance(op, Slide):
        return [x for x in (op.p, op.axis) if isinstance(x, int)]
    return [op.src.index] if isinstance(op.src, Buf) else []


def _writes(op: Op) -> list[int]:
    if isinstance(op, Turn):
        return [op.dst_u, op.dst_v]
    if isinstance(op, Lin | Slide):
        return [op.dst]
    return []


def compile_frames(tree: Tree, outputs: Sequence[int]) -> Program:
    """Operations computing the frames of links ``outputs`` (tree indices), in that order."""
    needed = tree.needed(outputs)
    prog = Program(n_joints=len(tree.joint_names))
    frames: dict[int, list[Col]] = {}
    written: dict[int, list[int]] = {}
    for frame, link in enumerate(outputs):
        written.setdefault(link, []).append(frame)
    for i in needed:  # tree order: parents first
        parent = tree.links[i].parent
        if parent < 0:
            frames[i] = [(1.0, 0.0, 0.0), (0.0, 1.0, 0.0), (0.0, 0.0, 1.0), (0.0, 0.0, 0.0)]
        else:
            frames[i] = _move(prog, tree, i, list(frames[parent]))
        # Written out at once, so a frame's buffers are free for reuse after its children.
        for frame in written.get(i, ()):
            prog.ops.extend(Out(frame, col, frames[i][col]) for col in range(4))
    prog.n_frames = len(outputs)
    _allocate(prog)
    return prog
