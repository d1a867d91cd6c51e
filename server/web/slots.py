"""A few requests at a time, a few more waiting briefly, the rest 503 with ``Retry-After``.

For work that holds the interpreter in turns with the event loop that streams
to viewers (transformations, recordings saved from the history): more of it
at once would only share the same core more thinly and slow the stream.
"""

from __future__ import annotations

import asyncio
import contextlib
from collections.abc import AsyncIterator

from fastapi import HTTPException


class Slots:
    """``running`` requests at once; ``waiting`` more wait up to ``wait_s``; the rest get 503."""

    def __init__(
        self, busy: str, running: int, waiting: int = 0, wait_s: float = 0.0, retry_s: int = 1
    ) -> None:
        self.busy_text = busy
        """What the 503 says is going on ("1 recording is being saved")."""
        self.running, self.max_waiting, self.wait_s, self.retry_s = (
            running,
            waiting,
            wait_s,
            retry_s,
        )
        self._slots: asyncio.Semaphore | None = None  # made in the serving loop
        self.waiting = 0
        self.refused = 0

    @contextlib.asynccontextmanager
    async def slot(self) -> AsyncIterator[None]:
        """Hold one slot for the block; HTTPException 503 if none comes in time."""
        if self._slots is None:
            self._slots = asyncio.Semaphore(self.running)
        if self._slots.locked() and self.waiting >= self.max_waiting:
            raise self._busy()
        self.waiting += 1
        try:
            async with asyncio.timeout(self.wait_s):
                await self._slots.acquire()
        except TimeoutError:
            raise self._busy() from None
        finally:
            self.waiting -= 1
        try:
            yield
        finally:
            self._slots.release()

    def _busy(self) -> HTTPException:
        self.refused += 1
        return HTTPException(
            status_code=503,
            detail=f"busy: {self.busy_text}; try again in {self.retry_s} s",
            headers={"Retry-After": str(self.retry_s)},
        )
