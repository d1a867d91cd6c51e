"""One acquisition task per data source, shared by every viewer.

It follows the joint nodes of every robot on that source through the
source's connector (whatever its protocol), turns each sample into poses
once, encodes them once per protocol, and publishes them to the hub. Viewer
count never changes the traffic to the device.
"""

from __future__ import annotations

import asyncio
import logging
import time
from collections.abc import Mapping
from dataclasses import dataclass

import numpy as np

from ..cell import Robot
from ..lateness import lateness
from ..sources import Connector, Sample, SourceError
from .batches import Job, Outcome, Pending, sample_batch
from .buckets import Buckets
from .frames import encode_binary, encode_json
from .hub import Hub, Message
from .status import SourceHealth
from .types import Array, NoTap, RobotSample, SampleTap

log = logging.getLogger(__name__)

STATUS_EVERY_S = 1.0
"""Status is republished this often, so pages show a live sample age."""
KINEMATICS_BUCKETS_S = (1e-5, 2e-5, 5e-5, 1e-4, 2e-4, 5e-4, 1e-3, 2e-3, 5e-3, 1e-2)


@dataclass(frozen=True)
class PollSettings:
    """How often to read, and how long to wait after the source failed."""

    period_s: float = 0.02
    retry_min_s: float = 0.5
    retry_max_s: float = 1.5
    """Kept short: a device that behaves again must be streaming within 2 s."""
    sample_cost_s: float = 0.0
    """CPU seconds wasted per sample: a test knob that overloads the process on purpose."""


class Acquisition:
    """Follows one data source and publishes frames for its robots."""

    def __init__(
        self,
        connector: Connector,
        robots: list[Robot],
        hub: Hub,
        health: SourceHealth,
        settings: PollSettings = PollSettings(),
        indices: Mapping[str, int] | None = None,
        tap: SampleTap | None = None,
    ) -> None:
        self.connector = connector
        self.tap: SampleTap = tap or NoTap()
        """Sees every sample and state change (the source's history)."""
        self._hub = hub
        self.health = health
        self.health.period_s = settings.period_s
        self._settings = settings
        self._seq = 0
        self._nodes = sorted({node for robot in robots for node in robot.followed})
        self._robots: list[tuple[int, Robot]] = []
        self.set_robots(robots, indices)
        self._status_sent = 0.0
        self._state_sent = ""
        self.failures = 0
        """Times the source failed as a whole."""
        self.kinematics_time = Buckets(KINEMATICS_BUCKETS_S)
        """Seconds per sample spent on the poses of every robot of the source."""
        self._frames_keys = (f"frames1:{health.name}", f"frames2:{health.name}")
        self._frames1_kept = False
        """True while the hub keeps a protocol-1 frame of this source."""

    def set_robots(self, robots: list[Robot], indices: Mapping[str, int] | None = None) -> None:
        """Swap in new robot definitions that read the same nodes (a reloaded cell)."""
        if sorted({node for robot in robots for node in robot.followed}) != self._nodes:
            raise ValueError("set_robots cannot change the nodes followed; restart instead")
        positions = indices or {r.name: i for i, r in enumerate(robots)}
        self._robots = [(positions[r.name], r) for r in robots]

    async def run(self) -> None:
        """Follow the source forever; errors are reported and retried, never raised."""
        # The loop's lateness ticker (10 Hz) checks the state: one task wakes for every
        # source of the process, not one per source.
        ticker = lateness()
        ticker.listen(self._check_state)
        try:
            await self._follow_forever()
        finally:
            ticker.unlisten(self._check_state)

    async def _follow_forever(self) -> None:
        retry = self._settings.retry_min_s
        while True:
            seq = self._seq
            try:
                await self._follow()
            except SourceError as exc:
                self._report_error(str(exc))
            except Exception as exc:  # a bug must not end the only stream of this source
                log.exception("data source %s: unexpected error", self.health.name)
                self._report_error(f"internal error: {exc!r}")
            if self._seq != seq:  # it worked for a while: a new failure starts the waits over
                retry = self._settings.retry_min_s
            await asyncio.sleep(retry)
            retry = min(retry * 2.0, self._settings.retry_max_s)

    async def _follow(self) -> None:
        """Process the source's samples until it fails."""
        # A connector may deliver as the bytes arrive (ctrlX's event streams): no task per sample.
        await self.connector.follow(self._nodes, self._settings.period_s, self._on_sample)

    def _check_state(self, _late_s: float) -> None:
        """Publish status when the derived state changes (e.g. stale) and once a second."""
        load_changed = self.health.roll_window()
        if load_changed:
            news = self.health.overloaded or "all samples processed again"
            level = logging.WARNING if self.health.overloaded else logging.INFO
            log.log(level, "data source %s: %s", self.health.name, news)
        state = self.health.current_state()
        due = time.monotonic() - self._status_sent >= STATUS_EVERY_S
        if load_changed or state != self._state_sent or due:
            if state == "stale" and self._state_sent != "stale":
                log.warning("data source %s: %s", self.health.name, self.health.status().error)
            self.publish_status()

    def _on_sample(self, sample: Sample) -> None:
        self._seq += 1
        self.tap.sample(self._seq, sample)
        if self._settings.sample_cost_s:
            _burn(self._settings.sample_cost_s)
        seq, robots = self._seq, self._robots
        jobs = [(robot, self._robot_sample(robot, sample, seq)) for _, robot in robots]

        def done(outcomes: list[Outcome], compute_s: float) -> None:
            # Connected once its robots have frames: health never shows one without the other.
            if self.health.mark_sample(sample.received):
                self.publish_status()
            self.kinematics_time.observe(compute_s)
            self._publish(seq, sample, robots, jobs, outcomes)

        # Computed with the samples of other sources that arrive within the batch window.
        sample_batch().add(Pending(jobs, done))

    def _robot_sample(self, robot: Robot, sample: Sample, seq: int) -> RobotSample:
        read = [sample.values[n] for n in robot.nodes]
        errors = [str(v) for v in read if isinstance(v, Exception)]
        return RobotSample(
            seq=seq,
            t_source=sample.t_source,
            values=None if errors else np.array(read, dtype=np.float64),
            error="; ".join(errors) if errors else None,
            setpoints=self._setpoints(robot, sample),
        )

    def _publish(
        self,
        seq: int,
        sample: Sample,
        robots: list[tuple[int, Robot]],
        jobs: list[Job],
        outcomes: list[Outcome],
    ) -> None:
        """Encode one sample's frames once per protocol and hand them to the hub."""
        frames = []
        for (index, robot), (_, read), (frame, bug) in zip(robots, jobs, outcomes, strict=True):
            frames.append((index, frame))
            if self.health.mark_robot(robot.name, frame.ok, frame.error, read.values):
                if frame.ok:  # a change: logged once, not per sample
                    log.info("robot %s: streaming", robot.name)
                else:
                    log.warning("robot %s: %s", robot.name, frame.error, exc_info=bug)
        t_sent = time.time()
        binary = encode_binary(frames, seq, sample.t_source, t_sent)
        frames1, frames2 = self._frames_keys
        self._hub.publish(frames2, Message(binary, sample.t_source), protocol=2)
        if self._hub.wants(1):  # protocol 1 costs a JSON encoding per robot: only when watched
            # One frame message per robot, but sent together: one write per viewer and sample.
            texts = tuple(encode_json(frame, t_sent) for _, frame in frames)
            self._hub.publish(frames1, Message(texts, sample.t_source), protocol=1)
            self._frames1_kept = True
        elif self._frames1_kept:  # the last one made is old now: it must greet no new viewer
            self._hub.discard(frames1)
            self._frames1_kept = False

    @staticmethod
    def _setpoints(robot: Robot, sample: Sample) -> Array | None:
        """The setpoint values, if the robot has setpoint nodes and all of them were read.

        A setpoint that cannot be read costs the ghost, never the actual pose; nor does one
        a sample lacks (a recording keeps the joints' nodes, not their setpoints').
        """
        if not robot.setpoint_nodes:
            return None
        read = [sample.values.get(n) for n in robot.setpoint_nodes]
        if any(v is None or isinstance(v, Exception) for v in read):
            return None
        return np.array(read, dtype=np.float64)

    def _report_error(self, error: str) -> None:
        self.failures += 1
        if self.health.mark_error(error):
            log.error("data source %s: %s", self.health.name, error)
            self.publish_status()

    def publish_status(self) -> None:
        """Send this source's status to every viewer now."""
        self.health.warning = self.connector.warning
        self.health.device = self.connector.device
        self.health.halted = self.connector.halted
        self._status_sent = time.monotonic()
        self._state_sent = self.health.current_state()
        self.tap.state(self._state_sent, self.health.status().error)
        message = Message(self.health.status_message())
        self._hub.publish(f"status:{self.health.name}", message)


def _burn(seconds: float) -> None:
    """Keep the CPU busy for ``seconds`` of its time (the test knob ``sample_cost_s``)."""
    # CPU time, not wall time: on a shared machine the knob costs the same work everywhere.
    end = time.thread_time() + seconds
    while time.thread_time() < end:
        pass
