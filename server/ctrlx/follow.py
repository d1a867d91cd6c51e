"""Following a set of nodes over time: a stream of samples, however they are fetched."""

from __future__ import annotations

import asyncio
import time
from collections.abc import AsyncIterator
from dataclasses import dataclass

from .client import DataLayerClient
from .problem import DataLayerError


@dataclass(frozen=True)
class Sample:
    """Values of the followed nodes at one instant, in data-layer units.

    A node that could not be read holds the exception saying why, so one bad
    node spoils only the robot that uses it.
    """

    t_source: float
    """Unix time (s) the data layer sampled the values."""
    values: dict[str, float | Exception]


async def poll(client: DataLayerClient, nodes: list[str], period_s: float) -> AsyncIterator[Sample]:
    """Read every node once per ``period_s``; raises DataLayerError when no node can be read."""
    next_tick = time.monotonic()
    while True:
        yield await read_all(client, nodes)
        next_tick += period_s
        delay = next_tick - time.monotonic()
        if delay < 0.0:  # fell behind: skip the missed ticks rather than burst
            next_tick = time.monotonic()
        await asyncio.sleep(max(delay, 0.0))


async def read_all(client: DataLayerClient, nodes: list[str]) -> Sample:
    """One concurrent read of ``nodes``; raises when all of them fail (the source is unusable)."""
    results = await asyncio.gather(*(client.read_number(n) for n in nodes), return_exceptions=True)
    t_source = time.time()
    values: dict[str, float | Exception] = {}
    for node, result in zip(nodes, results, strict=True):
        if isinstance(result, BaseException) and not isinstance(result, Exception):
            raise result
        values[node] = result
    failures = [v for v in values.values() if isinstance(v, Exception)]
    if failures and len(failures) == len(values):
        first = failures[0]
        raise first if isinstance(first, DataLayerError) else DataLayerError(str(first))
    return Sample(t_source, values)


def follow(client: DataLayerClient, nodes: list[str], period_s: float) -> AsyncIterator[Sample]:
    """The samples of ``nodes``, about every ``period_s`` seconds."""
    return poll(client, nodes, period_s)
