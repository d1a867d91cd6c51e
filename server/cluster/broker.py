"""The Redis server the roles of a cluster share: its URL, the keys they use, and a connection.

Keys and channels (every name starts with ``linkview:``):

* ``lease:<source>``: the id of the worker that follows the source, expiring
  unless renewed (``lease``);
* ``workers``: a sorted set of live workers, scored by when each expires;
* ``frames``: the channel every worker publishes its batches to
  (``envelope``), holding each source's frames and status;
* ``health:<source>``: the newest status record of the source, so a replica
  that starts (or reconnects) knows it before the next one;
* ``cmd:<source>``: the channel the holder of a source reads moves from;
  ``reply:<replica>``: where it answers;
* ``wants:1``: present while a replica has protocol-1 viewers (JSON frames
  are encoded only then).
"""

from __future__ import annotations

import logging
import os
import re
import secrets
import socket
import time
from dataclasses import dataclass, field
from typing import TYPE_CHECKING

from redis.asyncio import Redis
from redis.backoff import NoBackoff
from redis.retry import Retry

if TYPE_CHECKING:
    from ..config import Settings

log = logging.getLogger(__name__)

PREFIX = "linkview:"
FRAMES = PREFIX + "frames"
WORKERS = PREFIX + "workers"
WANTS_JSON = PREFIX + "wants:1"
RETRY_MIN_S = 0.5
RETRY_MAX_S = 2.0
"""Waits between two attempts to reach an absent broker: doubling from the first to this."""


@dataclass(frozen=True)
class BrokerSettings:
    """Where the broker is, and how long a lease lasts (a dead worker's sources wait that long)."""

    url: str
    password: str | None = None
    lease_s: float = 1.2


def broker_settings(settings: Settings) -> BrokerSettings | None:
    """The broker of the settings; None without ``--broker`` (one process does everything)."""
    if settings.broker is None:
        return None
    password = settings.broker_password
    return BrokerSettings(
        settings.broker,
        None if password is None else password.get_secret_value(),
        settings.broker_lease_s,
    )


def member_id(role: str) -> str:
    """A name for one process (or one request) in the cluster: role, host, pid, random part."""
    return f"{role}-{socket.gethostname()}-{os.getpid()}-{secrets.token_hex(3)}"


def lease_key(source: str) -> str:
    """Holds the id of the worker following ``source``."""
    return f"{PREFIX}lease:{source}"


def health_key(source: str) -> str:
    """Holds the newest status record of ``source``."""
    return f"{PREFIX}health:{source}"


def command_channel(source: str) -> str:
    """The holder of ``source`` reads moves from this channel."""
    return f"{PREFIX}cmd:{source}"


def reply_channel(replica: str) -> str:
    """Where workers answer the moves ``replica`` sent."""
    return f"{PREFIX}reply:{replica}"


def connect(url: str, password: str | None, timeout_s: float) -> Redis:
    """A client of the broker; it connects on first use and never retries on its own.

    Callers retry on their own schedule (and report each failure), so a
    request to an absent server fails after ``timeout_s`` instead of after
    a hidden series of attempts.
    """
    return Redis.from_url(
        url,
        password=password,
        socket_timeout=timeout_s,
        socket_connect_timeout=timeout_s,
        retry=Retry(NoBackoff(), 0),
        health_check_interval=0,
    )


MEMBER = re.compile(r"[A-Za-z0-9._-]{1,200}")
"""What ``member_id`` makes: a channel name is built from it, health shows it."""


def member_of(value: bytes | str | None) -> str | None:
    """A member id read from Redis (a lease's holder), None if absent or not shaped like one."""
    if isinstance(value, bytes):
        value = value.decode("utf-8", "replace")
    return value if value is not None and MEMBER.fullmatch(value) else None


def describe(exc: BaseException) -> str:
    """One line for an error talking to the broker."""
    text = str(exc) or type(exc).__name__
    return text if text[0].isupper() else f"{type(exc).__name__}: {text}"


@dataclass
class BrokerState:
    """Whether the broker answers, as a role saw it last; logs each change once."""

    url: str
    role: str
    up: bool = False
    error: str | None = "not connected yet"
    since: float = field(default_factory=time.monotonic)

    def reached(self) -> bool:
        """The broker answered; True when that is news."""
        if self.up:
            return False
        log.info("%s: message broker %s reached", self.role, self.url)
        self.up, self.error, self.since = True, None, time.monotonic()
        return True

    def failed(self, exc: BaseException, retry_s: float) -> bool:
        """Talking to the broker failed; True when that is news."""
        error = f"message broker {self.url} unreachable: {describe(exc)}"
        news = self.up or self.error != error
        if news:
            log.error("%s: %s; retrying every %.1f s", self.role, error, retry_s)
        self.up, self.error = False, error
        if news:
            self.since = time.monotonic()
        return news

    def report(self) -> dict[str, object]:
        """For /api/health."""
        return {
            "url": self.url,
            "role": self.role,
            "state": "connected" if self.up else "error",
            "error": self.error,
            "for_s": round(time.monotonic() - self.since, 3),
        }
