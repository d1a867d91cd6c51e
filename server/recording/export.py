"""The page's "Save recording": the last minutes of history as one MCAP file.

The rows are copied out on the event loop (``history_rows``, a few array
copies); the file is written in a worker thread a WINDOW_S of samples at a
time, so the poses computed and the messages encoded at once are those of
one window, whatever the span saved.
"""

from __future__ import annotations

import dataclasses
import time
from collections.abc import Iterator
from pathlib import Path

import numpy as np

from ..cell import Cell
from ..history import History, Mark, NewRows
from ..history.ring import Rows
from .encode import encode_batch
from .writer import McapFile

WINDOW_S = 10.0
"""Samples encoded together: 10 s of the demo cell's 3 robots is about 3 MB of messages."""


def history_rows(
    history: History, cell: Cell, seconds: float
) -> tuple[list[NewRows], list[Mark], float]:
    """Copies of every source's rows and the marks of the last ``seconds`` (on the event loop)."""
    t_from = time.time() - seconds
    out = []
    for name, source in history.sources.items():
        ring = source.ring
        robots = [(i, r) for i, r in enumerate(cell.robots) if r.source == name]
        out.append(NewRows(name, robots, ring.column, ring.between(t_from, float("inf")), 0))
    spans = [float(s.rows.t[0]) for s in out if len(s.rows)]
    return out, history.marks.since(t_from), min(spans, default=t_from)


def write_export(
    path: Path, cell: Cell, sources: list[NewRows], marks: list[Mark], t0: float
) -> None:
    """Write what ``history_rows`` copied to ``path`` (in a worker thread), window by window."""
    file = McapFile(path, cell, t0)
    try:
        for window_sources, window_marks in windows(sources, marks, t0):
            file.write(encode_batch(window_sources, window_marks, file.frames))
    finally:
        file.close()


def windows(
    sources: list[NewRows], marks: list[Mark], t0: float, span_s: float = WINDOW_S
) -> Iterator[tuple[list[NewRows], list[Mark]]]:
    """The rows and marks of each ``span_s`` from ``t0`` on, oldest first (every row once)."""
    ends = [float(s.rows.t[-1]) for s in sources if len(s.rows)] + [m.t for m in marks]
    last = max(ends, default=t0)
    start = t0
    while True:
        stop = start + span_s
        final = stop > last
        part = [_between(s, start, stop, first=start == t0, final=final) for s in sources]
        mine = [m for m in marks if (start <= m.t or start == t0) and (m.t < stop or final)]
        yield part, mine
        if final:
            return
        start = stop


def _between(source: NewRows, start: float, stop: float, first: bool, final: bool) -> NewRows:
    """``source`` with only its rows at ``start <= t < stop`` (open-ended at either end)."""
    rows = source.rows
    lo = 0 if first else int(np.searchsorted(rows.t, start, "left"))
    hi = len(rows) if final else int(np.searchsorted(rows.t, stop, "left"))
    part = Rows(rows.t[lo:hi], rows.seq[lo:hi], rows.values[lo:hi], rows.first + lo)
    return dataclasses.replace(source, rows=part, lost=source.lost if first else 0)
