"""An OPC UA server as a source: one session, one subscription, samples of the cell's nodes.

``follow`` opens a session, resolves the node keys (their namespaces by URI,
browse paths, units), follows them (``server.opcua.follow``) and, when the
session is lost (the server restarted or stalled, the connection dropped,
``BadSessionIdInvalid``), raises SourceError naming why: the acquisition shows
it and follows again within a second, in a new session resolved afresh.

A move calls an OPC UA method: the robot's ``command_node`` names a Method
taking the joint positions (one Double array, node units), called on the object
that has it. The Robotics specification defines none, so this is a server's own.
"""

from __future__ import annotations

import dataclasses
import logging
from collections.abc import Awaitable, Callable, Mapping

from asyncua import ua
from asyncua.ua.uaerrors import UaStatusCodeError

from ..sources import Sample, SourceError
from .follow import Follower
from .resolve import UnitRule, resolve
from .session import OpcuaSettings, Session, describe_failure, open_session

log = logging.getLogger(__name__)


class OpcuaConnector:
    """Follows nodes of one OPC UA server (see the module's text)."""

    def __init__(
        self,
        settings: OpcuaSettings,
        units: Mapping[str, UnitRule] | None = None,
        commands: Mapping[str, str] | None = None,
        prepare: Callable[[], Awaitable[str]] | None = None,
    ) -> None:
        self.settings = settings
        self.prepare = prepare
        """Called before each session; gives the URL (an embedded mock: started on first call)."""
        self.units = dict(units or {})
        """The unit each node's values are delivered in (by node key); others: as read."""
        self.commands = dict(commands or {})
        """Command nodes standing for others (an embedded mock's methods for the defaults)."""
        self.device: str | None = None
        self.halted: str | None = None
        self._session: Session | None = None
        self._notes: list[str] = []
        self._follower: Follower | None = None

    @property
    def warning(self) -> str | None:
        """Caveats: a password sent in clear, reads instead of a subscription, units assumed."""
        parts = list(self._notes)
        if self._session is not None and self._session.warning:
            parts.insert(0, self._session.warning)
        if self._follower is not None and self._follower.warning:
            parts.insert(0, self._follower.warning)
        return "; ".join(parts) or None

    async def follow(
        self, nodes: list[str], period_s: float, deliver: Callable[[Sample], None]
    ) -> None:
        """Deliver samples of ``nodes`` until the session is lost (then raise SourceError)."""
        if self.prepare is not None:
            url = await self.prepare()
            self.settings = dataclasses.replace(self.settings, url=url)
        session = await open_session(self.settings)
        self._session = session
        try:
            try:
                resolved = await resolve(session.client, nodes, self.units)
            except UaStatusCodeError as exc:
                raise SourceError(
                    f"{self.settings.url}: {describe_failure(exc, self.settings)}"
                ) from None
            self._notes = resolved.notes
            for error in resolved.errors.values():
                log.warning("source %s: %s", self.settings.source, error)
            self._follower = Follower(session, nodes, resolved, period_s, deliver)
            try:
                await self._follower.run()
            except (UaStatusCodeError, ConnectionError, OSError, TimeoutError) as exc:
                why = session.lost.result() if session.lost.done() else None
                why = why or describe_failure(exc, self.settings)
                raise SourceError(f"{self.settings.url}: {why}") from None
        finally:
            await session.close()

    async def move(self, command_node: str, values: list[float]) -> None:
        """Call the method ``command_node`` names with ``values`` (one Double array)."""
        key = self.commands.get(command_node, command_node)
        hint = "give the robot a command_node naming the OPC UA method that moves it"
        session = self._session
        if session is None or session.lost.done():
            raise SourceError(f"{self.settings.url}: not connected")
        try:
            resolved = await resolve(session.client, [key], {})
            if key in resolved.errors:
                raise SourceError(f"{resolved.errors[key]}; {hint}")
            method = session.client.get_node(resolved.ids[key])
            parent = await method.get_parent()
            if parent is None:
                raise SourceError(f"{key}: the method has no object to call it on")
            await parent.call_method(method.nodeid, ua.Variant(list(values), ua.VariantType.Double))
        except (TimeoutError, UaStatusCodeError, ConnectionError) as exc:
            raise SourceError(f"{key}: {describe_failure(exc, self.settings)}") from None

    async def close(self) -> None:
        """Close the session, if one is open."""
        if self._session is not None:
            await self._session.close()
