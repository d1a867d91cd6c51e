"""Following nodes by one data-layer subscription: its event stream gathered into samples.

The stream is renewed with each token before the old one expires (make
before break), and reopened after an interruption that ``Interruptions``
rides out.
"""

from __future__ import annotations

import asyncio
import logging
import time
from collections.abc import Callable, Sequence

from .client import DataLayerClient
from .events import EventStream, Subscription, SubscriptionSettings
from .interruptions import Interruptions, news_level
from .problem import DataLayerError, StreamEnded, Unsupported
from .sample import Sample, checked
from .updates import Items, Keepalive, PlainUpdates, Update

log = logging.getLogger(__name__)


class Latest:
    """The newest value of every node, gathered from events, handed out as Samples."""

    def __init__(self, nodes: list[str], grace_s: float) -> None:
        self._values: dict[str, float | Exception] = {}
        self._nodes = nodes
        self._wanted = frozenset(nodes)
        self._grace_s = grace_s
        self._opened = time.monotonic()
        self._t: float | None = None
        self._changed = False
        self._cycles = 0
        """Publish cycles (distinct timestamps) gathered since the last sample."""

    def add(self, item: Update | Keepalive | PlainUpdates) -> None:
        if isinstance(item, PlainUpdates):
            self._gather(item.nodes, item.t_sources, item.values)
        elif isinstance(item, Update):
            self._gather((item.node,), (item.t_source,), (item.value,))
        else:  # a keepalive says "nothing changed until t": a fresh sample of the same values
            self._gather((), (item.t_source,), ())

    def _gather(
        self,
        nodes: Sequence[str],
        t_sources: Sequence[float | None],
        values: Sequence[float | Exception],
    ) -> None:
        """Updates in arrival order (no nodes: a keepalive's time alone)."""
        wanted, t, cycles = self._wanted, self._t, self._cycles
        for k, t_source in enumerate(t_sources):
            if nodes:
                if nodes[k] not in wanted:
                    continue
                self._values[nodes[k]] = values[k]
            if t_source is not None:
                # The events of one publish cycle share its timestamp: a new one is a new cycle.
                cycles += t_source != t
                t = t_source if t is None or t_source > t else t
            self._changed = True
        self._t, self._cycles = t, cycles

    def take(self) -> Sample | None:
        """A sample if anything changed and every node was heard from (or waiting is over)."""
        if not self._changed:
            return None
        complete = len(self._values) == len(self._nodes)
        if not complete and time.monotonic() - self._opened < self._grace_s:
            return None  # the initial events of some nodes are still on their way
        self._changed, received, self._cycles = False, max(self._cycles, 1), 0
        if complete:
            values = {n: self._values[n] for n in self._nodes}
        else:
            missing = DataLayerError("the subscription sent no value for this node")
            values = {n: self._values.get(n, missing) for n in self._nodes}
        t_source = self._t if self._t is not None else time.time()
        return checked(Sample(t_source, values, received))


async def subscribe(
    client: DataLayerClient,
    nodes: list[str],
    period_s: float,
    keepalive_s: float,
    interruptions: Interruptions,
    deliver: Callable[[Sample], None],
) -> None:
    """Streams samples to ``deliver`` until the source fails for good (or is refused)."""
    settings = SubscriptionSettings(
        publish_interval_ms=max(1, round(period_s * 1000)),
        keepalive_interval_ms=max(1, round(keepalive_s * 1000)),
        error_interval_ms=max(1, round(keepalive_s * 1000)),
    )
    subscription = Subscription(client, nodes, settings)
    latest = Latest(nodes, grace_s=keepalive_s)
    unusable: list[DataLayerError] = []
    """Why every node failed, if they did: then the source as a whole is unusable, which is
    no passing interruption of its stream."""

    def on_items(items: Sequence[Update | Keepalive | PlainUpdates], mid_event: bool) -> None:
        for item in items:
            latest.add(item)
        if mid_event:
            return  # the rest of this publish cycle is in the next chunk
        try:
            sample = latest.take()
        except DataLayerError as exc:
            unusable[:] = [exc]
            raise
        if sample is not None:
            unusable.clear()
            interruptions.succeeded()
            deliver(sample)

    stream: EventStream | None = None
    log.log(
        news_level(client),
        "%s: subscribing to %d nodes (publish every %d ms)",
        client.base_url,
        len(nodes),
        settings.publish_interval_ms,
    )
    try:
        while True:
            try:
                if stream is None:
                    stream = await subscription.open(on_items)
                # Planned on our monotonic clock from the token's lifetime, never its exp.
                wait = client.tokens.seconds_to_renewal()
                if wait is not None and wait <= 0.0:
                    stream = await _hand_over(client, subscription, stream, on_items)
                    continue
                done, _ = await asyncio.wait((stream.ended,), timeout=wait)
                if not done:
                    continue  # time to renew the token
                raise stream.ended.result()
            except Unsupported:
                raise
            except DataLayerError as exc:
                if stream is not None:
                    stream.close()
                stream = None
                if unusable and exc is unusable[0]:
                    raise exc from None
                await interruptions.failed(exc)
    finally:
        if stream is not None:
            stream.close()
        await subscription.delete()


async def _hand_over(
    client: DataLayerClient,
    subscription: Subscription,
    old: EventStream,
    on_items: Items,
) -> EventStream:
    """Make before break: open a stream with a fresh token, then drop the old one.

    A server may end a stream when the token it was opened with expires, so
    the new stream must be running by then or viewers would see a gap.
    """
    await client.tokens.current()
    try:
        fresh = await subscription.open(on_items)
    finally:
        old.close()
    if old.ended.done():  # it ended while the new one opened: a broken stream is no news,
        why = old.ended.result()  # but a failure of the source or a bug is
        if not isinstance(why, StreamEnded):
            fresh.close()
            raise why
    return fresh
