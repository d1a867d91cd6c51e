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
import math
import time
from collections.abc import AsyncGenerator
from dataclasses import dataclass
from pathlib import Path

import numpy as np
import orjson
from mcap.exceptions import McapError
from mcap.reader import make_reader

from ..cell import Cell, CellError, Robot, load_cell
from ..ctrlx import DataLayerError, Sample
from ..history.ring import Array, IntArray
from .messages import joints_topic
from .writer import METADATA_NAME

NOT_RECORDED = "not in the recording (the joint nodes could not be read then)"


def recorded_cell_path(path: Path) -> Path | None:
    """The cell file a recording was made with (its path on the recording machine)."""
    try:
        with path.open("rb") as f:
            for record in make_reader(f).iter_metadata():
                if record.name == METADATA_NAME and record.metadata.get("cell"):
                    return Path(record.metadata["cell"])
    except (OSError, McapError, ValueError) as exc:
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

    @property
    def period_s(self) -> float:
        """The median time between samples (0.02 s when there are too few to tell)."""
        return float(np.median(np.diff(self.t))) if len(self.t) > 2 else 0.02

    async def play(self, speed: float = 1.0) -> AsyncGenerator[Sample, None]:
        """The samples at the pace they were taken (``speed`` times faster), over and over."""
        if len(self.t) == 0:
            raise DataLayerError(f"the recording holds no sample of source {self.name}")
        missing = DataLayerError(NOT_RECORDED)
        rows = self.values.tolist()
        times = self.t.tolist()
        while True:
            start, t0 = time.monotonic(), times[0]
            for t, row in zip(times, rows, strict=True):
                wait = (t - t0) / speed - (time.monotonic() - start)
                if wait > 0:
                    await asyncio.sleep(wait)
                values: dict[str, float | Exception] = {
                    n: (missing if math.isnan(v) else v)
                    for n, v in zip(self.nodes, row, strict=True)
                }
                yield Sample(t, values)
            await asyncio.sleep(self.period_s / speed)


def load_source(path: Path, name: str, robots: list[Robot]) -> SourceReplay:
    """Source ``name``'s samples from the recording at ``path`` (its robots' joint messages)."""
    nodes = tuple(sorted({n for r in robots for n in r.nodes}))
    column = {n: i for i, n in enumerate(nodes)}
    per_robot = _read_joints(path, robots)
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
    return SourceReplay(name, nodes, t, all_seq.astype(np.int64), values)


def _read_joints(path: Path, robots: list[Robot]) -> dict[str, tuple[IntArray, Array, Array]]:
    topics = {joints_topic(r.name): r for r in robots}
    found: dict[str, list[tuple[int, float, list[float]]]] = {r.name: [] for r in robots}
    try:
        with path.open("rb") as f:
            for _, channel, message in make_reader(f).iter_messages(topics=list(topics)):
                robot = topics[channel.topic]
                body = orjson.loads(message.data)
                position = body["position"]
                q = [float(position[j.name]) for j in robot.joints]
                found[robot.name].append((int(body["seq"]), float(body["t_source"]), q))
    except (OSError, McapError, ValueError, KeyError, TypeError) as exc:
        raise DataLayerError(f"cannot replay {path}: {exc!r}") from None
    out = {}
    for robot in robots:
        rows = found[robot.name]
        seq = np.array([r[0] for r in rows], dtype=np.int64)
        times = np.array([r[1] for r in rows])
        joints = np.array([r[2] for r in rows]).reshape(len(rows), len(robot.joints))
        out[robot.name] = (seq, times, joints)
    return out
