"""Logging set-up shared by the command-line entry points."""

from __future__ import annotations

import logging
import time

from .text import printable

FORMAT = "%(asctime)s %(levelname)s %(name)s: %(message)s"


class PlainFormatter(logging.Formatter):
    """Each line of a record with its control characters escaped (``server.text.printable``).

    Log messages quote what devices and files say (a Problem's detail, a node
    name); an ANSI escape there must not reach the terminal reading the log.
    Lines stay lines: a traceback or a list of cell mistakes reads as before.
    """

    def format(self, record: logging.LogRecord) -> str:
        return "\n".join(map(printable, super().format(record).split("\n")))


def setup_logging(level: int = logging.INFO) -> None:
    """Log to stderr with timestamps; passwords and tokens are never passed to loggers."""
    handler = logging.StreamHandler()
    handler.setFormatter(PlainFormatter(FORMAT))
    logging.basicConfig(level=level, handlers=[handler])


class Throttled:
    """Counts refusals by kind and logs them at most once per ``every_s``, with the count.

    What arrives from outside (a forged Redis record, a flood of commands, a
    hostile recording) may go wrong thousands of times a second: each is
    counted, and the log gets one line per interval naming the newest and how
    many there were since the last line, never a line per refusal.
    """

    def __init__(self, logger: logging.Logger, what: str, every_s: float = 60.0) -> None:
        self.logger = logger
        self.what = what
        self.every_s = every_s
        self.counts: dict[str, int] = {}
        """Refusals so far, by kind (for health and metrics)."""
        self.newest: str | None = None
        """The newest refusal's reason."""
        self._logged_at: float | None = None
        self._since_log = 0

    @property
    def total(self) -> int:
        """Refusals of every kind so far."""
        return sum(self.counts.values())

    def refuse(self, kind: str, reason: str) -> None:
        """Count one refusal of ``kind``; log it unless a line was logged within ``every_s``."""
        self.counts[kind] = self.counts.get(kind, 0) + 1
        self.newest = reason
        self._since_log += 1
        now = time.monotonic()
        if self._logged_at is not None and now - self._logged_at < self.every_s:
            return
        more = f" ({self._since_log} refused since the last such line)" * (self._since_log > 1)
        self.logger.warning("%s: refused %s%s", self.what, reason, more)
        self._logged_at, self._since_log = now, 0

    def report(self) -> dict[str, object]:
        """For /api/health: how many were refused, by kind, and the newest reason."""
        return {"refused": dict(self.counts), "newest": self.newest}
