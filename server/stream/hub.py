"""Fan-out of encoded messages to viewers: the newest message per key, never a backlog.

Each viewer has one slot per key (``hello:<protocol>``, ``cell``,
``frames<protocol>:<source>``, ``status:<source>``). Publishing overwrites the slot; a
viewer that reads slowly therefore skips stale frames instead of queueing
them, and can never slow the others down. A message may be meant for one
protocol version only (protocol 1's JSON frames, protocol 2's binary ones);
viewers get what their protocol speaks.

A viewer whose connection can take a message right away (nothing pending,
its socket keeping up) gets it written at once by ``send_now``, which the
web layer provides; only the others keep it pending for their own task.
"""

from __future__ import annotations

import asyncio
import itertools
from collections import Counter
from collections.abc import Callable

from .buckets import Buckets

Payload = str | bytes | tuple[str, ...]
"""One text or binary WebSocket message, or several text messages sent together."""


class Message:
    """An encoded message, the same bytes for every viewer."""

    __slots__ = ("payload", "t_source", "wire")

    def __init__(self, payload: Payload, t_source: float | None = None) -> None:
        self.payload = payload
        self.t_source = t_source
        """When the data layer sampled what a frame message shows (unix s); None otherwise."""
        self.wire: bytes | None = None
        """The message as the transport sends it, made once by the first viewer to need it."""


class Viewer:
    """One connected viewer's pending messages, newest per key."""

    _ids = itertools.count(1)

    def __init__(
        self, protocol: int = 1, send_now: Callable[[Message], bool] | None = None
    ) -> None:
        self.id = next(self._ids)
        self.protocol = protocol
        self.send_now = send_now
        """Sends a message at once if the connection can take it (True), else declines."""
        self.busy = False
        """Set while the viewer's task sends: a message sent now could overtake older ones."""
        self._pending: dict[str, Message] = {}
        self._ready = asyncio.Event()
        self.closed = False
        self.dropped = 0
        """Messages overwritten before this viewer read them."""

    def offer(self, key: str, message: Message) -> None:
        """Send ``message`` now if possible, else replace the pending one for ``key``."""
        if self.send_now is not None and not self._pending and not self.busy:
            if self.send_now(message):
                return
        if key in self._pending:
            self.dropped += 1
        self._pending[key] = message
        self._ready.set()

    def forget(self) -> None:
        """Drop everything pending (the cell changed: it would describe robots gone by)."""
        self._pending.clear()

    def close(self) -> None:
        """Wake a waiting ``take`` for good: the viewer went away."""
        self.closed = True
        self._ready.set()

    async def take(self) -> list[Message]:
        """Wait for pending messages and take them all, oldest key first; [] once closed."""
        await self._ready.wait()
        if self.closed:
            return []
        self._ready.clear()
        batch = list(self._pending.values())
        self._pending.clear()
        return batch


class Hub:
    """Keeps the newest message per key and offers every new one to the viewers it is for."""

    def __init__(self) -> None:
        self._viewers: set[Viewer] = set()
        self._latest: dict[str, tuple[Message, int | None]] = {}
        self._protocols: Counter[int] = Counter()
        self.dropped_by_departed = 0
        self.delay = Buckets()
        """Seconds from the data layer's sample to the send of each frame message, per viewer."""

    def publish(self, key: str, message: Message, protocol: int | None = None) -> None:
        """Offer ``message`` (already encoded) to every viewer of ``protocol`` (None: all)."""
        self._latest[key] = (message, protocol)
        for viewer in self._viewers:
            if protocol is None or viewer.protocol == protocol:
                viewer.offer(key, message)

    def discard(self, key: str) -> None:
        """Forget the newest message of ``key``: it went stale and must not greet a new viewer."""
        self._latest.pop(key, None)

    def restart(self) -> None:
        """Forget every message, kept and pending: what follows describes a new cell."""
        self._latest.clear()
        for viewer in self._viewers:
            viewer.forget()

    def join(self, protocol: int = 1, send_now: Callable[[Message], bool] | None = None) -> Viewer:
        """A new viewer, primed with the newest message of every key for its protocol."""
        viewer = Viewer(protocol, send_now)
        for key, (message, only) in self._latest.items():
            if only is None or only == protocol:
                viewer.offer(key, message)
        self._viewers.add(viewer)
        self._protocols[protocol] += 1
        return viewer

    def leave(self, viewer: Viewer) -> None:
        """Forget a viewer that disconnected."""
        if viewer in self._viewers:
            self._viewers.discard(viewer)
            self._protocols[viewer.protocol] -= 1
            self.dropped_by_departed += viewer.dropped

    def wants(self, protocol: int) -> bool:
        """True when a viewer of ``protocol`` is connected (so its messages are worth encoding)."""
        return self.viewers_of(protocol) > 0

    def viewers_of(self, protocol: int) -> int:
        """Viewers of ``protocol`` connected now."""
        return self._protocols[protocol]

    @property
    def viewer_count(self) -> int:
        """Viewers connected now."""
        return len(self._viewers)

    @property
    def dropped(self) -> int:
        """Messages skipped by slow viewers, connected or gone."""
        return self.dropped_by_departed + sum(v.dropped for v in self._viewers)
