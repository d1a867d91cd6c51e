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

While the loop's thread is woken more than ``ON_WAKES_PER_S`` times a second and
uses more than ``BUSY_ABOVE`` of a core, it is paced: a callback in every turn
keeps the loop from waiting in epoll and sleeps until the next tick (every
``TICK_S``), so each turn takes all the chunks that arrived meanwhile. The price
is latency: a sample waits for the tick and one sleep more (``_turn`` says why),
then for its batch (``BATCH_WINDOW_S``, also 2 ms); the median delay from a
controller's sample to the viewer grew from 4 to 7 or 8 ms. A turn that runs
past its tick sleeps not at all: an overloaded loop runs as it would unpaced.
Every ``PROBE_AFTER_S`` the pacing stops for one measuring period, to see
whether the flood goes on; when it does not, the loop stays unpaced and reacts
at once.
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
BUSY_ABOVE = 0.25
"""The share of a core the loop's thread must use as well: below, saving CPU is not worth
the delay (a robot's frame waits up to 4 ms more)."""
SATURATED_ABOVE = 0.9
"""A loop this busy is paced however seldom it waits: it seldom waits because it is always
behind, and unpaced, the first relief would bring the flood of wake-ups back."""
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
        self.busy = 0.0
        """The share of a core the loop's thread used in that period."""
        self._probing = False
        """Paced, but the period in progress runs unpaced, to measure."""
        self._flooded = False
        """The last period measured unpaced called for pacing (one alone is not enough)."""
        self._turning = False
        """True while a chain of ``_turn`` calls runs (it ends at its first call unpaced)."""
        self._started = False
        self._paced_since = 0.0
        self._next_tick = 0.0
        self._wakes = wakes_so_far()
        self._cpu = time.thread_time()
        self._measured = time.monotonic()

    def start(self) -> None:
        """Measure the running loop's wake-ups and pace it when flooded (idempotent)."""
        if not self._started and self._wakes is not None:
            self._started = True
            lateness().listen(self._measure)

    def _measure(self, _late_s: float) -> None:
        """After every lateness tick (in the loop's thread): the wake-ups and CPU since the
        last, and what they call for."""
        wakes, cpu, now = wakes_so_far(), time.thread_time(), time.monotonic()
        assert wakes is not None and self._wakes is not None  # else never started
        elapsed = max(now - self._measured, 1e-3)
        rate, busy = (wakes - self._wakes) / elapsed, (cpu - self._cpu) / elapsed
        self._wakes, self._cpu, self._measured = wakes, cpu, now
        if self.paced and not self._probing:  # the sleeps are wake-ups too: nothing learnt
            if now - self._paced_since >= PROBE_AFTER_S:
                self._probing = True  # the chain of turns ends at its next call
            return
        self.wakes_per_s, self.busy = rate, busy
        news = f"event loop woken {rate:.0f} times a second, {busy:.0%} busy"
        flooded = busy > BUSY_ABOVE and (rate > ON_WAKES_PER_S or busy > SATURATED_ABOVE)
        before, self._flooded = self._flooded, flooded
        if flooded and (self.paced or before):  # a probe confirms; else two periods in a row
            if not self.paced:
                log.info("%s: one turn per %g ms from now on", news, TICK_S * 1e3)
            self._pace(now)
        elif not flooded and self.paced:  # a probe found the flood over
            self.paced = self._probing = False
            log.info("%s: unpaced again", news)

    def _pace(self, now: float) -> None:
        self.paced, self._probing, self._paced_since = True, False, now
        self._next_tick = now + TICK_S
        if not self._turning:  # a chain not yet ended by the probe goes on
            self._turning = True
            asyncio.get_running_loop().call_soon(self._turn)

    def _turn(self) -> None:
        """Sleep until the next tick, and come again next turn.

        Being in the ready queue, this keeps the loop from waiting in epoll; the sleep
        is the turn's only wait, and the loop's next poll finds every socket that became
        ready meanwhile. It runs first in its turn, before the reads the last poll
        queued, so a read waits for one sleep more (a median of 3 ms instead of 1, for
        stamps a thread wrote into a socket every 1 ms). Sleeping only every other turn
        took the reads at once, but batches then held a third fewer samples and a robot-
        sample cost about 7 % more CPU (bench/plant.py, K = 50 to 150): at 50 frames a
        second, the 2 ms are not worth it.
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
