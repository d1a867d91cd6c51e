"""Keeping a loop at a steady rate, used by the client's polling and the mock's publishing."""

from __future__ import annotations

import asyncio
import time


class Pacer:
    """Sleeps between iterations so that they start every ``period_s`` on average.

    A little late, the next sleep is shorter so the rate holds; a whole
    period behind, the missed ticks are skipped rather than run in a burst.
    """

    def __init__(self, period_s: float) -> None:
        self.period_s = period_s
        self._next = time.monotonic()
        self.skipped = 0
        """Ticks skipped so far (the loop ran a whole period or more behind)."""

    def due_in(self) -> float:
        """Seconds until the next tick (``wait`` sleeps at most that long)."""
        return self._next + self.period_s - time.monotonic()

    async def wait(self) -> None:
        """Sleep until the next tick is due."""
        delay = self.due_in()
        self._next += self.period_s
        if delay < -self.period_s:
            self.skipped += int(-delay / self.period_s)
            self._next, delay = time.monotonic(), 0.0
        await asyncio.sleep(max(delay, 0.0))
