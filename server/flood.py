"""What one viewer connection may cost: the messages it sends, the bytes queued for it.

A viewer only reads; the page sends nothing but the pongs to our keep-alive
pings. A client that sends pings without reading the pongs, or floods
messages, would otherwise grow the server's write buffer without bound and
take the event loop from every other viewer. Past either bound it is closed
with 1008 (policy violation) and its buffer dropped. The same bounds hold on
``/ws`` (``web.wire``) and on the Foxglove endpoint (``foxglove.guard``).
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

SEND_TIMEOUT_S = 10.0
"""A viewer that cannot take one message (or batch) in this time is disconnected."""

closed: Counter[str] = Counter()
"""Viewers closed for breaking a bound, by bound (``messages``, ``queued``); read by /metrics."""


class MessageBudget:
    """A token bucket: ``spend`` is False once the viewer sends faster than allowed.

    ``rate`` per second sustained, ``burst`` at once (a viewer's messages by
    default; a cluster worker's moves per source take their own).
    """

    __slots__ = ("_at", "_burst", "_rate", "_tokens")

    def __init__(self, rate: float = MESSAGES_PER_S, burst: int = MESSAGE_BURST) -> None:
        self._rate, self._burst = rate, float(burst)
        self._tokens = self._burst
        self._at = time.monotonic()

    def spend(self) -> bool:
        """Take one message from the budget; False if there is none left."""
        now = time.monotonic()
        self._tokens = min(self._burst, self._tokens + (now - self._at) * self._rate)
        self._at = now
        if self._tokens < 1.0:
            return False
        self._tokens -= 1.0
        return True
