"""What one viewer connection may cost: the messages it sends, the bytes queued for it.

A viewer only reads; the page sends nothing but the pongs to our keep-alive
pings. A client that sends pings without reading the pongs, or floods
messages, would otherwise grow the server's write buffer without bound and
take the event loop from every other viewer. Past either bound it is closed
with 1008 (policy violation) and its buffer dropped (see ``wire``).
"""

from __future__ import annotations

import time
from collections import Counter

MESSAGES_PER_S = 20.0
"""Sustained messages a viewer may send (pings, pongs, text, binary)."""
MESSAGE_BURST = 100
"""Messages a viewer may send at once before the rate applies."""
MAX_QUEUED_BYTES = 4 << 20
"""Bytes waiting in a viewer's write buffer. Frames are only written while it is below
64 KiB (``wire``), so only what the server must answer (pongs) can pile up past it."""

closed: Counter[str] = Counter()
"""Viewers closed for breaking a bound, by bound (``messages``, ``queued``); read by /metrics."""


class MessageBudget:
    """A token bucket: ``spend`` is False once the viewer sends faster than allowed."""

    __slots__ = ("_at", "_tokens")

    def __init__(self) -> None:
        self._tokens = float(MESSAGE_BURST)
        self._at = time.monotonic()

    def spend(self) -> bool:
        """Take one message from the budget; False if there is none left."""
        now = time.monotonic()
        self._tokens = min(float(MESSAGE_BURST), self._tokens + (now - self._at) * MESSAGES_PER_S)
        self._at = now
        if self._tokens < 1.0:
            return False
        self._tokens -= 1.0
        return True
