"""Newest wins, at most once per period: how a fast source meets the frame cadence.

A controller that sends faster than the frames go out (RTDE's 500 Hz, a busy
MQTT topic) keeps only its newest values; ``Throttle`` decides when they are
delivered: at once when a period has passed since the last delivery (no added
latency), else when it has. Nothing queues, and no task wakes per message.
"""

from __future__ import annotations

import asyncio
from collections.abc import Callable


class Throttle:
    """Calls ``emit()`` after an ``offer()``, at most once per ``period_s`` (event loop time)."""

    def __init__(self, period_s: float, emit: Callable[[], None]) -> None:
        self.period_s = period_s
        self._emit = emit
        self._loop = asyncio.get_running_loop()
        self._last = -float("inf")
        self._handle: asyncio.TimerHandle | None = None

    def offer(self) -> None:
        """New values are waiting: emit now, or when the period has passed (once)."""
        if self._handle is not None:
            return
        wait = self._last + self.period_s - self._loop.time()
        if wait <= 0.0:
            self._fire()
        else:
            self._handle = self._loop.call_later(wait, self._fire)

    def _fire(self) -> None:
        self._handle = None
        self._last = self._loop.time()
        self._emit()

    def cancel(self) -> None:
        """Drop a pending emit (the source stopped)."""
        if self._handle is not None:
            self._handle.cancel()
            self._handle = None
