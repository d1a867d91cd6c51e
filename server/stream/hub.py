"""Fan-out of encoded messages to viewers: the newest message per key, never a backlog.

Each viewer has one slot per key (``frame:<robot>``, ``status:<source>``). Publishing
overwrites the slot; a viewer that reads slowly therefore skips stale frames
instead of queueing them, and can never slow the others down.
"""

from __future__ import annotations

import asyncio
import itertools


class Viewer:
    """One connected viewer's pending messages, newest per key."""

    _ids = itertools.count(1)

    def __init__(self) -> None:
        self.id = next(self._ids)
        self._pending: dict[str, str] = {}
        self._ready = asyncio.Event()
        self.closed = False
        self.dropped = 0
        """Messages overwritten before this viewer read them."""

    def offer(self, key: str, message: str) -> None:
        """Replace the pending message for ``key``; never blocks."""
        if key in self._pending:
            self.dropped += 1
        self._pending[key] = message
        self._ready.set()

    def close(self) -> None:
        """Wake a waiting ``take`` for good: the viewer went away."""
        self.closed = True
        self._ready.set()

    async def take(self) -> list[str]:
        """Wait for pending messages and take them all, oldest key first; [] once closed."""
        await self._ready.wait()
        if self.closed:
            return []
        self._ready.clear()
        batch = list(self._pending.values())
        self._pending.clear()
        return batch


class Hub:
    """Keeps the newest message per key and offers every new one to all viewers."""

    def __init__(self) -> None:
        self._viewers: set[Viewer] = set()
        self._latest: dict[str, str] = {}
        self.dropped_by_departed = 0

    def publish(self, key: str, message: str) -> None:
        """Offer ``message`` (already encoded) to every viewer."""
        self._latest[key] = message
        for viewer in self._viewers:
            viewer.offer(key, message)

    def join(self) -> Viewer:
        """A new viewer, primed with the newest message of every key."""
        viewer = Viewer()
        for key, message in self._latest.items():
            viewer.offer(key, message)
        self._viewers.add(viewer)
        return viewer

    def leave(self, viewer: Viewer) -> None:
        """Forget a viewer that disconnected."""
        self._viewers.discard(viewer)
        self.dropped_by_departed += viewer.dropped

    @property
    def viewer_count(self) -> int:
        """Viewers connected now."""
        return len(self._viewers)

    @property
    def dropped(self) -> int:
        """Messages skipped by slow viewers, connected or gone."""
        return self.dropped_by_departed + sum(v.dropped for v in self._viewers)
