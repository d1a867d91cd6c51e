"""Riding out a source's interruptions: when to reconnect, when to give up, what to log."""

from __future__ import annotations

import asyncio
import logging
import random
from dataclasses import dataclass

from ..lateness import Mark, lateness
from ..text import plural
from .client import DataLayerClient
from .problem import AuthError, BadAddress, DataLayerError, ProblemError, Unsupported

log = logging.getLogger(__name__)


@dataclass(frozen=True)
class RetryPolicy:
    """How to ride out interruptions: delays grow from ``first_s`` to ``max_s``, with jitter."""

    first_s: float = 0.05
    max_s: float = 1.0
    """Short, so a device that behaves again is streaming within 2 s."""
    give_up_s: float = 3.0
    """Raise to the caller (who shows the error) once a working source has failed this long."""

    def delay(self, attempt: int) -> float:
        """Seconds before reconnect ``attempt`` (0: at once, since most drops are one-offs)."""
        if attempt == 0:
            return 0.0
        # Jitter spreads the reconnects of many clients after a controller restart.
        return min(self.max_s, self.first_s * 2.0 ** (attempt - 1)) * random.uniform(0.5, 1.0)


DEFAULT_RETRY = RetryPolicy()


class Interruptions:
    """Decides, after a failure, whether to wait and reconnect or to give up."""

    def __init__(self, policy: RetryPolicy) -> None:
        self._policy = policy
        self._worked = False
        self._attempt = 0
        self._since: Mark | None = None
        """When this streak of failures began (its length counts our on-time loop only)."""

    def succeeded(self) -> None:
        self._worked, self._attempt, self._since = True, 0, None

    async def failed(self, exc: DataLayerError) -> None:
        """Sleep before the next attempt, or raise ``exc`` if it is no passing interruption."""
        self._since = lateness().mark() if self._since is None else self._since
        too_long = self._since.on_time_s() > self._policy.give_up_s
        if not (self._worked and transient(exc)) or too_long:
            raise exc
        delay = self._policy.delay(self._attempt)
        level = logging.INFO if self._attempt == 0 else logging.DEBUG  # news once per streak
        self._attempt += 1
        log.log(level, "data layer interrupted (%s); retrying in %.2f s", exc, delay)
        await asyncio.sleep(delay)


def transient(exc: DataLayerError) -> bool:
    """True for failures that may pass by themselves (network, timeouts, 5xx, closed streams)."""
    if isinstance(exc, AuthError | Unsupported | BadAddress):
        return False
    if isinstance(exc, ProblemError):
        return exc.status >= 500 or exc.status in (408, 429)
    return True


def samples_again(client: DataLayerClient) -> None:
    """A sample came: say so once if starts had failed before.

    A device that is down is tried again and again (by whoever restarts
    ``follow``); each attempt's own lines then go to DEBUG (``news_level``), the
    failed starts are counted on the client, and the first sample says how
    many attempts it took.
    """
    if client.failed_starts:
        failed = plural(client.failed_starts, "failed attempt")
        log.info("%s: samples again, after %s", client.base_url, failed)
        client.failed_starts = 0


def news_level(client: DataLayerClient) -> int:
    """INFO for a start after samples came, DEBUG while attempts keep failing."""
    return logging.DEBUG if client.failed_starts else logging.INFO
