"""Health of a data source and its robots, for /api/health, the log and the page."""

from __future__ import annotations

import time
from dataclasses import dataclass, field

import numpy as np
import numpy.typing as npt
import orjson

from ..protocol import SourceStatus

STALE_PERIODS = 5
STALE_MIN_S = 0.25
"""A source whose last sample is older than 5 periods, and at least this, is ``stale``."""


@dataclass
class RobotHealth:
    """The newest frame's outcome for one robot."""

    ok: bool = False
    error: str | None = "no sample yet"
    frames: int = 0
    values: npt.NDArray[np.float64] | None = None
    """The joint nodes' values as last read (node units, joint order), for checking the mapping."""


@dataclass
class SourceHealth:
    """State of one data source; the ``mark_*`` methods return True when the state changed."""

    name: str
    url: str
    mock: bool = False
    period_s: float = 0.02
    state: str = "connecting"
    """As last marked: ``connecting``, ``connected`` or ``error`` (``stale`` is derived)."""
    error: str | None = None
    warning: str | None = None
    last_sample: float | None = None
    """``time.monotonic()`` when the last sample arrived: the device's clock may differ."""
    robots: dict[str, RobotHealth] = field(default_factory=dict)

    @property
    def stale_after_s(self) -> float:
        """Sample age beyond which a connected source counts as stale."""
        return max(STALE_PERIODS * self.period_s, STALE_MIN_S)

    def age(self) -> float | None:
        """Seconds since the last sample (our clock), None before the first."""
        return None if self.last_sample is None else time.monotonic() - self.last_sample

    def current_state(self) -> str:
        """The state as of now: ``connected`` turns ``stale`` when samples stop coming."""
        age = self.age()
        if self.state == "connected" and age is not None and age > self.stale_after_s:
            return "stale"
        return self.state

    @property
    def live(self) -> bool:
        """True while fresh samples arrive."""
        return self.current_state() == "connected"

    def mark_sample(self) -> bool:
        """A sample arrived."""
        changed = self.current_state() != "connected"
        self.last_sample = time.monotonic()
        self.state, self.error = "connected", None
        return changed

    def mark_error(self, error: str) -> bool:
        """The source failed as a whole."""
        changed = (self.state, self.error) != ("error", error)
        self.state, self.error = "error", error
        return changed

    def mark_robot(
        self,
        robot: str,
        ok: bool,
        error: str | None,
        values: npt.NDArray[np.float64] | None = None,
    ) -> bool:
        """A robot's frame was computed (from node ``values``, where they could be read)."""
        health = self.robots.setdefault(robot, RobotHealth())
        changed = (health.ok, health.error) != (ok, error)
        health.ok, health.error = ok, error
        if values is not None:
            health.values = values
        health.frames += 1
        return changed

    def status(self) -> SourceStatus:
        """As sent to viewers."""
        state = self.current_state()
        error = self.error
        age = self.age()
        if state == "stale":
            error = f"no sample for {age:.2f} s (expected every {self.period_s:g} s)"
        return SourceStatus(
            name=self.name,
            url=self.url,
            mock=self.mock,
            state=state,  # type: ignore[arg-type]
            error=error,
            warning=self.warning,
            last_sample_age_s=age,
        )

    def status_message(self) -> str:
        """The ``status`` message for this source alone."""
        return orjson.dumps({"type": "status", "sources": [self.status().model_dump()]}).decode()
