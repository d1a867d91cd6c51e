"""Every source's recent samples and the marks worth jumping to (errors, outages, reloads).

The acquisition hands each sample to its source's ``SourceHistory`` (the tap
``server.stream`` calls); readers (the /api/history route, the recorder, the
Foxglove endpoint) copy rows out. Memory grows as samples arrive, up to
``seconds`` of samples at the source's period, with a margin
(``bytes_at_most``); the cell check refuses cells whose histories could pass
``MAX_BYTES`` together.
"""

from __future__ import annotations

import math
import time
from collections import deque
from collections.abc import Iterable
from dataclasses import dataclass
from typing import Literal

from ..sources import Sample
from .ring import SampleRing

MarkKind = Literal["error", "stale", "live", "reload"]
MARGIN = 1.25
"""Room for sources that deliver a little faster than their period."""
MAX_MARKS = 2000
MAX_BYTES = 2 << 30
"""The most the histories of a cell may come to when full (2 GiB): ``python -m server check``
refuses more, naming ``--history`` and ``period_ms``. A 7-axis arm with setpoints at 50 Hz
takes 4.8 MB per 600 s: about 440 of them."""
NAN = math.nan


@dataclass(frozen=True)
class Mark:
    """What happened at ``t`` (unix s): a source failed or stalled, came back; a reload."""

    t: float
    kind: MarkKind
    source: str | None
    """The source it concerns; None for the whole cell (a reload)."""
    text: str


class Marks:
    """The newest ``MAX_MARKS`` marks, oldest first."""

    def __init__(self) -> None:
        self._marks: deque[Mark] = deque(maxlen=MAX_MARKS)

    def add(
        self, kind: MarkKind, text: str, source: str | None = None, t: float | None = None
    ) -> None:
        """Note ``kind`` now (or at ``t``)."""
        self._marks.append(Mark(time.time() if t is None else t, kind, source, text))

    def since(self, t: float) -> list[Mark]:
        """Marks at or after ``t``."""
        return [m for m in self._marks if m.t >= t]

    def __len__(self) -> int:
        return len(self._marks)


class SourceHistory:
    """One source's samples: what the acquisition's tap writes to (see ``server.stream``)."""

    def __init__(self, name: str, nodes: tuple[str, ...], capacity: int, marks: Marks) -> None:
        self.name = name
        self.ring = SampleRing(nodes, capacity)
        self.marks = marks
        self.frozen = False
        """Set for a replay, whose history is its whole file from the start: nothing is added."""
        self._nodes = nodes
        self._state = "connecting"

    def sample(self, seq: int, sample: Sample) -> None:
        """Keep a sample (the hot path: one list and three array stores)."""
        if self.frozen:
            return
        values = sample.values
        try:
            self.ring.write(seq, sample.t_source, [values[n] for n in self._nodes])  # type: ignore[misc]
        except (TypeError, ValueError):  # a node that could not be read holds its exception
            row = [
                v if isinstance(v, int | float) else NAN for v in (values[n] for n in self._nodes)
            ]
            self.ring.write(seq, sample.t_source, row)

    def state(self, state: str, error: str | None) -> None:
        """The source's state as published; changes worth finding again become marks."""
        before, self._state = self._state, state
        if state == before:
            return
        if state in ("error", "stale"):
            self.marks.add(state, error or state, self.name)  # type: ignore[arg-type]
        elif state == "connected" and before in ("error", "stale"):
            self.marks.add("live", "samples again", self.name)


class History:
    """The histories of every source of the running cell, and the marks."""

    def __init__(self, seconds: float) -> None:
        if seconds <= 0:
            raise ValueError("history must cover more than 0 s")
        self.seconds = seconds
        self.sources: dict[str, SourceHistory] = {}
        self.marks = Marks()

    def source(
        self, name: str, nodes: Iterable[str], period_s: float, samples: int | None = None
    ) -> SourceHistory:
        """The history of source ``name``: the one it had if it reads the same nodes, else new.

        ``samples`` asks for a new history of that many samples (a replay's whole file).
        """
        nodes = tuple(sorted(set(nodes)))
        kept = self.sources.get(name)
        if samples is None and kept is not None and kept.ring.nodes == nodes and not kept.frozen:
            return kept
        capacity = self.capacity(period_s) if samples is None else max(16, samples)
        self.sources[name] = SourceHistory(name, nodes, capacity, self.marks)
        return self.sources[name]

    def capacity(self, period_s: float) -> int:
        """Samples a live source's history holds: ``seconds`` at ``period_s``, with a margin."""
        return max(16, math.ceil(self.seconds / period_s * MARGIN))

    def bytes_at_most(self, nodes: int, period_s: float) -> int:
        """The memory a live source reading ``nodes`` every ``period_s`` takes when full."""
        return self.capacity(period_s) * (nodes + 2) * 8

    def keep_only(self, names: Iterable[str]) -> None:
        """Forget the histories of sources no longer in the cell."""
        wanted = set(names)
        for name in [n for n in self.sources if n not in wanted]:
            del self.sources[name]

    def span(self) -> tuple[float, float] | None:
        """The oldest and newest sample time over every source, None before any sample."""
        spans = [s for s in (h.ring.span() for h in self.sources.values()) if s is not None]
        if not spans:
            return None
        return min(s[0] for s in spans), max(s[1] for s in spans)

    @property
    def samples(self) -> int:
        """Samples held now, every source together."""
        return sum(len(h.ring) for h in self.sources.values())

    @property
    def nbytes(self) -> int:
        """Memory the histories hold now (it grows with use, up to ``bytes_at_most``)."""
        return sum(h.ring.nbytes for h in self.sources.values())
