"""How late this process's event loop runs: the first sign that it carries more than it can.

The measure is ``server.lateness`` (one ticker per loop, waking every 0.1 s),
which the data-source watchdogs also use to leave our lateness out of a
device's time. This keeps its histogram and newest value for /metrics.
"""

from __future__ import annotations

import asyncio

from ..lateness import lateness
from ..stream.buckets import Buckets

LAG_BUCKETS_S = (0.001, 0.002, 0.005, 0.01, 0.02, 0.05, 0.1, 0.2, 0.5, 1.0, 5.0)


class LoopLag:
    """Lateness of the event loop's wake-ups (s): a histogram and the newest one."""

    def __init__(self) -> None:
        self.buckets = Buckets(LAG_BUCKETS_S)
        self.newest = 0.0

    def _observe(self, late_s: float) -> None:
        self.newest = late_s
        self.buckets.observe(late_s)

    async def run(self) -> None:
        """Record every tick of the running loop's measure until cancelled."""
        clock = lateness()
        clock.listen(self._observe)
        try:
            await asyncio.Event().wait()
        finally:
            clock.unlisten(self._observe)
