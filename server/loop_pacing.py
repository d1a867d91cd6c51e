"""Under a flood of wake-ups, the event loop wakes once per tick and takes every ready socket.

Each controller's event stream sends a chunk per publish cycle, each at its
own moment. A loop that waits in epoll between them wakes once per chunk: at
100 controllers of 50 samples/s, 1 200 to 2 000 times a second. Each wake-up
is a context switch and an exit from idle, 30 to 75 µs of CPU on the 2-core
virtual machine of docs/benchmarks.md (bench/wakeups.py), and each chunk is
then made into frames with the few others of its 2 ms batch. Paced, the loop
wakes about 500 times a second, its batches hold twice the samples, and the
server's CPU per robot-sample fell by 15 to 29 % at 50 to 150 controllers
(bench/plant.py, section "Robots per core, before and after pacing").

While the loop's thread is woken more than ``ON_WAKES_PER_S`` times a second,
it is paced: a callback at the end of every turn keeps the loop from waiting in
epoll and sleeps until the next tick (every ``TICK_S``), so each turn takes all
the chunks that arrived meanwhile. The price is latency: a sample waits for its
turn's tick, then for its batch (``BATCH_WINDOW_S``, also 2 ms); the median delay
from a controller's sample to the viewer grew from 4 to 7 or 8 ms. A turn that runs past its tick
sleeps not at all: an overloaded loop runs as it would unpaced. Every
``PROBE_AFTER_S`` the pacing stops for one measuring period, to see whether the
flood goes on; when it does not, the loop stays unpaced and reacts at once.
"""

from __future__ import annotations

import asyncio
import logging
import resource
import time

from .lateness import lateness
from .per_loop import PerLoop

log = logging.getLogger(__name__)

TICK_S = 0.002
"""A paced loop turns at most this often; the sample batch waits as long (BATCH_WINDOW_S)."""
ON_WAKES_PER_S = 1000.0
"""Twice the paced rate: pacing at least halves the wake-ups it is switched on for."""
PROBE_AFTER_S = 2.0
"""Paced this long, the loop runs one measuring period (lateness.PERIOD_S) unpaced."""


def wakes_so_far() -> int | None:
    """Times the calling thread gave up the CPU to wait (voluntary context switches); None
    where the system does not count them per thread (the loop is then never paced)."""
    thread = getattr(resource, "RUSAGE_THREAD", None)
    return None if thread is None else resource.getrusage(thread).ru_nvcsw


class LoopPacer:
    """Paces one event loop while its thread is woken too often (see the module's text)."""

    def __init__(self) -> None:
        self.paced = False
        """On: the loop turns once per tick (but for a probe's measuring period now and then)."""
        self.wakes_per_s = 0.0
        """Wake-ups per second in the newest measuring period that ran unpaced."""
        self._probing = False
        """Paced, but the period in progress runs unpaced, to measure."""
        self._turning = False
        """True while a chain of ``_turn`` calls runs (it ends at its first call unpaced)."""
        self._started = False
        self._paced_since = 0.0
        self._next_tick = 0.0
        self._wakes = wakes_so_far()
        self._measured = time.monotonic()

    def start(self) -> None:
        """Measure the running loop's wake-ups and pace it when flooded (idempotent)."""
        if not self._started and self._wakes is not None:
            self._started = True
            lateness().listen(self._measure)

    def _measure(self, _late_s: float) -> None:
        """After every lateness tick: the wake-ups since the last, and what they call for."""
        wakes, now = wakes_so_far(), time.monotonic()
        assert wakes is not None and self._wakes is not None  # else never started
        rate = (wakes - self._wakes) / max(now - self._measured, 1e-3)
        self._wakes, self._measured = wakes, now
        if self.paced and not self._probing:  # the sleeps are wake-ups too: nothing learnt
            if now - self._paced_since >= PROBE_AFTER_S:
                self._probing = True  # the chain of turns ends at its next call
            return
        self.wakes_per_s = rate
        if rate > ON_WAKES_PER_S:
            if not self.paced:
                log.info(
                    "event loop woken %.0f times a second: one turn per %g ms from now on",
                    rate,
                    TICK_S * 1e3,
                )
            self._pace(now)
        elif self.paced:  # a probe found the flood over
            self.paced = self._probing = False
            log.info("event loop woken %.0f times a second: unpaced again", rate)

    def _pace(self, now: float) -> None:
        self.paced, self._probing, self._paced_since = True, False, now
        self._next_tick = now + TICK_S
        if not self._turning:  # a chain not yet ended by the probe goes on
            self._turning = True
            asyncio.get_running_loop().call_soon(self._turn)

    def _turn(self) -> None:
        """The end of a paced turn: sleep until the next tick, and come again after the next turn.

        Being in the ready queue, this keeps the loop from waiting in epoll; the
        sleep is the turn's only wait, and the loop's next poll finds every socket
        that became ready meanwhile.
        """
        if not self.paced or self._probing:
            self._turning = False
            return
        now = time.monotonic()
        if now < self._next_tick:
            time.sleep(self._next_tick - now)
            self._next_tick += TICK_S
        else:  # behind: no sleep, and no burst of short ticks to catch up
            self._next_tick = now + TICK_S
        asyncio.get_running_loop().call_soon(self._turn)


_PACERS = PerLoop(LoopPacer)


def loop_pacer() -> LoopPacer:
    """The running event loop's pacer (not started until ``start``)."""
    return _PACERS.get()
