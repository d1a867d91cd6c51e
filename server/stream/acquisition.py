"""One acquisition task per data source, shared by every viewer.

It reads the joint nodes of every robot on that source once per period,
turns each robot's sample into a frame, and publishes it to the hub. Viewer
count never changes the data-layer traffic.
"""

from __future__ import annotations

import asyncio
import contextlib
import logging
import time
from dataclasses import dataclass

import numpy as np

from ..cell import Robot
from ..ctrlx import DataLayerClient, DataLayerError, Mode, Sample, follow
from .frames import compute_frame
from .hub import Hub
from .status import SourceHealth
from .types import RobotSample

log = logging.getLogger(__name__)

STATUS_EVERY_S = 1.0
"""Status is also republished this often while healthy, so pages show a live sample age."""


@dataclass(frozen=True)
class PollSettings:
    """How often to read, and how long to wait after the source failed."""

    period_s: float = 0.02
    mode: Mode = "subscribe"
    """How samples are fetched: ``subscribe`` (falls back to ``poll``), ``poll`` or ``get``."""
    keepalive_s: float = 1.0
    retry_min_s: float = 0.5
    retry_max_s: float = 1.5
    """Kept short: a device that behaves again must be streaming within 2 s."""


class Acquisition:
    """Follows one data source and publishes frames for its robots."""

    def __init__(
        self,
        client: DataLayerClient,
        robots: list[Robot],
        hub: Hub,
        health: SourceHealth,
        settings: PollSettings = PollSettings(),
    ) -> None:
        self._client = client
        self._robots = robots
        self._hub = hub
        self.health = health
        self._settings = settings
        self._seq = 0
        self._nodes = sorted({node for robot in robots for node in robot.nodes})
        self._status_sent = 0.0

    async def run(self) -> None:
        """Follow the source forever; errors are reported and retried, never raised."""
        retry = self._settings.retry_min_s
        while True:
            try:
                samples = follow(
                    self._client,
                    self._nodes,
                    self._settings.period_s,
                    self._settings.mode,
                    keepalive_s=self._settings.keepalive_s,
                )
                async with contextlib.aclosing(samples):
                    async for sample in samples:
                        retry = self._settings.retry_min_s
                        self._on_sample(sample)
            except DataLayerError as exc:
                self._report_error(str(exc))
            except Exception as exc:  # a bug must not end the only stream of this source
                log.exception("data source %s: unexpected error", self.health.name)
                self._report_error(f"internal error: {exc!r}")
            await asyncio.sleep(retry)
            retry = min(retry * 2.0, self._settings.retry_max_s)

    def _on_sample(self, sample: Sample) -> None:
        self._seq += 1
        now = time.monotonic()
        if self.health.mark_sample() or now - self._status_sent >= STATUS_EVERY_S:
            self._publish_status()
        for robot in self._robots:
            self._publish_robot(robot, sample)

    def _publish_robot(self, robot: Robot, sample: Sample) -> None:
        read = [sample.values[n] for n in robot.nodes]
        errors = [str(v) for v in read if isinstance(v, Exception)]
        robot_sample = RobotSample(
            seq=self._seq,
            t_source=sample.t_source,
            values=None if errors else np.array(read, dtype=np.float64),
            error="; ".join(errors) if errors else None,
        )
        bug: Exception | None = None
        try:
            message, ok, error = compute_frame(robot, robot_sample)
        except Exception as exc:  # one robot's bug must not stop the others
            bug = exc
            failed = RobotSample(robot_sample.seq, robot_sample.t_source, None, repr(exc))
            message, ok, error = compute_frame(robot, failed)
        if self.health.mark_robot(robot.name, ok, error):  # log changes only, not every sample
            if ok:
                log.info("robot %s: streaming", robot.name)
            else:
                log.warning("robot %s: %s", robot.name, error, exc_info=bug)
        self._hub.publish(f"frame:{robot.name}", message.decode())

    def _report_error(self, error: str) -> None:
        if self.health.mark_error(error):
            log.error("data source %s: %s", self.health.name, error)
            self._publish_status()

    def _publish_status(self) -> None:
        self.health.warning = self._client.warning
        self._status_sent = time.monotonic()
        self._hub.publish(f"status:{self.health.name}", self.health.status_message())
