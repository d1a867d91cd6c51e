"""A ctrlX CORE's data layer as a source: ``follow_into`` to read, ``axsPos`` writes to move."""

from __future__ import annotations

from collections.abc import Callable

from ..sources import Sample
from .client import DataLayerClient
from .follow import Mode, follow_into


class CtrlxConnector:
    """Follows nodes of one data layer through ``client`` (see ``server.ctrlx.follow``)."""

    device: str | None = None
    halted: str | None = None

    def __init__(
        self, client: DataLayerClient, mode: Mode = "subscribe", keepalive_s: float = 1.0
    ) -> None:
        self.client = client
        self.mode: Mode = mode
        self.keepalive_s = keepalive_s

    @property
    def warning(self) -> str | None:
        """The client's standing caveat: credentials in clear, a refused faster path."""
        return self.client.warning

    async def follow(
        self, nodes: list[str], period_s: float, deliver: Callable[[Sample], None]
    ) -> None:
        """Deliver samples as the data layer streams (or is polled for) them."""
        await follow_into(
            self.client, nodes, period_s, deliver, self.mode, keepalive_s=self.keepalive_s
        )

    async def move(self, command_node: str, values: list[float]) -> None:
        """A synchronised move: ``{"axsPos": values}`` written to the group's command node."""
        await self.client.write(command_node, "object", {"axsPos": values})

    async def close(self) -> None:
        """Log out and close the HTTP session."""
        await self.client.close()
