"""Token issuing and checking for the mock identity manager (HS256 JWTs)."""

from __future__ import annotations

import secrets
import time
from collections.abc import Callable
from dataclasses import dataclass, field

import jwt

SCOPES = ["rexroth-device.all.rwx"]
MAX_REMEMBERED = 10_000


@dataclass
class TokenIssuer:
    """Issues JWTs with ``iat``, ``exp`` and ``scope`` that really expire, and can revoke them."""

    users: dict[str, str] = field(repr=False)
    lifetime_s: float = 3600.0
    clock: Callable[[], float] = time.time
    _key: bytes = field(default_factory=lambda: secrets.token_bytes(32), repr=False)
    _revoked: set[str] = field(default_factory=set, repr=False)
    _sessions: dict[str, str] = field(default_factory=dict, repr=False)
    _expiry: dict[str, float] = field(default_factory=dict, repr=False)
    """The ``exp`` of each token whose signature checked out under ``_key``: a stream checks
    its token every publish cycle, and decoding a JWT each time was an eighth of a mock's CPU."""
    issued: int = 0

    def issue(self, user: str, password: str) -> str | None:
        """A new token, or None when the credentials are wrong."""
        if not secrets.compare_digest(self.users.get(user, "\0"), password):
            return None
        now = self.clock()
        claims = {
            "sub": user,
            "name": user,
            "iat": now,
            "exp": now + self.lifetime_s,
            "scope": SCOPES,
            "jti": secrets.token_hex(8),
        }
        self.issued += 1
        return jwt.encode(claims, self._key, algorithm="HS256")

    def check(self, token: str) -> str | None:
        """None if the token is valid, else the reason it is not."""
        if token in self._revoked:
            return "the token was revoked"
        exp = self._expiry.get(token)
        if exp is None:
            try:
                claims = jwt.decode(
                    token, self._key, algorithms=["HS256"], options={"verify_exp": False}
                )
            except jwt.InvalidTokenError:
                return "the token is not valid"
            exp = self._remember(token, float(claims.get("exp", 0.0)))
        # Checked against our clock (not PyJWT's) so tests may run the mock on a fake clock.
        if exp <= self.clock():
            return "the token has expired"
        return None

    def _remember(self, token: str, exp: float) -> float:
        if len(self._expiry) >= MAX_REMEMBERED:  # only tokens we signed, but a long run issues many
            now = self.clock()
            self._expiry = {t: e for t, e in self._expiry.items() if e > now}
        self._expiry[token] = exp
        return exp

    def revoke(self, token: str) -> None:
        """Make ``token`` invalid from now on (DELETE /auth/token), and end its sessions."""
        self._revoked.add(token)
        self._sessions = {s: t for s, t in self._sessions.items() if t != token}

    def revoke_all(self) -> None:
        """Invalidate every token issued so far (tests use it to force a re-login)."""
        self._key = secrets.token_bytes(32)
        self._expiry.clear()
        self._revoked.clear()
        self._sessions.clear()

    def open_session(self, token: str) -> str:
        """A new session id for ``token`` (the ``CTRLX-OS-SESSION-ID`` cookie of a login)."""
        session = secrets.token_urlsafe(24)
        self._sessions[session] = token
        return session

    def session_token(self, session: str) -> str | None:
        """The still valid token of ``session``, if there is one."""
        token = self._sessions.get(session)
        if token is None or self.check(token) is not None:
            self._sessions.pop(session, None)
            return None
        return token
