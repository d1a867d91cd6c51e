"""Reading the histories as they grow: each reader takes only what it has not taken yet."""

from __future__ import annotations

import math
from dataclasses import dataclass

from ..cell import Cell, Robot
from .ring import Rows, SampleRing
from .store import History, Mark


@dataclass(frozen=True)
class NewRows:
    """One source's rows a reader had not seen, with the robots and columns to read them."""

    name: str
    robots: list[tuple[int, Robot]]
    """``(hello index, robot)`` of the source."""
    column: dict[str, int]
    rows: Rows
    lost: int
    """Rows that were overwritten before this reader came for them."""


class HistoryReader:
    """Takes the rows and marks added since its last ``take`` (a recorder, a live endpoint).

    Replayed sources (frozen histories) are skipped: their file is already a recording.
    """

    def __init__(self, history: History, from_start: bool = True) -> None:
        self.history = history
        self.from_start = from_start
        """Begin with what the histories hold already (a recorder) or with what comes next."""
        self._cursors: dict[str, tuple[SampleRing, int]] = {}
        self._marks_after = -math.inf

    def take(self, cell: Cell) -> tuple[list[NewRows], list[Mark]]:
        """New rows of every live source of ``cell``, and marks newer than the last taken."""
        out = []
        for name, source in self.history.sources.items():
            if source.frozen:
                continue
            ring = source.ring
            known = self._cursors.get(name)
            if known is not None and known[0] is ring:
                start = known[1]
            else:
                start = ring.oldest if self.from_start else ring.count
            lost = max(0, ring.oldest - start)
            rows = ring.rows(start)
            self._cursors[name] = (ring, ring.count)
            robots = [(i, r) for i, r in enumerate(cell.robots) if r.source == name]
            out.append(NewRows(name, robots, ring.column, rows, lost))
        marks = [m for m in self.history.marks.since(self._marks_after) if m.t > self._marks_after]
        if marks:
            self._marks_after = marks[-1].t
        return out, marks
