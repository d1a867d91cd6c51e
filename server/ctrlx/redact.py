"""Keeping passwords and tokens out of every text a device can make us write."""

from __future__ import annotations

import re
from collections import deque
from typing import TypeVar

from .problem import ProblemError

E = TypeVar("E", bound=BaseException)

MASK = "***"
MIN_SECRET_LEN = 8
"""Shorter passwords are not masked (8 is NIST SP 800-63B's minimum for chosen passwords).

A short one is often a word the device itself uses: masking the password
"wrong" turns "wrong user name or password" into "*** user name or
password", which garbles the message and gives the password away as well.
"""
KEEP_TOKENS = 8
"""Tokens remembered for masking; a device may echo an older one in a later error."""

# A JWT starts with base64url('{"'), i.e. "eyJ"; a device may echo any token, ours or not.
_JWT = re.compile(r"eyJ[A-Za-z0-9_-]+(?:\.[A-Za-z0-9_-]*){0,2}")
_BEARER = re.compile(r"(?i)\b(bearer)\s+[^\s,;'\"]+")


class Redactor:
    """Knows one session's secrets and blanks them, and anything shaped like a JWT, out of text.

    Every message built from what a device answered (Problem fields, bodies,
    values, parser errors) passes through it before it can reach a log line,
    an exception text, /api/health or the page.
    """

    def __init__(self, *secrets: str) -> None:
        self._fixed = [s for s in secrets if len(s) >= MIN_SECRET_LEN]
        self._tokens: deque[str] = deque(maxlen=KEEP_TOKENS)

    def __repr__(self) -> str:
        return f"Redactor({len(self._fixed) + len(self._tokens)} secrets)"

    def add(self, secret: str) -> None:
        """Blank ``secret`` from now on (a token just received)."""
        if len(secret) >= MIN_SECRET_LEN and secret not in self._tokens:
            self._tokens.append(secret)

    def text(self, text: str) -> str:
        """``text`` with every known secret and every JWT-like or bearer string masked."""
        # Longest first, so a secret that contains another is masked whole.
        for secret in sorted((*self._fixed, *self._tokens), key=len, reverse=True):
            if secret in text:
                text = text.replace(secret, MASK)
        text = _JWT.sub(MASK, text)
        return _BEARER.sub(rf"\1 {MASK}", text)

    def error(self, exc: E) -> E:
        """``exc`` itself, its message (and Problem fields) masked in place."""
        exc.args = tuple(self.text(a) if isinstance(a, str) else a for a in exc.args)
        if isinstance(exc, ProblemError):
            exc.title = self.text(exc.title)
            exc.detail = None if exc.detail is None else self.text(exc.detail)
            exc.instance = None if exc.instance is None else self.text(exc.instance)
            exc.args = (exc.message(),)
        return exc
