"""Data-layer subscriptions: create one, open its server-sent event stream, parse the events."""

from __future__ import annotations

import asyncio
import logging
import math
import re
import secrets
from collections.abc import Callable, Sequence
from dataclasses import dataclass
from typing import Any
from urllib.parse import unquote

import orjson

from ..lateness import lateness
from .bodies import loads
from .client import REFUSED, DataLayerClient
from .problem import (
    DataLayerError,
    ProblemError,
    StreamEnded,
    Unsupported,
    problem_for_status,
)
from .stream_wire import ByteSource, open_stream_into
from .timestamps import FIRST_FILETIME_S, parse_filetime, unix_from_filetime
from .values import SCALAR_TYPES, number_from_data

log = logging.getLogger(__name__)

MAX_LINE_BYTES = 64 * 1024
"""Longest SSE line we hold; an update line of one node is ~200 bytes."""
MAX_EVENT_BYTES = 1024 * 1024
"""Largest event (its data lines together) we hold."""


class InvalidEvent(StreamEnded):
    """One event we cannot use (malformed JSON, an update naming no node); the stream may go on."""


@dataclass(slots=True)  # not frozen: made per event, and frozen init costs 2.5x
class SseEvent:
    """One server-sent event: its type, id and (joined) data lines."""

    event: str
    id: str | None
    data: str


class SseParser:
    """Incremental ``text/event-stream`` parser (WHATWG rules: fields, comments, blank lines).

    Bounded: a line longer than ``max_line`` bytes or an event larger than
    ``max_event`` raises StreamEnded, since a broken device may otherwise send
    a line (or data lines) without end and we would hold all of it.
    """

    def __init__(self, max_line: int = MAX_LINE_BYTES, max_event: int = MAX_EVENT_BYTES) -> None:
        self.max_line = max_line
        self.max_event = max_event
        self._buffer = b""
        self._event = ""
        self._id: str | None = None
        self._data: list[str] = []
        self._size = 0

    @property
    def pending(self) -> bool:
        """True while a partly received event waits for more bytes."""
        return bool(self._buffer or self._data or self._event)

    def feed(self, chunk: bytes) -> list[SseEvent]:
        """The events completed by ``chunk``."""
        data = self._buffer + chunk if self._buffer else chunk
        events: list[SseEvent] = []
        try:
            if b"\r" in data:
                self._feed_any_line_ends(data, events)
            else:
                self._feed_lf(data, events)
        except StreamEnded:
            # The traceback keeps this frame alive until a garbage collection; what it held
            # (up to a line and an event) must not live on with it.
            del data, chunk, events
            self._buffer, self._event, self._data, self._size = b"", "", [], 0
            raise
        return events

    def usual_updates(self, chunk: bytes) -> list[str] | None:
        """The data of every event of ``chunk`` if it holds whole ``update`` events only, laid
        out as data layers send them, and no event was partly received; else None (``feed``
        reads it).

        A publish cycle then costs a regex match per event and no event objects:
        its events are read as ``feed`` would read them (the same last id too).
        """
        if self.pending or not chunk.endswith(b"\n\n") or b"\r" in chunk:
            return None
        text = chunk.decode("utf-8", "replace")
        # A match per event reads each byte once. Matching the whole run, then searching it
        # for the data lines, read each byte twice and cost twice as much.
        datas, last_id, pos, usual = [], None, 0, _USUAL_UPDATE.match
        while pos < len(text):
            event = usual(text, pos)
            if event is None:
                return None
            event_id, data = event.groups()
            if len(data) > self.max_line:
                return None  # ``feed`` raises
            datas.append(data)
            last_id = event_id if event_id is not None else last_id
            pos = event.end()
        if last_id is not None:
            self._id = last_id.strip()
        return datas

    def _feed_lf(self, data: bytes, events: list[SseEvent]) -> None:
        """LF line ends only, as every data layer we know sends: one split, in C.

        This runs for every event of every source (seven per sample of a 7-axis
        arm); finding line ends one by one in Python cost four times as much.
        Cutting at the last LF is safe for UTF-8: no multi-byte sequence holds
        that byte.
        """
        end = data.rfind(b"\n")
        self._buffer = data[end + 1 :]
        if len(self._buffer) > self.max_line:
            raise self._too_long()
        if end < 0:
            return
        text = data[:end].decode("utf-8", "replace")
        pos = 0 if self._data or self._event else self._usual_events(text, events)
        if pos and pos == len(text):
            return  # all of it read (an empty text is still a blank line)
        line = self._line
        for text_line in text[pos:].split("\n"):
            if len(text_line) > self.max_line:
                raise self._too_long()
            line(text_line, events)

    def _usual_events(self, text: str, events: list[SseEvent]) -> int:
        """Whole events laid out as data layers send them, one regex match each; where they end.

        ``event``, maybe ``id``, one ``data`` line, a blank line: the same events the
        line-by-line rules make, at a quarter of their cost (four lines per event,
        seven events per sample of a 7-axis arm). The rest, from the first event
        laid out otherwise, is left to those rules.
        """
        pos, match = 0, _USUAL_EVENT.match
        while (found := match(text, pos)) is not None:
            kind, event_id, data = found.groups()
            if len(data) > self.max_line or len(data) >= self.max_event:
                break  # the line rules raise
            if event_id is not None:
                self._id = event_id.strip()
            events.append(SseEvent(kind.strip() or "message", self._id, data))
            pos = found.end()
        return pos

    def _feed_any_line_ends(self, data: bytes, events: list[SseEvent]) -> None:
        """CRLF, LF or CR line ends (the WHATWG rules), one line at a time."""
        pos = 0
        while (cut := _line_end(data, pos)) is not None:
            end, after = cut
            if end - pos > self.max_line:
                raise self._too_long()
            self._line(data[pos:end].decode("utf-8", "replace"), events)
            pos = after
        self._buffer = data[pos:]
        if len(self._buffer) > self.max_line:
            raise self._too_long()

    def _too_long(self) -> StreamEnded:
        return StreamEnded(
            f"event stream sent a line longer than {self.max_line // 1024} KiB; dropped"
        )

    def _line(self, line: str, events: list[SseEvent]) -> None:
        if not line:
            if self._data:
                events.append(SseEvent(self._event or "message", self._id, "\n".join(self._data)))
            self._event, self._data, self._size = "", [], 0
            return
        if line[0] == ":":
            return  # a comment; some servers send them as heartbeats
        name, _, value = line.partition(":")
        if value[:1] == " ":
            value = value[1:]
        if name == "event":
            self._event = value.strip()
        elif name == "data":
            self._size += len(value) + 1
            if self._size > self.max_event:
                raise StreamEnded(
                    f"event stream sent an event larger than {self.max_event // 1024 // 1024} MiB "
                    "(data lines without the blank line that ends an event); dropped"
                )
            self._data.append(value)
        elif name == "id":
            self._id = value.strip()


_USUAL_EVENT = re.compile(r"event: ?([^\n]*)\n(?:id: ?([^\n]*)\n)?data: ?([^\n]*)\n(?:\n|\Z)")
"""One event as data layers lay it out, in the text before a chunk's last LF: there, a
final LF is followed by the blank line's (the LF cut off), so it ends the event too."""


_USUAL_UPDATE = re.compile(r"event: ?update\n(?:id: ?([^\n]*)\n)?data: ?([^\n]*)\n\n")
"""One whole ``update`` event as data layers lay it out: its id (if any) and data."""


def _line_end(data: bytes, pos: int) -> tuple[int, int] | None:
    """Where the line starting at ``pos`` ends and the next begins (CRLF, LF or CR)."""
    lf, cr = data.find(b"\n", pos), data.find(b"\r", pos)
    if cr == -1 or (lf != -1 and lf < cr):
        return None if lf == -1 else (lf, lf + 1)
    if cr + 1 == len(data):
        return None  # a CR at the end may be the first half of a CRLF
    return cr, cr + 2 if data[cr + 1] == 0x0A else cr + 1


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


@dataclass(slots=True)  # not frozen: made per event, and frozen init costs 2.5x
class Update:
    """A node's new value (or why it has none) at data-layer time ``t_source`` (unix s)."""

    node: str
    t_source: float | None
    value: float | Exception


@dataclass(slots=True)  # not frozen: made per event, and frozen init costs 2.5x
class Keepalive:
    """The stream is alive; nothing changed up to ``t_source`` (unix s, if stated)."""

    t_source: float | None


def decode_event(event: SseEvent, nodes_prefix: str) -> Update | Keepalive | None:
    """Turn one SSE event into an Update or Keepalive; None for events we do not use.

    An ``error`` event that names no node is a failure of the whole stream and
    is raised; an event we cannot read raises InvalidEvent. NaN and Infinity
    literals are read, so they spoil only the node that carries them.
    """
    if event.event not in ("update", "keepalive", "error"):
        return None
    try:
        data = loads(event.data) if event.data and not event.data.isspace() else {}
    except ValueError:
        raise InvalidEvent(f"{event.event} event with malformed JSON {event.data[:40]!r}") from None
    if not isinstance(data, dict):
        data = {}
    t_source = parse_filetime(data.get("timestamp"))
    if event.event == "keepalive":
        return Keepalive(t_source)
    node = data.get("node")
    if event.event == "error":
        status = data.get("status")
        status = status if isinstance(status, int) and 400 <= status <= 599 else 500
        problem = problem_for_status(status, data, "subscription error")
        node = node if isinstance(node, str) else _node_of_instance(problem, nodes_prefix)
        if node is None:
            raise problem
        return Update(node, t_source, problem)
    if not isinstance(node, str):
        raise InvalidEvent("update event without a node")
    value: float | Exception
    try:
        value = number_from_data(node, data)
    except DataLayerError as exc:
        value = exc
    return Update(node, t_source, value)


@dataclass(slots=True)
class PlainUpdates:
    """Updates of plain numbers in arrival order, as three columns: one object for a chunk.

    What ``decode_event`` makes of each event, without an object per event.
    """

    nodes: list[str]
    t_sources: list[float | None]
    values: list[float]


def plain_updates(datas: Sequence[str]) -> PlainUpdates | None:
    """The ``data`` of ``update`` events decoded as ``decode_event`` would, if all are updates
    of plain numbers; else None.

    The usual publish cycle (an update per node: a float value, a FILETIME
    stamp, a scalar type) is read without the general path's layers of calls
    and objects: in a process following 100 controllers decoding took half of
    reading a stream. Anything else (NaN, integer or object values, stamps as
    strings, malformed JSON) returns None and is decoded event by event.
    tests/ctrlx/test_ctrlx_units.py checks that both agree.
    """
    nodes, t_sources, values = [], [], []
    for data in datas:
        try:
            body = orjson.loads(data)
        except orjson.JSONDecodeError:
            return None
        if type(body) is not dict:
            return None
        node, value, stamp = body.get("node"), body.get("value"), body.get("timestamp")
        if (
            type(node) is not str
            or type(value) is not float
            or type(stamp) is not int
            or body.get("type") not in SCALAR_TYPES
            or not math.isfinite(value)
        ):
            return None
        nodes.append(node)
        values.append(value)
        t_source = unix_from_filetime(stamp)
        t_sources.append(t_source if t_source >= FIRST_FILETIME_S else None)
    return PlainUpdates(nodes, t_sources, values)


def _node_of_instance(problem: ProblemError, nodes_prefix: str) -> str | None:
    """The node an error names in ``instance`` (``/automation/api/v2/nodes/<path>``)."""
    if problem.instance and problem.instance.startswith(nodes_prefix):
        return unquote(problem.instance[len(nodes_prefix) :])
    return None


Items = Callable[[Sequence[Update | Keepalive | PlainUpdates], bool], None]
"""Takes the usable events of a chunk, and whether the chunk ended inside an event."""


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
