"""Bearer tokens from the ctrlX identity manager: which paths, how long they live, when to renew.

A token's ``iat`` and ``exp`` are stamped by the device's clock, which may be
hours off ours. So only their difference, the lifetime the device means, is
trusted, and it is measured on our monotonic clock from the moment the token
arrived. Comparing ``exp`` with our wall clock instead once made a controller
whose clock was behind ours drive us to 750 logins a second.
"""

from __future__ import annotations

import asyncio
import logging
import math
import time
from collections.abc import Awaitable, Callable
from dataclasses import dataclass, field
from typing import Literal

import jwt

log = logging.getLogger(__name__)

ApiVersion = Literal["v2", "v1"]


@dataclass(frozen=True)
class ApiPaths:
    """Where the identity manager and the data layer answer, for one firmware generation."""

    token: str
    nodes: str
    """Prefix of node reads; the encoded node path follows it."""
    bulk: str | None
    events: str | None
    """None where the firmware has no such service (the client then falls back)."""


API_PATHS: dict[ApiVersion, ApiPaths] = {
    "v2": ApiPaths(
        token="/identity-manager/api/v2/auth/token",
        nodes="/automation/api/v2/nodes/",
        bulk="/automation/api/v2/bulk",
        events="/automation/api/v2/events",
    ),
    # Firmware 1.x: token at v1.0, nodes straight under /automation/api/v1/.
    "v1": ApiPaths(
        token="/identity-manager/api/v1.0/auth/token",
        nodes="/automation/api/v1/",
        bulk=None,
        events=None,
    ),
}


RENEW_MARGIN_S = 60.0
RENEW_SHARE = 0.2
MIN_RENEW_AFTER_S = 0.5
"""No renewal is planned sooner after a login: 10 ms tokens give 2 logins a second, not 100."""


@dataclass(frozen=True)
class Token:
    """A bearer token, its (unverified) JWT claims and when it reached us."""

    value: str = field(repr=False)
    issued_at: float | None
    """``iat``, unix seconds on the device's clock; None if not stated."""
    expires_at: float | None
    """``exp``, unix seconds on the device's clock; None if not stated."""
    received_wall: float
    """Our ``time.time()`` when the token arrived."""
    received_mono: float
    """Our ``time.monotonic()`` when the token arrived: renewal is planned from here."""

    @classmethod
    def from_jwt(cls, raw: str, wall: float, mono: float) -> Token:
        """Read ``iat`` and ``exp`` without checking the signature: only the device can."""
        try:
            claims = jwt.decode(raw, options={"verify_signature": False})
        except jwt.InvalidTokenError:
            claims = {}  # an opaque token still works; we just cannot plan its renewal
        return cls(raw, _number(claims.get("iat")), _number(claims.get("exp")), wall, mono)

    @property
    def lifetime_s(self) -> float | None:
        """``exp - iat``, how long the device means the token to live; None if unknown or <= 0.

        Without ``iat`` our arrival time stands in for it (the best guess left).
        """
        if self.expires_at is None:
            return None
        start = self.issued_at if self.issued_at is not None else self.received_wall
        lifetime = self.expires_at - start
        return lifetime if lifetime > 0.0 else None

    def renew_at(
        self,
        margin_s: float = RENEW_MARGIN_S,
        share: float = RENEW_SHARE,
        min_after_s: float = MIN_RENEW_AFTER_S,
    ) -> float | None:
        """Our monotonic time to log in again; None: only once the device rejects the token.

        ``share`` of the lifetime before it ends, at most ``margin_s``: a 2 s
        token is renewed 0.4 s early, a one-hour token a minute early.
        """
        lifetime = self.lifetime_s
        if lifetime is None:
            return None
        return self.received_mono + max(lifetime - min(margin_s, share * lifetime), min_after_s)

    def clock_warning(self) -> str | None:
        """Why this token's times look wrong from here, for people; None if they look fine."""
        exp, iat = self.expires_at, self.issued_at
        if exp is None:
            return None
        if iat is not None and exp <= iat:
            return (
                "clock skew: the controller's tokens expire before they are issued (exp <= iat); "
                "they are renewed only when it rejects one; check its time settings (NTP)"
            )
        if exp <= self.received_wall:
            behind = (
                f"about {_duration(self.received_wall - iat)} "
                if iat is not None and iat < self.received_wall
                else ""
            )
            return (
                f"clock skew: the controller's clock is {behind}behind ours (its tokens arrive "
                "already expired); renewal follows the token's lifetime on our clock, but check "
                "the controller's time (NTP)"
            )
        return None


@dataclass(frozen=True)
class LoginBackoff:
    """Least time between two logins while they fail or their tokens are rejected.

    The first failure allows one login a second, later ones a little less,
    capped at ``max_s`` so that a device that behaves again (and the
    acquisition, which retries within 1.5 s) is streaming within 2 s.
    """

    first_s: float = 1.0
    factor: float = 1.25
    max_s: float = 1.5

    def gap(self, failures: int) -> float:
        """Seconds that must separate the next login from the previous one."""
        if failures <= 0:
            return 0.0
        return min(self.max_s, self.first_s * self.factor ** (failures - 1))


class TokenManager:
    """Holds the current token; logs in lazily, before it runs out, and after a rejection.

    ``fetch`` performs the actual login request and returns the raw token.
    Logins after failures are spaced by ``backoff``; ``warning`` says, once,
    when the device's token times do not fit our clock.
    """

    def __init__(
        self,
        fetch: Callable[[], Awaitable[str]],
        *,
        wall: Callable[[], float] = time.time,
        mono: Callable[[], float] = time.monotonic,
        sleep: Callable[[float], Awaitable[None]] = asyncio.sleep,
        backoff: LoginBackoff = LoginBackoff(),
    ) -> None:
        self._fetch = fetch
        self._wall = wall
        self._mono = mono
        self._sleep = sleep
        self._backoff = backoff
        self._token: Token | None = None
        self._lock = asyncio.Lock()
        self._failures = 0
        self._last_login: float | None = None
        self._attempts = 0
        """Login attempts finished so far."""
        self._last_error: Exception | None = None
        self.logins = 0
        """Successful logins so far."""
        self.warning: str | None = None
        """A standing caveat about the device's token times (clock skew), never secret."""

    def __repr__(self) -> str:
        state = "none" if self._token is None else f"lifetime_s={self._token.lifetime_s}"
        return f"TokenManager({state}, logins={self.logins}, failures={self._failures})"

    @property
    def token(self) -> Token | None:
        """The token held now, if any (not renewed)."""
        return self._token

    @property
    def renew_at(self) -> float | None:
        """Monotonic time the current token is due for renewal (None: no token or no lifetime)."""
        return None if self._token is None else self._token.renew_at()

    def seconds_to_renewal(self) -> float | None:
        """Seconds until the planned renewal (<= 0: due now); None if none is planned."""
        renew_at = self.renew_at
        return None if renew_at is None else renew_at - self._mono()

    def due(self) -> bool:
        """True when there is no token or it should be renewed now."""
        wait = self.seconds_to_renewal()
        return self._token is None or (wait is not None and wait <= 0.0)

    async def current(self) -> str:
        """A token that is not about to run out, logging in if needed."""
        if not self.due():
            assert self._token is not None
            return self._token.value
        return await self.renew(stale=self._token.value if self._token else None)

    async def renew(self, stale: str | None, *, rejected: bool = False) -> str:
        """Log in again unless another task already replaced ``stale``.

        ``rejected``: the device refused ``stale`` (401), which counts as a
        failure for the spacing of logins.
        """
        attempts = self._attempts
        async with self._lock:
            # Many readers may see the same 401 or the same expiry; only the first logs in.
            if self._token is not None and self._token.value != stale:
                return self._token.value
            if self._attempts != attempts and self._last_error is not None:
                raise self._last_error  # a login failed while we queued: do not repeat it now
            if rejected and self._token is not None:
                self._failures += 1
            await self._spaced()
            return await self._login()

    def accepted(self) -> None:
        """The device took the current token: logins need no spacing any more."""
        self._failures = 0

    def forget(self) -> str | None:
        """Drop the token (on logout); returns it so it can be revoked."""
        token, self._token = self._token, None
        return None if token is None else token.value

    async def _spaced(self) -> None:
        if self._last_login is None:
            return
        wait = self._last_login + self._backoff.gap(self._failures) - self._mono()
        if wait > 0.0:
            log.debug("next login in %.2f s (after %d failures)", wait, self._failures)
            await self._sleep(wait)

    async def _login(self) -> str:
        self._last_login = self._mono()
        try:
            raw = await self._fetch()
        except Exception as exc:
            self._failures += 1
            self._last_error = exc
            raise
        finally:
            self._attempts += 1  # counted when done: who queued meanwhile shares the outcome
        self._last_error = None
        token = Token.from_jwt(raw, self._wall(), self._mono())
        self._token = token
        self.logins += 1
        self._set_warning(token.clock_warning())
        return token.value

    def _set_warning(self, warning: str | None) -> None:
        if warning == self.warning:
            return  # reported once, not at every login
        if warning is not None:
            log.warning("%s", warning)
        else:
            log.info("the controller's token times fit our clock again")
        self.warning = warning


def _number(raw: object) -> float | None:
    if isinstance(raw, bool) or not isinstance(raw, int | float) or not math.isfinite(raw):
        return None
    return float(raw)


def _duration(seconds: float) -> str:
    if seconds >= 3600:
        return f"{seconds / 3600:.1f} h"
    if seconds >= 120:
        return f"{seconds / 60:.0f} min"
    return f"{seconds:.0f} s"
