"""Bearer tokens from the ctrlX identity manager: which paths, when they expire, when to renew."""

from __future__ import annotations

import asyncio
import time
from collections.abc import Awaitable, Callable
from dataclasses import dataclass, field
from typing import Literal

import jwt

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
    # The seed's relay (firmware 1.x): token at v1.0, nodes straight under /automation/api/v1/.
    "v1": ApiPaths(
        token="/identity-manager/api/v1.0/auth/token",
        nodes="/automation/api/v1/",
        bulk=None,
        events=None,
    ),
}


@dataclass(frozen=True)
class Token:
    """A bearer token and the times read from its (unverified) JWT claims, unix seconds."""

    value: str = field(repr=False)
    issued_at: float
    expires_at: float | None
    """None when the token states no ``exp`` (it is then renewed only after a 401)."""

    @classmethod
    def from_jwt(cls, raw: str, now: float) -> Token:
        """Read ``iat`` and ``exp`` without checking the signature: only the device can."""
        try:
            claims = jwt.decode(raw, options={"verify_signature": False})
        except jwt.InvalidTokenError:
            claims = {}  # an opaque token still works; we just cannot plan its renewal
        iat, exp = claims.get("iat"), claims.get("exp")
        issued = float(iat) if isinstance(iat, int | float) else now
        expires = float(exp) if isinstance(exp, int | float) else None
        return cls(raw, issued, expires)

    def renew_at(self, margin_s: float = 60.0, share: float = 0.2) -> float | None:
        """When to log in again: ``share`` of the lifetime before expiry, at most ``margin_s``.

        A 2 s test token is renewed 0.4 s early; a one-hour token a minute early.
        """
        if self.expires_at is None:
            return None
        lifetime = max(self.expires_at - self.issued_at, 0.0)
        return self.expires_at - min(margin_s, share * lifetime)


class TokenManager:
    """Holds the current token; logs in lazily, before expiry, and once after a 401.

    ``fetch`` performs the actual login request and returns the raw token.
    """

    def __init__(
        self, fetch: Callable[[], Awaitable[str]], clock: Callable[[], float] = time.time
    ) -> None:
        self._fetch = fetch
        self._clock = clock
        self._token: Token | None = None
        self._lock = asyncio.Lock()
        self.logins = 0

    def __repr__(self) -> str:
        state = "none" if self._token is None else f"expires_at={self._token.expires_at}"
        return f"TokenManager({state})"

    @property
    def token(self) -> Token | None:
        """The token held now, if any (not renewed)."""
        return self._token

    @property
    def renew_at(self) -> float | None:
        """Unix time the current token is due for renewal (None: no token or no expiry)."""
        return None if self._token is None else self._token.renew_at()

    def due(self) -> bool:
        """True when there is no token or it should be renewed now."""
        renew_at = self.renew_at
        return self._token is None or (renew_at is not None and self._clock() >= renew_at)

    async def current(self) -> str:
        """A token that is not about to expire, logging in if needed."""
        if not self.due():
            assert self._token is not None
            return self._token.value
        return await self.renew(stale=self._token.value if self._token else None)

    async def renew(self, stale: str | None) -> str:
        """Log in again unless another task already replaced ``stale``."""
        async with self._lock:
            # Many readers may see the same 401 or the same expiry; only the first logs in.
            if self._token is None or self._token.value == stale:
                raw = await self._fetch()
                self._token = Token.from_jwt(raw, self._clock())
                self.logins += 1
            return self._token.value

    def forget(self) -> str | None:
        """Drop the token (on logout); returns it so it can be revoked."""
        token, self._token = self._token, None
        return None if token is None else token.value
