"""Health of a data source and its robots, for /api/health, the log and the page."""

from __future__ import annotations

import time
from dataclasses import dataclass, field

import orjson

from ..protocol import SourceStatus


@dataclass
class RobotHealth:
    """The newest frame's outcome for one robot."""

    ok: bool = False
    error: str | None = "no sample yet"
    frames: int = 0


@dataclass
class SourceHealth:
    """State of one data source; the ``mark_*`` methods return True when the state changed."""

    name: str
    url: str
    state: str = "connecting"
    error: str | None = None
    warning: str | None = None
    last_sample: float | None = None
    """``time.monotonic()`` when the last sample arrived: the device's clock may differ."""
    robots: dict[str, RobotHealth] = field(default_factory=dict)

    def mark_sample(self) -> bool:
        """A sample arrived."""
        self.last_sample = time.monotonic()
        changed = self.state != "connected"
        self.state, self.error = "connected", None
        return changed

    def mark_error(self, error: str) -> bool:
        """The source failed as a whole."""
        changed = (self.state, self.error) != ("error", error)
        self.state, self.error = "error", error
        return changed

    def mark_robot(self, robot: str, ok: bool, error: str | None) -> bool:
        """A robot's frame was computed."""
        health = self.robots.setdefault(robot, RobotHealth())
        changed = (health.ok, health.error) != (ok, error)
        health.ok, health.error = ok, error
        health.frames += 1
        return changed

    def status(self) -> SourceStatus:
        """As sent to viewers."""
        age = None if self.last_sample is None else time.monotonic() - self.last_sample
        return SourceStatus(
            name=self.name,
            url=self.url,
            state=self.state,  # type: ignore[arg-type]
            error=self.error,
            warning=self.warning,
            last_sample_age_s=age,
        )

    def status_message(self) -> str:
        """The ``status`` message for this source alone."""
        return orjson.dumps({"type": "status", "sources": [self.status().model_dump()]}).decode()
