"""The running service: one source (connector, mock, acquisition) per source of the cell.

It also swaps in a reloaded cell, restarting only the sources it changes,
and moves robots on request where that is allowed.
"""

from __future__ import annotations

import asyncio
import logging
import secrets
from dataclasses import dataclass, field

import numpy as np
import numpy.typing as npt

from ..cell import Cell, Robot
from ..history import History
from ..sources import SourceError
from ..stream import PROTOCOL_VERSIONS, Hub, Message, SourceHealth, cell_message, hello_message
from .source import (
    RunningSource,
    SourceDefaults,
    fingerprint,
    may_command,
    mock_hold_s,
    start_source,
)

log = logging.getLogger(__name__)

__all__ = ["MoveError", "Runtime", "SourceDefaults", "may_command", "move_target"]


async def _stop_quietly(running: RunningSource, why: str) -> None:
    """Stop ``running``; a source that fails to stop is logged, and keeps nothing else from
    running (the new cell starts regardless)."""
    try:
        await running.stop()
    except Exception:
        log.exception("source %s: stopping it (%s) failed", running.config.name, why)


class MoveError(ValueError):
    """A move that cannot be commanded (not allowed, outside the limits, device refused)."""

    def __init__(self, status: int, reason: str) -> None:
        super().__init__(reason)
        self.status = status


def move_target(robot: Robot, q: list[float]) -> list[float]:
    """Joints ``q`` (rad or m, hello order) as ``robot``'s nodes take them; MoveError if unfit."""
    target = np.asarray(q, dtype=np.float64)
    if target.shape != (len(robot.joints),) or not np.isfinite(target).all():
        raise MoveError(422, f"{robot.name} needs {len(robot.joints)} finite joint values")
    outside = [
        j.name
        for j, value in zip(robot.joints, target, strict=True)
        if j.limits is not None and not j.limits[0] <= value <= j.limits[1]
    ]
    if outside:
        raise MoveError(422, f"outside the joint limits: {', '.join(outside)}")
    values: list[float] = robot.from_si(target).tolist()
    return values


@dataclass
class Runtime:
    """The hub every viewer reads, and the sources feeding it."""

    cell: Cell
    defaults: SourceDefaults = field(default_factory=SourceDefaults)
    hub: Hub = field(default_factory=Hub)
    sources: dict[str, RunningSource] = field(default_factory=dict)
    cell_error: str | None = None
    """Why the cell file on disk could not be loaded (the running cell stays)."""
    session: str = field(default_factory=lambda: secrets.token_hex(8))
    history: History = field(default_factory=lambda: History(SourceDefaults.history_s))
    """Every source's recent samples (the timeline, recordings, the Foxglove endpoint)."""
    _applying: asyncio.Lock = field(default_factory=asyncio.Lock, repr=False)

    @classmethod
    async def start(cls, cell: Cell, defaults: SourceDefaults | None = None) -> Runtime:
        """Start every source of ``cell``."""
        defaults = defaults or SourceDefaults()
        runtime = cls(cell, defaults, history=History(defaults.history_s))
        await runtime.apply(cell)
        return runtime

    async def apply(self, cell: Cell) -> None:
        """Run ``cell``: restart the sources it changes, keep the others, tell every viewer.

        One at a time: the file watcher and an edit from the page may both apply a cell,
        and two interleaved would each start a source of the same name.

        The changed sources are started before the old ones stop: if any fails
        to start (whatever it raises: a recording whose numbers overflow, a
        mock that cannot bind), the ones started are closed again, the running
        cell goes on untouched, and the error is raised for the caller to show.
        """
        async with self._applying:
            await self._apply(cell)

    async def _apply(self, cell: Cell) -> None:
        indices = {robot.name: i for i, robot in enumerate(cell.robots)}
        wanted = {s.name: s for s in cell.sources}
        kept: dict[str, RunningSource] = {}
        retired: list[tuple[RunningSource, str]] = []
        for name, running in self.sources.items():
            config = wanted.get(name)
            if config is not None and running.fingerprint == fingerprint(
                config, cell.robots_of(name)
            ):
                kept[name] = running
            else:
                retired.append((running, "changed" if config else "removed"))
        histories = dict(self.history.sources)
        started: list[RunningSource] = []
        try:
            for name, config in wanted.items():
                if name not in kept:
                    started.append(
                        await start_source(
                            config, cell.robots_of(name), self.hub, self.defaults, self.history
                        )
                    )
        except BaseException:
            self.history.sources = histories  # the running sources' histories, as they were
            for running in started:
                await _stop_quietly(running, "its cell could not start")
            raise
        for running, why in retired:
            log.info("source %s: stopping (%s)", running.config.name, why)
            await _stop_quietly(running, why)
        kept.update((running.config.name, running) for running in started)
        # From here on nothing awaits: viewers get the new hello before any new frame.
        for name, running in kept.items():
            running.robots = cell.robots_of(name)
            running.acquisition.set_robots(running.robots, indices)
        if self.sources:  # not the first start: a reload
            self.history.marks.add("reload", f"cell {self.cell_name or '(built in)'} reloaded")
        self.history.keep_only(wanted)
        self.sources = {s.name: kept[s.name] for s in cell.sources}
        self.cell, self.cell_error = cell, None
        self.hub.restart()
        self._publish_cell()
        for running in self.sources.values():
            running.acquisition.publish_status()
        for running in started:
            running.begin()

    def reject(self, error: str) -> None:
        """A new version of the cell file is unusable: keep running, say why."""
        self.cell_error = self.cell.shown(error)
        self.hub.publish("cell", Message(cell_message(self.cell_name, error)))

    async def stop(self) -> None:
        """Stop every source."""
        for running in self.sources.values():
            await running.stop()
        self.sources = {}

    @property
    def robots(self) -> tuple[Robot, ...]:
        """Every robot of the running cell, in hello order."""
        return self.cell.robots

    def robot(self, name: str) -> Robot | None:
        """The robot called ``name``, if any."""
        return next((r for r in self.cell.robots if r.name == name), None)

    def healths(self) -> list[SourceHealth]:
        """The health of every source, in cell order."""
        return [s.health for s in self.sources.values()]

    def newest_values(self) -> dict[str, npt.NDArray[np.float64]]:
        """The joint values (node units) of every robot whose newest sample had poses."""
        return {
            name: robot.values
            for health in self.healths()
            for name, robot in health.robots.items()
            if robot.ok and robot.values is not None
        }

    def commandable(self, robot: Robot) -> bool:
        """Whether moves may be sent for ``robot``: embedded mock, or allowed by flag or cell."""
        source = self.sources.get(robot.source)
        return source is not None and may_command(source.config, self.defaults.allow_commands)

    def hold_s(self, robot: Robot) -> float | None:
        """How long ``robot``'s embedded mock holds a commanded pose (None: no mock)."""
        source = next((s for s in self.cell.sources if s.name == robot.source), None)
        return None if source is None else mock_hold_s(source, self.defaults)

    async def move(self, robot: Robot, q: list[float]) -> None:
        """Command a synchronised move of ``robot`` to joints ``q`` (rad or m, hello order)."""
        if not self.commandable(robot):
            raise MoveError(
                403,
                f"{robot.name} is driven by a controller; start with --allow-commands to move it",
            )
        values = move_target(robot, q)
        connector = self.sources[robot.source].connector
        try:
            await connector.move(robot.command_node, values)
        except SourceError as exc:
            raise MoveError(502, f"the controller refused the move: {exc}") from exc
        log.info("robot %s: move to %s commanded", robot.name, np.round(values, 3).tolist())

    def report(self) -> dict[str, object]:
        """What this runtime adds to /api/health (a cluster replica: its message broker)."""
        return {}

    @property
    def cell_name(self) -> str | None:
        """The cell file as viewers see it: its name, in its own folder."""
        return None if self.cell.path is None else self.cell.path.name

    def _publish_cell(self) -> None:
        infos = self.cell.infos(self.commandable, self.hold_s)
        for protocol in PROTOCOL_VERSIONS:
            hello = hello_message(infos, self.session, protocol)
            self.hub.publish(f"hello:{protocol}", Message(hello), protocol=protocol)
        self.hub.publish("cell", Message(cell_message(self.cell_name, self.cell_error)))
