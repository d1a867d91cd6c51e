"""A UR controller's RTDE interface as a linkview source (``type = "rtde"``).

The controller sends a data package every 2 ms (e-Series; 8 ms on CB3); the
frames go out at the source's period (20 ms). Packages are therefore kept
raw as they arrive, newest wins, and one is unpacked and delivered at most
once per period: as soon as it arrives if the period has passed, else when
it has. ``received`` counts the source periods a sample stands for (by the
controller's clock), not the packages: 500 Hz packages for a 50 Hz source are
the design, not an overload; a delivery two periods late stands for two. A drop is ridden
out by reconnecting at once, then with growing delays; only a controller
that stays away for ``give_up_s`` (or stops sending for ``stall_s``) becomes
a SourceError. The robot and safety modes are kept in ``device``.
"""

from __future__ import annotations

import asyncio
import logging
import time
from collections.abc import Callable
from dataclasses import dataclass

from ..lateness import Mark, lateness
from ..sources import Sample, SourceError, Throttle
from . import wire
from .link import Controller, LinkClosed, RtdeLink, handshake
from .recipe import recipe_fields

log = logging.getLogger(__name__)


@dataclass(frozen=True)
class RtdeSettings:
    """How to reach a controller and how patient to be with it."""

    host: str
    port: int = wire.PORT
    frequency_hz: float = wire.MAX_FREQUENCY_HZ
    """What the recipe asks for (a CB3 controller answers at its own 125 Hz at most)."""
    timeout_s: float = 5.0
    stall_s: float = 1.0
    """No data package for this long (on-time loop seconds): the stream is dead."""
    give_up_s: float = 1.5
    """Reconnecting after a drop for this long: report the controller as down."""

    @property
    def where(self) -> str:
        return f"rtde://{self.host}:{self.port}"


MAX_BATCH = 16
"""At most this many packages gathered per wake-up."""


class NotFound(SourceError):
    """A field the controller answered NOT_FOUND: it has no such output (e.g. that register)."""


def modes_text(controller: Controller | None, robot_mode: float, safety_mode: float) -> str:
    """``URControl 5.15.0: robot mode RUNNING, safety mode PROTECTIVE_STOP``."""
    robot = wire.ROBOT_MODES.get(int(robot_mode), f"{int(robot_mode)}")
    safety = wire.SAFETY_MODES.get(int(safety_mode), f"{int(safety_mode)}")
    head = "" if controller is None else f"{controller.version_text}: "
    return f"{head}robot mode {robot}, safety mode {safety}"


class RtdeConnector:
    """Follows nodes (``actual_q[2]``, ``output_double_register_24``) of one controller."""

    warning: str | None = None

    def __init__(self, settings: RtdeSettings) -> None:
        self.settings = settings
        self.device: str | None = None
        self.halted: str | None = None
        self.controller: Controller | None = None
        self._link: RtdeLink | None = None
        self._newest: bytes | None = None
        self.packages = 0
        """Data packages received in all (they outnumber the samples delivered)."""
        self._up = False
        """Whether the current connection got through its handshake."""

    async def follow(
        self, nodes: list[str], period_s: float, deliver: Callable[[Sample], None]
    ) -> None:
        """Deliver the newest values of ``nodes`` at most once per ``period_s``."""
        keys = {node: wire.parse_key(node) for node in nodes}
        fields = recipe_fields(keys.values())
        down: Mark | None = None
        attempt = 0
        while True:
            self._up = False
            try:
                await self._stream(fields, keys, period_s, deliver)
            except (OSError, LinkClosed, TimeoutError) as exc:
                why = str(exc) or type(exc).__name__
                if not why.startswith(self.settings.where):
                    why = f"{self.settings.where}: {why}"
                if self._up:  # it streamed: a new streak of drops
                    down = None
                if self.controller is None or (down and down.on_time_s() > self.settings.give_up_s):
                    raise SourceError(why) from None
                if down is None:
                    log.info("%s; reconnecting", why)
                    down, attempt = lateness().mark(), 0
                await asyncio.sleep(min(0.5, 0.05 * 2.0**attempt) if attempt else 0.0)
                attempt += 1
                continue
            except wire.WireError as exc:
                raise SourceError(f"{self.settings.where}: {exc}") from None
            finally:
                self._drop()

    async def _stream(
        self,
        fields: list[str],
        keys: dict[str, wire.Key],
        period_s: float,
        deliver: Callable[[Sample], None],
    ) -> None:
        """One connection: handshake, then samples until it closes or stalls."""
        loop = asyncio.get_running_loop()
        settings = self.settings
        async with asyncio.timeout(settings.timeout_s):
            _, link = await loop.create_connection(
                lambda: RtdeLink(settings.where), settings.host, settings.port
            )
            self._link = link
            link.on_data = self._on_data
            controller = await handshake(link, fields, settings.frequency_hz)
        self.controller, self._up = controller, True
        if controller.missing:
            log.warning(
                "%s: the controller has no output %s (NOT_FOUND)",
                settings.where,
                ", ".join(controller.missing),
            )
        log.info(
            "%s: %s streaming %d fields",
            settings.where,
            controller.version_text,
            len(controller.recipe.fields),
        )
        emit = _Emitter(controller, keys, period_s, deliver, self, link)
        self._emit = emit.offer
        watchdog = loop.create_task(self._watch(link))
        try:
            await asyncio.shield(link.closed)
        finally:
            watchdog.cancel()
            emit.cancel()
            self._emit = None

    _emit: Callable[[bytes], None] | None = None

    def _on_data(self, payload: bytes, count: int) -> None:
        self.packages += count
        if self._emit is not None:
            self._emit(payload)

    async def _watch(self, link: RtdeLink) -> None:
        """Close a link that stopped sending: a stalled controller looks like a live socket."""
        seen, since = self.packages, lateness().mark()
        while True:
            await asyncio.sleep(min(0.25, self.settings.stall_s / 4))
            if self.packages != seen:
                seen, since = self.packages, lateness().mark()
            elif since.on_time_s() > self.settings.stall_s:
                link.connection_lost(
                    TimeoutError(f"no data package for {self.settings.stall_s:g} s")
                )
                return

    def _drop(self) -> None:
        if self._link is not None:
            self._link.close()
            self._link = None

    async def move(self, command_node: str, values: list[float]) -> None:
        """Refused: linkview only reads RTDE (moving a UR takes a URScript program)."""
        raise SourceError(f"{self.settings.where}: moves are not supported over RTDE")

    async def close(self) -> None:
        """Close the connection, if any."""
        self._drop()


class _Emitter:
    """Delivers the newest package at most once per period (see the module doc)."""

    def __init__(
        self,
        controller: Controller,
        keys: dict[str, wire.Key],
        period_s: float,
        deliver: Callable[[Sample], None],
        connector: RtdeConnector,
        link: RtdeLink,
    ) -> None:
        recipe = controller.recipe
        self.link = link
        self.package_bytes = wire.HEADER.size + recipe.layout.size
        self.batch = 1
        """Packages the kernel gathers before it wakes us (see ``_pace``)."""
        self.seen = connector.packages
        self.recipe = recipe
        self.deliver = deliver
        self.connector = connector
        self.controller = controller
        self.found = {n: recipe.position(k) for n, k in keys.items() if k.field in recipe.offsets}
        self.lacking: dict[str, float | Exception] = {
            node: NotFound(
                f"{connector.settings.where}: the controller has no RTDE output {key.field} "
                "(answered NOT_FOUND)"
            )
            for node, key in keys.items()
            if key.field not in recipe.offsets
        }
        offsets = recipe.offsets
        self.at_time = offsets.get("timestamp")
        self.at_modes = offsets.get("robot_mode"), offsets.get("safety_mode")
        self.offset_s: float | None = None
        """Our clock minus the controller's (its timestamp counts from its boot): least seen."""
        self.modes: tuple[float, float] | None = None
        self.warned = False
        self.period_s = period_s
        self.newest: bytes | None = None
        self.stamp: float | None = None
        """The controller time of the last sample delivered."""
        self.throttle = Throttle(period_s, self.emit)

    def offer(self, payload: bytes) -> None:
        self.newest = payload
        self.throttle.offer()

    def emit(self) -> None:
        payload = self.newest
        if payload is None:
            return
        self.newest = None
        try:
            flat = self.recipe.unpack(payload)
        except wire.WireError as exc:
            if not self.warned:  # once per connection: every package would say the same
                self.warned = True
                log.warning("%s: %s", self.connector.settings.where, exc)
            return
        now = time.time()
        t_source, received = now, 1
        if self.at_time is not None:
            stamp = flat[self.at_time]
            if self.stamp is not None:
                received = max(1, round((stamp - self.stamp) / self.period_s))
                self._pace(stamp - self.stamp)
            self.stamp = stamp
            offset = now - stamp
            if self.offset_s is None or offset < self.offset_s:
                self.offset_s = offset  # the least delay seen is the closest to the true offset
            t_source = stamp + self.offset_s
        values: dict[str, float | Exception] = {n: float(flat[i]) for n, i in self.found.items()}
        if self.lacking:
            values.update(self.lacking)
        robot, safety = self.at_modes
        if robot is not None and safety is not None:
            modes = (flat[robot], flat[safety])
            if modes != self.modes:  # the text changes rarely: made only then
                self.modes = modes
                self.connector.device = modes_text(self.controller, *modes)
                self.connector.halted = wire.halt_text(int(modes[1]))
        self.deliver(Sample(t_source, values, received))

    def _pace(self, elapsed_s: float) -> None:
        """Be woken once 40 % of a period's packages are in, not by each one.

        At 500 packages a second, each read woken by one package costs the event loop a
        wake-up and a system call; the frames need the newest of each period. The rate is
        the one measured (by the controller's clock), so a controller that sends fewer
        packages is never waited for longer than that.
        """
        packages = self.connector.packages - self.seen
        self.seen = self.connector.packages
        if packages <= 0 or elapsed_s <= 0.0:
            return
        batch = max(1, min(MAX_BATCH, int(0.4 * self.period_s * packages / elapsed_s)))
        if batch != self.batch:
            self.batch = batch
            self.link.wake_after(batch * self.package_bytes)

    def cancel(self) -> None:
        self.throttle.cancel()
