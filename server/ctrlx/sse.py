"""The ``text/event-stream`` format: an incremental, bounded parser (WHATWG rules), with a
fast path for events laid out as data layers send them."""

from __future__ import annotations

import re
from dataclasses import dataclass

from .problem import StreamEnded

MAX_LINE_BYTES = 64 * 1024
"""Longest SSE line we hold; an update line of one node is ~200 bytes."""
MAX_EVENT_BYTES = 1024 * 1024
"""Largest event (its data lines together) we hold."""


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
