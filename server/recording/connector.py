"""A recording being replayed, as the connector of its source: samples at their recorded pace."""

from __future__ import annotations

import contextlib
from collections.abc import AsyncGenerator, Callable

from ..sources import Sample, SourceError


class ReplayConnector:
    """Delivers what ``play()`` yields (see ``SourceReplay.play``); cannot be moved."""

    device: str | None = None
    halted: str | None = None

    def __init__(
        self, play: Callable[[], AsyncGenerator[Sample, None]], warning: str | None = None
    ) -> None:
        self._play = play
        self.warning = warning
        """What the replay leaves out of the file (``SourceReplay.warning``)."""

    async def follow(
        self, nodes: list[str], period_s: float, deliver: Callable[[Sample], None]
    ) -> None:
        """Deliver the recording's samples (the nodes were chosen when it was loaded)."""
        async with contextlib.aclosing(self._play()) as samples:
            async for sample in samples:
                deliver(sample)

    async def move(self, command_node: str, values: list[float]) -> None:
        """A recording plays what happened: it cannot be moved."""
        raise SourceError("a recording being replayed cannot be moved")

    async def close(self) -> None:
        """Nothing to release."""
