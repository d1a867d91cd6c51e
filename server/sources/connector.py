"""The interface between a protocol client and the shared acquisition path."""

from __future__ import annotations

from collections.abc import Callable
from typing import Protocol

from .sample import Sample


class Closable(Protocol):
    """Something a source owns and must release when it stops (a client, an embedded mock)."""

    async def close(self) -> None: ...


class Connector(Closable, Protocol):
    """A protocol client as the acquisition uses it: one per source.

    ``warning``, ``device`` and ``halted`` are read whenever the source's status
    is published (at least once a second), so a connector just keeps them current.
    """

    @property
    def warning(self) -> str | None:
        """A standing caveat for health (plain http with credentials, unchecked TLS, a fallback)."""
        ...

    @property
    def device(self) -> str | None:
        """What the device says of itself (e.g. a robot or safety mode); None: nothing to say."""
        ...

    @property
    def halted(self) -> str | None:
        """Why the device holds its robots still (``protective stop``); None while it does not."""
        ...

    async def follow(
        self, nodes: list[str], period_s: float, deliver: Callable[[Sample], None]
    ) -> None:
        """Call ``deliver`` with the values of ``nodes`` about every ``period_s``, until cancelled.

        Short interruptions are ridden out inside (reconnecting with backoff);
        a source that is unusable raises SourceError, and the acquisition calls
        ``follow`` again after a short wait. Samples never queue: one that
        arrives before the last was delivered replaces it (``received`` counts
        both). ``deliver`` is synchronous and cheap, and is called on the event loop.
        """
        ...

    async def move(self, command_node: str, values: list[float]) -> None:
        """Command a synchronised move to ``values`` (node units).

        Raises SourceError where the protocol or the device cannot move the robot.
        """
        ...
