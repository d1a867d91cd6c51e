"""The samples of every source that arrive in one turn of the event loop, made into frames at once.

A busy process reads many sources per turn (the sockets that became readable
together); computing their robots in one batch per kinematic model costs each
a fraction of a call of its own (``compute_frames``). An idle process sees one
sample per turn and loses nothing but the turn (microseconds). So the batch
grows with the load, which is when it pays.
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

Job = tuple[Robot, RobotSample]
Outcome = tuple[RobotFrame, Exception | None]
"""A robot's frame, and the bug that left it without poses (None: it computed)."""


@dataclass(frozen=True)
class Pending:
    """One source's sample: its robots' jobs, and what to do with their frames."""

    jobs: Sequence[Job]
    done: Callable[[list[Outcome], float], None]
    """Called with the outcomes in job order and this sample's share of the compute time (s)."""


class TurnBatch:
    """Collects the samples of one turn; computes and hands them back at the turn's end."""

    def __init__(self) -> None:
        self._pending: list[Pending] = []
        self.sizes = 0
        """Samples computed so far, every turn together (with ``turns``: the mean batch)."""
        self.turns = 0

    def add(self, pending: Pending) -> None:
        """Compute ``pending`` with the rest of this turn's samples, at its end."""
        if not self._pending:
            asyncio.get_running_loop().call_soon(self._run)
        self._pending.append(pending)

    def _run(self) -> None:
        pending, self._pending = self._pending, []
        start = time.perf_counter()
        outcomes = outcomes_of([job for p in pending for job in p.jobs])
        share = (time.perf_counter() - start) / len(pending)
        self.turns += 1
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


_BATCHES = PerLoop(TurnBatch)


def turn_batch() -> TurnBatch:
    """The running event loop's batch (every acquisition of the process shares it)."""
    return _BATCHES.get()
