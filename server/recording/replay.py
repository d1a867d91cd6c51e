"""Replay: a recording read back and served as if live, a data source like a controller.

The joint values recorded per robot (SI, ``/<robot>/joints``) are turned back
into node values (the cell's scale, offset and unit, inverted) and grouped by
the acquisition's sample counter into the samples the source once delivered,
with their original times. ``play`` yields them at the pace they were
sampled, from the start again after the end.
"""

from __future__ import annotations

import asyncio
import dataclasses
import logging
import math
import time
from array import array
from collections import Counter
from collections.abc import AsyncGenerator
from dataclasses import dataclass
from pathlib import Path

import numpy as np
import orjson
from mcap.exceptions import McapError
from mcap.records import Channel, Message, Metadata

from ..cell import Cell, CellError, Robot, load_cell
from ..ctrlx import DataLayerError, Sample
from ..history.ring import Array, IntArray
from .mcap_stream import Stream, TooLarge
from .messages import joints_topic
from .writer import METADATA_NAME

log = logging.getLogger(__name__)

NOT_RECORDED = "not in the recording (the joint nodes could not be read then)"
MAX_MESSAGES = 1_000_000
"""Joint messages of one source a replay keeps (an hour of 5 robots at 50 Hz: 900 000).
Each costs 16 bytes and 8 per joint, and as much again in the history."""
MAX_T = float(1 << 33)
"""A ``t_source`` at or past this (the year 2242) is not a Unix time."""
MIN_STEP_S = 0.001
"""Samples are replayed at most 1000 a second, whatever their times say."""
MAX_PAUSE_S = 60.0
"""A longer pause between two recorded samples is replayed as this long."""
MAX_LAG_S = 1.0
"""Replay that falls this far behind (a stalled loop) goes on from now instead of racing."""


def recorded_cell_path(path: Path) -> Path | None:
    """The cell file a recording was made with (its path on the recording machine)."""
    try:
        for record in Stream(path, open_chunks=False).records():
            if isinstance(record, Metadata) and record.name == METADATA_NAME:
                cell = record.metadata.get("cell")
                return Path(cell) if cell else None
    except (OSError, McapError, TooLarge) as exc:
        raise CellError(path, [("(recording)", f"cannot read it as MCAP: {exc}")]) from None
    return None


def replay_cell(path: Path, cell_file: Path | None = None) -> Cell:
    """The cell that replays ``path``: ``cell_file`` if given, else the one recorded with it."""
    if not path.is_file():
        raise CellError(path, [("(recording)", "no such file")])
    target = cell_file or recorded_cell_path(path)
    if target is None or not target.is_file():
        why = "it names no cell file" if target is None else f"its cell file {target} is not here"
        raise CellError(path, [("(recording)", f"{why}; give the cell with --cell")])
    cell = load_cell(target)
    sources = tuple(dataclasses.replace(s, url=None, replay=path.resolve()) for s in cell.sources)
    return dataclasses.replace(cell, sources=sources)


@dataclass(frozen=True)
class SourceReplay:
    """One source's recorded samples: node values in data-layer units, NaN where not read."""

    name: str
    nodes: tuple[str, ...]
    t: Array
    seq: IntArray
    values: Array
    warning: str | None = None
    """What was left out of the file (messages refused, a cut end), shown in health."""

    @property
    def period_s(self) -> float:
        """The median time between samples that advance (0.02 s when too few to tell)."""
        steps = np.diff(self.t)
        steps = steps[steps > 0]
        return max(float(np.median(steps)), MIN_STEP_S) if len(steps) > 1 else 0.02

    async def play(self, speed: float = 1.0) -> AsyncGenerator[Sample, None]:
        """The samples at the pace they were taken (``speed`` times faster), over and over.

        The pace is the recorded times', but never faster than one sample per
        MIN_STEP_S and never a pause longer than MAX_PAUSE_S: where the clock
        stalls or steps back, the samples follow each other at the median
        period; each sample keeps its recorded time.
        """
        if len(self.t) == 0:
            raise DataLayerError(f"the recording holds no sample of source {self.name}")
        missing = DataLayerError(NOT_RECORDED)
        period = self.period_s
        while True:
            due = time.monotonic()
            previous: float | None = None
            for t, row in zip(self.t.tolist(), self.values, strict=True):
                step = period if previous is None else t - previous
                due += (period if step <= 0 else min(max(step, MIN_STEP_S), MAX_PAUSE_S)) / speed
                wait = due - time.monotonic()
                if wait < -MAX_LAG_S:  # the loop stalled: go on from now, not in a rush
                    due -= wait
                await asyncio.sleep(max(wait, 0.0))
                values: dict[str, float | Exception] = {
                    n: (missing if math.isnan(v) else v)
                    for n, v in zip(self.nodes, row.tolist(), strict=True)
                }
                yield Sample(t, values)
                previous = t


def load_source(path: Path, name: str, robots: list[Robot]) -> SourceReplay:
    """Source ``name``'s samples from the recording at ``path`` (its robots' joint messages).

    Read front to back with bounded memory (``mcap_stream``); a message that
    is not a joints message as the recorder writes it is refused on its own
    and counted; a file with more than MAX_MESSAGES of them, or a record over
    the limits, is refused whole (DataLayerError, naming the number).
    """
    nodes = tuple(sorted({n for r in robots for n in r.nodes}))
    column = {n: i for i, n in enumerate(nodes)}
    topics = {joints_topic(r.name): r for r in robots}
    found = {r.name: Joints(r) for r in robots}
    refused: Counter[str] = Counter()
    channels: dict[int, Robot] = {}
    stream = Stream(path)
    count = 0
    try:
        for record in stream.records():
            if isinstance(record, Channel):
                if record.topic in topics:
                    channels[record.id] = topics[record.topic]
                continue
            robot = channels.get(record.channel_id) if isinstance(record, Message) else None
            if robot is None:
                continue
            assert isinstance(record, Message)
            count += 1
            if count > MAX_MESSAGES:
                raise DataLayerError(
                    f"cannot replay {path}: it holds more than {MAX_MESSAGES} joint messages "
                    f"of source {name}; at most {MAX_MESSAGES} are replayed"
                )
            why = found[robot.name].add(record.data)
            if why is not None:
                refused[why] += 1
    except (OSError, McapError, TooLarge) as exc:
        raise DataLayerError(f"cannot replay {path}: {exc}") from None
    warning = _left_out(refused, stream)
    if warning is not None:
        log.warning("source %s: replay of %s: %s", name, path.name, warning)
    per_robot = {r.name: found[r.name].arrays() for r in robots}
    seqs = [s for s, _, _ in per_robot.values()]
    all_seq = np.unique(np.concatenate(seqs)) if seqs else np.zeros(0, dtype=np.int64)
    t = np.zeros(len(all_seq))
    values = np.full((len(all_seq), len(nodes)), np.nan)
    for robot in robots:
        seq, times, q = per_robot[robot.name]
        at = np.searchsorted(all_seq, seq)
        t[at] = times
        cols = [column[n] for n in robot.nodes]
        values[np.ix_(at, np.array(cols, dtype=np.intp))] = robot.from_si(q)
    return SourceReplay(name, nodes, t, all_seq.astype(np.int64), values, warning)


def _left_out(refused: Counter[str], stream: Stream) -> str | None:
    """One line for what the replay leaves out of the file, None if nothing."""
    parts = []
    if refused:
        reasons = ", ".join(f"{why}: {n}" for why, n in refused.most_common())
        parts.append(f"{sum(refused.values())} messages refused ({reasons})")
    if stream.cut is not None:
        parts.append(
            f"the recording was cut short: replayed up to its last complete chunk "
            f"({stream.chunks} read; {stream.cut})"
        )
    return "; ".join(parts) or None


class Joints:
    """One robot's joint messages as read: ``add`` each, then ``arrays``."""

    def __init__(self, robot: Robot) -> None:
        self.joints = [j.name for j in robot.joints]
        self.seq = array("q")
        self.t = array("d")
        self.q = array("d")

    def add(self, data: bytes) -> str | None:
        """Keep one message's sample; why it was refused, None if it was kept."""
        try:
            body = orjson.loads(data)
        except orjson.JSONDecodeError:
            return "not JSON"
        if not isinstance(body, dict):
            return "not a joints message"
        seq, t, position = body.get("seq"), body.get("t_source"), body.get("position")
        if type(seq) is not int or not 0 <= seq < 1 << 63:
            return "seq not an integer within int64"
        if not isinstance(t, int | float) or isinstance(t, bool) or not 0.0 <= t < MAX_T:
            return "t_source not a finite Unix time"  # NaN and inf fail the comparison
        if not isinstance(position, dict):
            return "no position"
        try:
            q = [float(position[name]) for name in self.joints]
        except (KeyError, TypeError, ValueError):
            return "a joint missing or not a number"
        if not all(map(math.isfinite, q)):
            return "a joint value not finite"
        self.seq.append(seq)
        self.t.append(float(t))
        self.q.extend(q)
        return None

    def arrays(self) -> tuple[IntArray, Array, Array]:
        """Sequence numbers, times and joint values (one row per message)."""
        seq = np.frombuffer(self.seq, dtype=np.int64) if self.seq else np.zeros(0, np.int64)
        t = np.frombuffer(self.t, dtype=np.float64) if self.t else np.zeros(0)
        q = np.frombuffer(self.q, dtype=np.float64) if self.q else np.zeros(0)
        return seq, t, q.reshape(len(t), len(self.joints))
