"""A source's samples of the last minutes in numpy blocks, allocated as samples arrive.

Writing a sample is a few array stores, no Python object kept per sample: this
runs on the acquisition's hot path, 50 to 100 times a second per source. The
ring's capacity (the most it holds) is fixed, but its memory is not taken up
front: rows live in blocks of about ``BLOCK_BYTES``, each allocated when the
first sample reaches it, so memory grows with use, up to the capacity, and a
cell of many robots costs nothing until they send. (Preallocated, a cell of
2 000 robots took 1.37 GB at start.) Blocks are never copied when the ring
grows, so no sample waits for a large copy.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import numpy.typing as npt

Array = npt.NDArray[np.float64]
IntArray = npt.NDArray[np.int64]
BLOCK_BYTES = 1 << 20
"""About this much per block (a few seconds of a big source, minutes of a small one)."""
MAX_BLOCK_ROWS = 4096


@dataclass(frozen=True)
class Rows:
    """Consecutive samples, oldest first, copied out of a ring."""

    t: Array
    """``(n,)`` unix time (s) the data layer sampled each row."""
    seq: IntArray
    """``(n,)`` the acquisition's sample counter."""
    values: Array
    """``(n, nodes)`` node values in data-layer units; NaN where a node could not be read."""
    first: int
    """Ring index (monotonic) of the first row."""

    def __len__(self) -> int:
        return len(self.t)


class SampleRing:
    """The newest ``capacity`` samples of a set of nodes, oldest overwritten first."""

    def __init__(self, nodes: tuple[str, ...], capacity: int) -> None:
        if capacity < 2:
            raise ValueError("a ring needs room for at least 2 samples")
        self.nodes = nodes
        self.column = {node: i for i, node in enumerate(nodes)}
        self.capacity = capacity
        row_bytes = 8 * (len(nodes) + 2)
        self.block_rows = max(16, min(MAX_BLOCK_ROWS, capacity, BLOCK_BYTES // row_bytes))
        blocks = -(-capacity // self.block_rows)
        self._t: list[Array | None] = [None] * blocks
        self._seq: list[IntArray | None] = [None] * blocks
        self._values: list[Array | None] = [None] * blocks
        self.count = 0
        """Samples written so far (monotonic): the next sample's ring index."""

    @property
    def nbytes(self) -> int:
        """Memory held by the blocks allocated so far (at most ``capacity`` rows' worth)."""
        return sum(t.nbytes for t in self._t if t is not None) + sum(
            v.nbytes + s.nbytes
            for v, s in zip(self._values, self._seq, strict=True)
            if v is not None and s is not None
        )

    def __len__(self) -> int:
        return min(self.count, self.capacity)

    @property
    def oldest(self) -> int:
        """Ring index of the oldest sample still held."""
        return max(0, self.count - self.capacity)

    def _block(self, b: int) -> tuple[Array, IntArray, Array]:
        """Block ``b``, allocated on first use (the last one holds only what is left)."""
        t, seq, values = self._t[b], self._seq[b], self._values[b]
        if t is None or seq is None or values is None:
            rows = min(self.block_rows, self.capacity - b * self.block_rows)
            t, seq = np.zeros(rows), np.zeros(rows, dtype=np.int64)
            values = np.full((rows, len(self.nodes)), np.nan)
            self._t[b], self._seq[b], self._values[b] = t, seq, values
        return t, seq, values

    def write(self, seq: int, t: float, values: list[float]) -> None:
        """Store one sample; ``values`` in node order, NaN for a node that was not read."""
        b, row = divmod(self.count % self.capacity, self.block_rows)
        block_t, block_seq, block_values = self._block(b)
        block_t[row] = t
        block_seq[row] = seq
        block_values[row] = values
        self.count += 1

    def write_many(self, seq: IntArray, t: Array, values: Array) -> None:
        """Store many samples at once, oldest first (a replay filling its history)."""
        done = 0
        while done < len(t):
            b, row = divmod(self.count % self.capacity, self.block_rows)
            block_t, block_seq, block_values = self._block(b)
            n = min(len(t) - done, len(block_t) - row)
            block_t[row : row + n] = t[done : done + n]
            block_seq[row : row + n] = seq[done : done + n]
            block_values[row : row + n] = values[done : done + n]
            self.count += n
            done += n

    def rows(self, first: int, stop: int | None = None) -> Rows:
        """Copies of the rows with ring indices ``first`` up to ``stop`` (default: all written)."""
        first = max(first, self.oldest)
        stop = max(first, self.count if stop is None else min(stop, self.count))
        parts: list[tuple[Array, IntArray, Array]] = []
        index = first
        while index < stop:  # one slice per block the rows span
            b, row = divmod(index % self.capacity, self.block_rows)
            block_t, block_seq, block_values = self._block(b)
            n = min(stop - index, len(block_t) - row)
            parts.append((block_t[row : row + n], block_seq[row : row + n],
                          block_values[row : row + n]))  # fmt: skip
            index += n
        if not parts:
            empty = np.zeros(0)
            return Rows(empty, np.zeros(0, dtype=np.int64), np.zeros((0, len(self.nodes))), first)
        return Rows(
            np.concatenate([p[0] for p in parts]),
            np.concatenate([p[1] for p in parts]),
            np.concatenate([p[2] for p in parts]),
            first,
        )

    def time_at(self, index: int) -> float:
        """The time of the sample with ring index ``index`` (one still held)."""
        b, row = divmod(index % self.capacity, self.block_rows)
        return float(self._block(b)[0][row])

    def span(self) -> tuple[float, float] | None:
        """Times of the oldest and the newest sample held, None while empty."""
        if self.count == 0:
            return None
        return self.time_at(self.oldest), self.time_at(self.count - 1)

    def between(self, t_from: float, t_to: float) -> Rows:
        """The rows sampled at ``t_from <= t <= t_to`` (times are assumed not to go back)."""
        held = len(self)
        if held == 0:
            return self.rows(self.count)
        # The ring is two sorted runs: bisect in the chronological view without copying it.
        oldest = self.oldest
        times = _Chronological(self, oldest, held)
        first = oldest + times.bisect_left(t_from)
        stop = oldest + times.bisect_right(t_to)
        return self.rows(first, stop)


class _Chronological:
    """Binary search over the ring's times in sample order."""

    def __init__(self, ring: SampleRing, oldest: int, held: int) -> None:
        self.ring, self.oldest, self.held = ring, oldest, held

    def _at(self, k: int) -> float:
        return self.ring.time_at(self.oldest + k)

    def bisect_left(self, x: float) -> int:
        lo, hi = 0, self.held
        while lo < hi:
            mid = (lo + hi) // 2
            if self._at(mid) < x:
                lo = mid + 1
            else:
                hi = mid
        return lo

    def bisect_right(self, x: float) -> int:
        lo, hi = 0, self.held
        while lo < hi:
            mid = (lo + hi) // 2
            if x < self._at(mid):
                hi = mid
            else:
                lo = mid + 1
        return lo
