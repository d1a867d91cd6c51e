"""The page's record button: the last minutes of history as one MCAP file."""

from __future__ import annotations

import time
from pathlib import Path

from ..cell import Cell
from ..history import History, Mark, NewRows
from .encode import encode_batch
from .writer import McapFile


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
    """Write what ``history_rows`` copied to ``path`` (in a worker thread)."""
    file = McapFile(path, cell, t0)
    try:
        file.write(encode_batch(sources, marks, file.frames))
    finally:
        file.close()
