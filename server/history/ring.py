"""A source's samples of the last minutes in preallocated numpy arrays: a fixed amount of memory.

Writing a sample is a few array stores, no Python object kept per sample: this
runs on the acquisition's hot path, 50 to 100 times a second per source.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import numpy.typing as npt

Array = npt.NDArray[np.float64]
IntArray = npt.NDArray[np.int64]


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
        self._t = np.zeros(capacity)
        self._seq = np.zeros(capacity, dtype=np.int64)
        self._values = np.full((capacity, len(nodes)), np.nan)
        self.count = 0
        """Samples written so far (monotonic): the next sample's ring index."""

    @property
    def nbytes(self) -> int:
        """Memory held by the arrays, allocated once."""
        return self._t.nbytes + self._seq.nbytes + self._values.nbytes

    def __len__(self) -> int:
        return min(self.count, self.capacity)

    @property
    def oldest(self) -> int:
        """Ring index of the oldest sample still held."""
        return max(0, self.count - self.capacity)

    def write(self, seq: int, t: float, values: list[float]) -> None:
        """Store one sample; ``values`` in node order, NaN for a node that was not read."""
        slot = self.count % self.capacity
        self._t[slot] = t
        self._seq[slot] = seq
        self._values[slot] = values
        self.count += 1

    def write_many(self, seq: IntArray, t: Array, values: Array) -> None:
        """Store many samples at once, oldest first (a replay filling its history)."""
        for start in range(0, len(t), self.capacity):
            stop = min(start + self.capacity, len(t))
            slots = (self.count + np.arange(stop - start)) % self.capacity
            self._t[slots] = t[start:stop]
            self._seq[slots] = seq[start:stop]
            self._values[slots] = values[start:stop]
            self.count += stop - start

    def rows(self, first: int, stop: int | None = None) -> Rows:
        """Copies of the rows with ring indices ``first`` up to ``stop`` (default: all written)."""
        first = max(first, self.oldest)
        stop = self.count if stop is None else min(stop, self.count)
        slots = np.arange(first, max(first, stop)) % self.capacity
        return Rows(self._t[slots], self._seq[slots], self._values[slots], first)

    def span(self) -> tuple[float, float] | None:
        """Times of the oldest and the newest sample held, None while empty."""
        if self.count == 0:
            return None
        return float(self._t[self.oldest % self.capacity]), float(
            self._t[(self.count - 1) % self.capacity]
        )

    def between(self, t_from: float, t_to: float) -> Rows:
        """The rows sampled at ``t_from <= t <= t_to`` (times are assumed not to go back)."""
        held = len(self)
        if held == 0:
            return self.rows(self.count)
        # The ring is two sorted runs: bisect in the chronological view without copying it.
        oldest = self.oldest
        times = _Chronological(self._t, oldest, held, self.capacity)
        first = oldest + times.bisect_left(t_from)
        stop = oldest + times.bisect_right(t_to)
        return self.rows(first, stop)


class _Chronological:
    """Binary search over the ring's times in sample order."""

    def __init__(self, t: Array, oldest: int, held: int, capacity: int) -> None:
        self.t, self.oldest, self.held, self.capacity = t, oldest, held, capacity

    def _at(self, k: int) -> float:
        return float(self.t[(self.oldest + k) % self.capacity])

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
