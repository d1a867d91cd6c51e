"""How late this process's event loop runs: the first sign that it carries more than it can.

A task asks to wake every ``PERIOD_S`` and measures how much later it woke.
That lateness is ours, not a controller's: it is what every sample, frame
and reply waited for a turn. /metrics exports the histogram and the newest value.
"""

from __future__ import annotations

import asyncio
import time

from ..stream.buckets import Buckets

PERIOD_S = 0.1
LAG_BUCKETS_S = (0.001, 0.002, 0.005, 0.01, 0.02, 0.05, 0.1, 0.2, 0.5, 1.0, 5.0)


class LoopLag:
    """Lateness of the event loop's wake-ups (s): a histogram and the newest one."""

    def __init__(self) -> None:
        self.buckets = Buckets(LAG_BUCKETS_S)
        self.newest = 0.0

    async def run(self) -> None:
        """Measure forever (cancel to stop)."""
        while True:
            start = time.perf_counter()
            await asyncio.sleep(PERIOD_S)
            self.newest = max(0.0, time.perf_counter() - start - PERIOD_S)
            self.buckets.observe(self.newest)
