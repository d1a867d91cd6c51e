"""Following nodes by reading them once per period: one bulk read, or one GET per node."""

from __future__ import annotations

import asyncio
import dataclasses
import logging
import time
from collections.abc import AsyncIterator

from .client import DataLayerClient
from .interruptions import Interruptions, news_level
from .pacing import Pacer
from .problem import DataLayerError, Unsupported
from .refusal import Refusal
from .sample import Sample, checked

log = logging.getLogger(__name__)


async def poll(
    client: DataLayerClient,
    nodes: list[str],
    period_s: float,
    bulk: Refusal | None,
    events: Refusal | None,
    interruptions: Interruptions,
) -> AsyncIterator[Sample]:
    """Polls until the refused subscriptions are due to be tried again (if ever)."""
    use_bulk = bulk is not None and bulk.due()
    how = "bulk reads" if use_bulk else "one GET per node"
    log.log(
        news_level(client),
        "%s: polling %d nodes every %g s (%s)",
        client.base_url,
        len(nodes),
        period_s,
        how,
    )
    pacer, skipped = Pacer(period_s), 0
    while events is None or not events.due():
        if bulk is not None and not use_bulk and bulk.due():
            bulk.retry()
            use_bulk = True
        try:
            sample = await (read_bulk(client, nodes) if use_bulk else read_all(client, nodes))
        except Unsupported as exc:
            if bulk is None or not use_bulk:
                raise
            bulk.refused(exc)
            use_bulk = False
            continue
        except DataLayerError as exc:
            await interruptions.failed(exc)
            # The ticks of an interruption were the device's to miss, not ours: a new pace.
            pacer, skipped = Pacer(period_s), 0
            continue
        if use_bulk and bulk is not None:
            bulk.worked()
        interruptions.succeeded()
        # A tick skipped because we were late is a sample the device had and we did not take.
        yield dataclasses.replace(sample, received=1 + pacer.skipped - skipped)
        skipped = pacer.skipped
        await pacer.wait()


async def read_bulk(client: DataLayerClient, nodes: list[str]) -> Sample:
    wall, mono = time.time(), time.monotonic()
    read = await client.bulk_read(nodes)
    t_source = read.t_source if read.t_source is not None else midpoint(wall, mono)
    return checked(Sample(t_source, read.values))


async def read_all(client: DataLayerClient, nodes: list[str]) -> Sample:
    """One concurrent GET per node; raises when all of them fail (the source is unusable).

    A plain GET carries no timestamp, so the sample time is the middle of the
    round trip.
    """
    wall, mono = time.time(), time.monotonic()
    results = await asyncio.gather(*(client.read_number(n) for n in nodes), return_exceptions=True)
    values: dict[str, float | Exception] = {}
    for node, result in zip(nodes, results, strict=True):
        if isinstance(result, BaseException) and not isinstance(result, Exception):
            raise result
        values[node] = result
    return checked(Sample(midpoint(wall, mono), values))


def midpoint(wall: float, mono: float) -> float:
    return wall + (time.monotonic() - mono) / 2.0
