"""Data-layer subscriptions: create one, open its server-sent event stream, read its events
(parsed by ``sse``, decoded by ``updates``) as they arrive."""

from __future__ import annotations

import asyncio
import logging
import secrets
from collections.abc import Sequence
from dataclasses import dataclass
from typing import Any

from ..lateness import lateness
from .client import REFUSED, DataLayerClient
from .problem import (
    DataLayerError,
    ProblemError,
    StreamEnded,
    Unsupported,
)
from .sse import SseEvent, SseParser
from .stream_wire import ByteSource, open_stream_into
from .updates import (
    InvalidEvent,
    Items,
    Keepalive,
    PlainUpdates,
    Update,
    decode_event,
    plain_updates,
)

log = logging.getLogger(__name__)


@dataclass(frozen=True)
class SubscriptionSettings:
    """Subscription properties: intervals in ms as the data layer takes them (sampling in µs)."""

    publish_interval_ms: int = 20
    keepalive_interval_ms: int = 1000
    error_interval_ms: int = 1000
    sampling_interval_us: int | None = None
    """Defaults to the publish interval."""

    def properties(self, subscription_id: str) -> dict[str, Any]:
        """The ``properties`` object of ``POST /events``."""
        sampling = self.sampling_interval_us or self.publish_interval_ms * 1000
        return {
            "id": subscription_id,
            "publishInterval": self.publish_interval_ms,
            "keepaliveInterval": self.keepalive_interval_ms,
            "errorInterval": self.error_interval_ms,
            "rules": [{"rule_type": "Sampling", "rule": {"samplingInterval": sampling}}],
        }


class EventStream:
    """One open event stream: its events decoded as they arrive, and a watchdog on silence and junk.

    The bytes come from ``data_received`` (see stream_wire), so everything
    here runs without a task. ``ended`` resolves to why the stream ended: the
    server closed it, it broke, it sent no valid event (update, keepalive,
    node error) for ``dead_after_s``, whether it sent nothing or only bytes we
    cannot use, or ``on_items`` raised.
    """

    def __init__(self, client: DataLayerClient, dead_after_s: float, on_items: Items) -> None:
        self._client = client
        self._on_items = on_items
        self._parser = SseParser()
        self.dead_after_s = dead_after_s
        self._lateness = lateness()  # this loop's (a stream lives in one)
        self._alive = self._lateness.mark()
        """When the last valid event came: silence is counted from here, on-time seconds only."""
        self._junk_bytes = 0
        self._junk: str | None = None
        loop = asyncio.get_running_loop()
        self.ended: asyncio.Future[Exception] = loop.create_future()
        self._source: ByteSource | None = None
        self._watchdog: asyncio.TimerHandle | None = None
        """Armed once the stream is open: a slow login or subscription is no silence."""

    async def connect(self, path: str, params: dict[str, str] | None = None) -> None:
        """GET the stream at ``path``; raises what the client raises when there is none."""
        self._source = await open_stream_into(self._client, path, params, self.feed, self.end)
        if self.ended.done():
            return  # it ended while opening (closed at once): nothing to watch
        self._alive = self._lateness.mark()  # silence counts from the open stream
        self._watchdog = asyncio.get_running_loop().call_later(self.dead_after_s, self._watch)

    def feed(self, chunk: bytes) -> None:
        """Parse and hand on the events ``chunk`` completes."""
        if self.ended.done():
            return
        self._junk_bytes += len(chunk)
        try:
            items = self._items(chunk)
            if items:
                self._alive, self._junk_bytes, self._junk = self._lateness.mark(), 0, None
                self._on_items(items, self._parser.pending)
        except Exception as exc:  # the stream's end, raised where its owner waits
            self.end(exc)

    def end(self, why: Exception) -> None:
        """End the stream for ``why`` (the first reason counts)."""
        if self.ended.done():
            return
        if isinstance(why, DataLayerError):
            why = self._client.redact.error(why)
        self.ended.set_result(why)
        self.close()

    def _watch(self) -> None:
        """Silence counts only while our loop was on time: a busy process reads late,
        and that is no fault of the device (see server.lateness)."""
        left = self.dead_after_s - self._alive.on_time_s()
        if left > 0.0:
            self._watchdog = asyncio.get_running_loop().call_later(left, self._watch)
        else:
            self.end(StreamEnded(self._why_dead()))

    def _items(self, chunk: bytes) -> Sequence[Update | Keepalive | PlainUpdates]:
        """The usable events ``chunk`` completes: one PlainUpdates where it can, else one by one."""
        events = None
        datas = self._parser.usual_updates(chunk)
        if datas is None:
            events = self._parser.feed(chunk)
            if events and all(event.event == "update" for event in events):
                datas = [event.data for event in events]
        plain = plain_updates(datas) if datas else None
        if plain is not None:
            return (plain,)
        if events is None:  # the usual layout, but values to decode one by one
            events = [SseEvent("update", None, data) for data in datas or ()]
        return self._decoded(events)

    def _decoded(self, events: list[SseEvent]) -> list[Update | Keepalive]:
        """The usable events, one by one; the last unusable one is kept to say why."""
        items: list[Update | Keepalive] = []
        for event in events:
            try:
                item = decode_event(event, self._client.paths.nodes)
            except InvalidEvent as exc:
                self._junk = str(exc)
                continue
            if item is not None:
                if isinstance(item, Update) and isinstance(item.value, Exception):
                    self._client.redact.error(item.value)
                items.append(item)
        return items

    def _why_dead(self) -> str:
        if self._junk_bytes == 0:
            return f"event stream silent for {self.dead_after_s:g} s (no keepalive)"
        last = f" (last: {self._junk})" if self._junk else ""
        return (
            f"event stream sent {self._junk_bytes} bytes but no valid event "
            f"for {self.dead_after_s:g} s{last}"
        )

    def close(self) -> None:
        """Drop the connection (there is no polite way to end an SSE response)."""
        if self._watchdog is not None:
            self._watchdog.cancel()
        if self._source is not None:
            self._source.close()


class Subscription:
    """A subscription to ``nodes``; open its stream as often as needed (it is reused).

    Tries ``POST /events`` with properties first, then the short form
    ``GET /events?nodes=...&publishIntervalMs=N``; raises Unsupported when
    the server has neither.
    """

    def __init__(
        self, client: DataLayerClient, nodes: list[str], settings: SubscriptionSettings
    ) -> None:
        self._client = client
        self.nodes = nodes
        self.settings = settings
        self.id = f"linkview-{secrets.token_hex(6)}"
        self._created = False
        self._short_form = False

    async def open(self, on_items: Items) -> EventStream:
        """Open a new event stream of this subscription; its events go to ``on_items``."""
        events = self._client.paths.events
        if events is None or self._client.capabilities.subscribe is False:
            raise Unsupported("this data layer offers no subscriptions")
        dead_after = 2.5 * self.settings.keepalive_interval_ms / 1000.0
        stream = EventStream(self._client, dead_after, on_items)
        try:
            if not self._short_form and not self._created:
                await self._create(events)
            if self._short_form:
                params = {
                    "nodes": ",".join(self.nodes),
                    "publishIntervalMs": str(self.settings.publish_interval_ms),
                }
                await stream.connect(events, params)
            else:
                try:
                    await stream.connect(f"{events}/{self.id}")
                except Unsupported:
                    # The server forgot the subscription (unused for a minute): make it again.
                    self._created = False
                    await self._create(events)
                    await stream.connect(f"{events}/{self.id}")
        except BaseException as exc:
            stream.close()
            if isinstance(exc, Unsupported):
                self._client.capabilities.subscribe = False
            raise
        self._client.capabilities.subscribe = True
        return stream

    async def _create(self, events: str) -> None:
        body = {"properties": self.settings.properties(self.id), "nodes": self.nodes}
        try:
            await self._client.request("POST", events, json=body)
            self._created = True
        except ProblemError as exc:
            if exc.status not in REFUSED:
                raise
            log.info("POST %s refused (%s); trying the short form", events, exc.status)
            self._short_form = True

    async def delete(self) -> None:
        """Delete the subscription on the server (best effort; it expires anyway)."""
        events = self._client.paths.events
        if not self._created or events is None:
            return
        self._created = False
        if self._client.tokens.due():
            return  # not worth a login (maybe a failing one): unused subscriptions expire
        try:
            async with asyncio.timeout(2.0):
                await self._client.request("DELETE", f"{events}/{self.id}")
        except (DataLayerError, TimeoutError) as exc:
            log.debug("deleting subscription %s failed: %s", self.id, exc)
