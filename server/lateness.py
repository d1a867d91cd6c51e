"""How late this process's event loop runs, summed: time that we, not a device, are to blame for.

A controller that answers in time, but whose answer waits in our queue
because the event loop is busy, is not late. Watchdogs on devices (a request
with no answer, a silent event stream, a stale source) therefore count only
the time the loop was on time: the time that passed, less the lateness
measured meanwhile. Otherwise a busy process declares live controllers dead,
reconnects them, and gets busier still: a cliff instead of a slower rate.

One ticker per event loop asks to wake every ``PERIOD_S`` and sums how much
later it woke; it starts on first use. /metrics exports the same measure.
"""

from __future__ import annotations

import asyncio
import logging
import time
import weakref
from collections.abc import Callable
from types import TracebackType
from typing import NamedTuple

log = logging.getLogger(__name__)

PERIOD_S = 0.1


class Mark(NamedTuple):
    """An instant, and the lateness of ``clock`` summed up to it (both s, monotonic clock)."""

    at: float
    late: float
    clock: Lateness

    def on_time_s(self) -> float:
        """Seconds since this mark during which the loop was on time."""
        return self.clock.on_time_since(self)


class Lateness:
    """Lateness of one event loop's wake-ups (s): their sum, the newest, listeners of each."""

    def __init__(self) -> None:
        self.total_s = 0.0
        """Lateness of every finished tick, summed."""
        self.newest_s = 0.0
        self._due: float | None = None
        """When the tick in progress should wake (None: no ticker, e.g. outside a loop)."""
        self._listeners: list[Callable[[float], None]] = []
        self._task: asyncio.Task[None] | None = None

    def listen(self, listener: Callable[[float], None]) -> None:
        """Call ``listener(late_s)`` after every tick."""
        self._listeners.append(listener)

    def unlisten(self, listener: Callable[[float], None]) -> None:
        """Stop calling ``listener``."""
        self._listeners.remove(listener)

    def late_so_far(self, now: float | None = None) -> float:
        """Lateness summed up to ``now``, the overdue part of the tick in progress included."""
        now = time.monotonic() if now is None else now
        pending = 0.0 if self._due is None else max(0.0, now - self._due)
        return self.total_s + pending

    def mark(self) -> Mark:
        """Now, to measure on-time seconds from (``on_time_since``)."""
        now = time.monotonic()
        return Mark(now, self.late_so_far(now), self)

    def on_time_since(self, mark: Mark) -> float:
        """Seconds since ``mark`` during which the loop was on time (elapsed less lateness)."""
        now = time.monotonic()
        return max(0.0, now - mark.at - (self.late_so_far(now) - mark.late))

    async def run(self) -> None:
        """Measure forever (cancel to stop)."""
        while True:
            self._due = time.monotonic() + PERIOD_S
            await asyncio.sleep(PERIOD_S)
            now = time.monotonic()
            late = max(0.0, now - self._due)
            self.total_s, self.newest_s, self._due = self.total_s + late, late, None
            for listener in tuple(self._listeners):  # a listener may unlisten meanwhile
                try:
                    listener(late)
                except Exception:  # one listener's bug must not stop the measure for all
                    log.exception("a listener of the loop's lateness failed")


_OF_LOOP: weakref.WeakKeyDictionary[asyncio.AbstractEventLoop, Lateness] = (
    weakref.WeakKeyDictionary()
)
_IDLE = Lateness()
"""Outside an event loop nothing is late (and no ticker runs)."""


def lateness() -> Lateness:
    """The measure of the running event loop, its ticker started on the first call."""
    try:
        loop = asyncio.get_running_loop()
    except RuntimeError:
        return _IDLE
    found = _OF_LOOP.get(loop)
    if found is None:
        found = _OF_LOOP[loop] = Lateness()
        found._task = loop.create_task(found.run(), name="loop lateness")
    return found


class PatientTimeout:
    """``asyncio.timeout(budget_s)`` that counts only the seconds our event loop was on time.

    ``async with PatientTimeout(5.0):`` raises TimeoutError once the block has
    had 5 s of on-time loop without finishing. Where the loop ran late, the
    deadline moves on by that much, so only the device's own slowness counts.
    """

    def __init__(self, budget_s: float) -> None:
        self.budget_s = budget_s
        self._timeout = asyncio.timeout(None)
        self._handle: asyncio.TimerHandle | None = None

    async def __aenter__(self) -> PatientTimeout:
        await self._timeout.__aenter__()
        if self.budget_s != float("inf"):
            loop, mark = asyncio.get_running_loop(), lateness().mark()

            def check() -> None:
                left = self.budget_s - mark.on_time_s()
                if left <= 0.0:
                    self._timeout.reschedule(loop.time())  # expires at once
                else:
                    self._handle = loop.call_later(left, check)

            self._handle = loop.call_later(self.budget_s, check)
        return self

    async def __aexit__(
        self,
        exc_type: type[BaseException] | None,
        exc: BaseException | None,
        tb: TracebackType | None,
    ) -> None:
        if self._handle is not None:
            self._handle.cancel()
        await self._timeout.__aexit__(exc_type, exc, tb)
