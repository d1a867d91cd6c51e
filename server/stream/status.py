"""Health of a data source and its robots, for /api/health, the log and the page."""

from __future__ import annotations

import time
from dataclasses import dataclass, field

import numpy as np
import numpy.typing as npt
import orjson

from ..lateness import Mark, lateness
from ..protocol import SourceStatus
from ..text import plural

STALE_PERIODS = 5
STALE_MIN_S = 0.25
"""A source whose last sample is older than 5 periods, and at least this, is ``stale``.

The age counts only the time our event loop was on time (server.lateness): a
busy process that reads late makes its sources slower, not stale."""
LOAD_WINDOW_S = 2.0
"""Samples received and processed are compared over windows this long."""
OVERLOADED_BELOW = 0.9
"""Share of the device's samples made into frames under which the process is overloaded."""


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
    device: str | None = None
    """What the device says of itself (a robot or safety mode), as its connector reports it."""
    halted: str | None = None
    """Why the device holds its robots still (a protective stop), as its connector reports it."""
    last_sample: float | None = None
    """``time.monotonic()`` when the last sample arrived: the device's clock may differ."""
    robots: dict[str, RobotHealth] = field(default_factory=dict)
    received: int = 0
    """Samples the device sent (a late reader merges several into the newest one)."""
    processed: int = 0
    """Samples made into frames."""
    overloaded: str | None = None
    """"overloaded: N of M samples processed ..." while the last window says so, else None."""
    rate_hz: float | None = None
    """Samples made into frames per second (per robot) in the last window."""
    last_window: tuple[int, int] = (0, 0)
    """Samples received and processed in the last window."""
    _last_mark: Mark | None = None
    _window: tuple[float, int, int] | None = None
    """Start of the window: monotonic time, ``received`` and ``processed`` then."""

    @property
    def stale_after_s(self) -> float:
        """Sample age beyond which a connected source counts as stale."""
        return max(STALE_PERIODS * self.period_s, STALE_MIN_S)

    def age(self) -> float | None:
        """Seconds since the last sample (our clock), None before the first."""
        return None if self.last_sample is None else time.monotonic() - self.last_sample

    def _silent_s(self) -> float | None:
        """Seconds since the last sample during which our event loop was on time."""
        if self._last_mark is None:
            return self.age()
        return self._last_mark.on_time_s()

    def current_state(self) -> str:
        """The state as of now: ``connected`` turns ``stale`` when samples stop coming."""
        if self.state != "connected" or self.last_sample is None:
            return self.state
        # On-time silence is at most the time elapsed: counted only when that could be stale
        # (this runs for every sample).
        if time.monotonic() - self.last_sample > self.stale_after_s:
            silent = self._silent_s()
            if silent is not None and silent > self.stale_after_s:
                return "stale"
        return self.state

    @property
    def live(self) -> bool:
        """True while fresh samples arrive."""
        return self.current_state() == "connected"

    def mark_sample(self, received: int = 1) -> bool:
        """A sample arrived, standing for ``received`` of the device's (the newest of them)."""
        changed = self.current_state() != "connected"
        self._last_mark = lateness().mark()
        self.last_sample = self._last_mark.at
        self.state, self.error = "connected", None
        self.received += received
        self.processed += 1
        return changed

    def roll_window(self) -> bool:
        """Close the load window once it is LOAD_WINDOW_S old; True when ``overloaded`` changed."""
        now = time.monotonic()
        if self._window is None:
            self._window = (now, self.received, self.processed)
            return False
        start, received, processed = self._window
        if now - start < LOAD_WINDOW_S:
            return False
        self._window = (now, self.received, self.processed)
        received, processed = self.received - received, self.processed - processed
        self.rate_hz = processed / (now - start)
        self.last_window = (received, processed)
        was = self.overloaded
        if received and processed < OVERLOADED_BELOW * received:
            self.overloaded = overloaded_text(processed, received, f"{self.rate_hz:.0f}")
        else:
            self.overloaded = None
        return (was is None) != (self.overloaded is None)

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
            device=self.device,
            halted=self.halted,
            last_sample_age_s=age,
            overloaded=self.overloaded,
        )

    def status_message(self) -> str:
        """The ``status`` message for this source alone."""
        return orjson.dumps({"type": "status", "sources": [self.status().model_dump()]}).decode()


def overloaded_text(processed: int, received: int, rate: str) -> str:
    """The overload line, "overloaded: N of M samples processed, R frames/s per robot"."""
    return (
        f"overloaded: {processed} of {plural(received, 'sample')} processed, "
        f"{rate} frames/s per robot"
    )


def load_summary(sources: list[SourceHealth]) -> dict[str, object]:
    """Samples received and processed by every source, and in the last windows, for health.

    ``overloaded`` says "overloaded: N of M samples processed, R frames/s per robot (slowest
    S)" while any source's last window fell short, else None.
    """
    received = sum(s.last_window[0] for s in sources)
    processed = sum(s.last_window[1] for s in sources)
    rates = [s.rate_hz for s in sources if s.rate_hz is not None]
    text = None
    overloaded = [s for s in sources if s.overloaded]
    if overloaded and rates:
        rate = f"{float(np.median(rates)):.0f}"
        text = overloaded_text(processed, received, rate) + f" (slowest {min(rates):.0f})"
    elif overloaded:  # a replica: the workers count, and say so per source
        text = f"{overloaded[0].name}: {overloaded[0].overloaded}"
        text += f" (and {plural(len(overloaded) - 1, 'other source')})" * (len(overloaded) > 1)
    return {
        "overloaded": text,
        "received": sum(s.received for s in sources),
        "processed": sum(s.processed for s in sources),
        "window": {"received": received, "processed": processed},
        "rate_hz": {
            "min": min(rates, default=None),
            "median": float(np.median(rates)) if rates else None,
        },
    }
