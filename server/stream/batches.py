"""Samples of every source that arrive within two milliseconds, made into frames at once.

Computing many robots in one batch per kinematic model costs each a fraction
of a call of its own (``compute_frames``): numpy's fixed cost per call is most
of the work for one 7-axis arm. Batching only the samples of one loop turn
gave 1.2 samples per batch at 50 controllers (the sockets seldom become
readable together), so a batch waits ``BATCH_WINDOW_S`` for the others: at 50
controllers of 50 samples/s that is 6 samples per batch, and the server's CPU
per sample fell by a fifth (bench/plant.py). The wait is a tenth of a sample
period.
"""

from __future__ import annotations

import asyncio
import logging
import time
from collections.abc import Callable, Sequence
from dataclasses import dataclass

from ..cell import Robot
from ..per_loop import PerLoop
from .frames import RobotFrame, compute_frame, compute_frames
from .types import RobotSample

log = logging.getLogger(__name__)

BATCH_WINDOW_S = 0.002
"""How long the first sample of a batch waits for others."""

Job = tuple[Robot, RobotSample]
Outcome = tuple[RobotFrame, Exception | None]
"""A robot's frame, and the bug that left it without poses (None: it computed)."""


@dataclass(slots=True)  # not frozen: made per sample; a frozen init costs 1.5 µs more
class Pending:
    """One source's sample: its robots' jobs, and what to do with their frames."""

    jobs: Sequence[Job]
    done: Callable[[list[Outcome], float], None]
    """Called with the outcomes in job order and this sample's share of the compute time (s)."""


class SampleBatch:
    """Collects samples for ``BATCH_WINDOW_S``, then computes them and hands them back."""

    def __init__(self) -> None:
        self._pending: list[Pending] = []
        self.sizes = 0
        """Samples computed so far, every batch together (with ``batches``: the mean size)."""
        self.batches = 0

    def add(self, pending: Pending) -> None:
        """Compute ``pending`` with the other samples that arrive within the window."""
        if not self._pending:
            asyncio.get_running_loop().call_later(BATCH_WINDOW_S, self.flush)
        self._pending.append(pending)

    def flush(self) -> None:
        """Compute what is pending now (the window's timer then finds nothing left)."""
        pending, self._pending = self._pending, []
        if not pending:
            return
        start = time.perf_counter()
        outcomes = outcomes_of([job for p in pending for job in p.jobs])
        share = (time.perf_counter() - start) / len(pending)
        self.batches += 1
        self.sizes += len(pending)
        at = 0
        for p in pending:
            try:
                p.done(outcomes[at : at + len(p.jobs)], share)
            except Exception:  # one source's bug must not cost the others their frames
                log.exception("publishing a sample's frames failed")
            at += len(p.jobs)


def outcomes_of(jobs: Sequence[Job]) -> list[Outcome]:
    """Every job's frame, batched; where the batch fails, robot by robot, a bug costing one only."""
    try:
        return [(frame, None) for frame in compute_frames(jobs)]
    except Exception:  # found again below, robot by robot, and reported there
        return [_alone(robot, sample) for robot, sample in jobs]


def _alone(robot: Robot, sample: RobotSample) -> Outcome:
    try:
        return compute_frame(robot, sample), None
    except Exception as exc:  # one robot's bug must not stop the others
        failed = RobotSample(sample.seq, sample.t_source, None, repr(exc))
        return compute_frame(robot, failed), exc


_BATCHES = PerLoop(SampleBatch)


def sample_batch() -> SampleBatch:
    """The running event loop's batch (every acquisition of the process shares it)."""
    return _BATCHES.get()
