"""``python -m server acquire``: an acquisition worker of a cluster.

A worker runs the sources of the cell it holds leases for, exactly as one
process does (``Runtime``, ``Acquisition``), but with a hub that publishes
to Redis. It follows the cell file like the web server, and executes the
moves replicas route to it for the sources it holds.

When it cannot renew its leases for a lease time (Redis gone), it stops
every source: another worker may be following them by then, and no source
is followed by two workers. The leases have a Redis connection of their own,
so nothing else the worker does with Redis (publishing frames, answering a
flood of moves) can keep them from being renewed; moves are bounded per
source (``commands``), and every task is ``supervised``.
"""

from __future__ import annotations

import asyncio
import contextlib
import dataclasses
import logging
import signal
import time
from collections.abc import Callable
from pathlib import Path

from redis.asyncio import Redis
from redis.exceptions import RedisError

from ..cell import Cell
from ..history import History
from ..logs import Throttled
from ..loop_pacing import loop_pacer
from ..runtime import MoveError, Runtime, SourceDefaults
from ..runtime.reload import follow_cell_file
from .broker import (
    RETRY_MAX_S,
    BrokerSettings,
    BrokerState,
    command_channel,
    connect,
    member_id,
)
from .commands import Commands, MoveCommand
from .inbound import MAX_TEXT
from .lease import Leases, Tick
from .publisher import BrokerHub
from .supervise import supervised

log = logging.getLogger(__name__)

WORKER_HISTORY_S = 1.0


def cut(text: str) -> str:
    """A text of a status record, within what replicas take (``inbound.MAX_TEXT``)."""
    return text if len(text) <= MAX_TEXT else text[: MAX_TEXT - 3] + "..."


def listed(names: list[str], most: int = 8) -> str:
    """Source names for a log line: the first few and how many in all."""
    if not names:
        return "no source"
    shown = ", ".join(names[:most])
    return shown if len(names) <= most else f"{len(names)} sources ({shown}, ...)"


class Worker(Runtime):
    """The sources this worker holds leases for, publishing to the broker."""

    def __init__(self, cell: Cell, defaults: SourceDefaults, broker: BrokerSettings) -> None:
        self.id = member_id("acquire")
        self.redis: Redis = connect(broker.url, broker.password, broker.lease_s / 2)
        # Nothing reads a worker's history (replicas serve viewers): a second of it will do.
        history = History(WORKER_HISTORY_S)
        super().__init__(cell, defaults, BrokerHub(self.redis, self._describe), history=history)
        self.whole = cell
        """The cell file's cell; ``self.cell`` holds only the sources held."""
        self.held: list[str] = []
        self.broker = BrokerState(broker.url, f"worker {self.id}")
        self.lease_redis: Redis = connect(broker.url, broker.password, broker.lease_s / 2)
        self.leases = Leases(self.lease_redis, self.id, broker.lease_s)
        self.lease_s = broker.lease_s
        self._lock = asyncio.Lock()
        self._applied: Cell | None = None
        """The cell file's cell the running sources were last set up from."""
        refusals = Throttled(log, f"worker {self.id}: moves")
        self.commands = Commands(self.redis, self._execute, self._source_of, refusals)
        self.restarts: dict[str, int] = {}
        """Supervised tasks started again after they failed, by name."""

    @property
    def publisher(self) -> BrokerHub:
        """The hub, as the broker publisher it is."""
        assert isinstance(self.hub, BrokerHub)
        return self.hub

    async def apply(self, cell: Cell) -> None:
        """A new cell file: keep following the sources held that it still has.

        Where it cannot start, the sources held run on (``Runtime.apply``) and so
        does the cell they came from: a lease taken later starts from that one.
        """
        previous, self.whole = self.whole, cell
        try:
            await self.hold([s for s in self.held if any(c.name == s for c in cell.sources)])
        except BaseException:
            self.whole = previous
            raise

    async def hold(self, names: list[str]) -> None:
        """Follow exactly the sources ``names`` (stopping, starting what changes)."""
        async with self._lock:
            wanted = [s for s in self.whole.sources if s.name in names]
            if [s.name for s in wanted] == self.held and self._applied is self.whole:
                return
            await Runtime.apply(self, dataclasses.replace(self.whole, sources=tuple(wanted)))
            self._applied = self.whole
            if set(self.held) != {s.name for s in wanted}:
                log.info("%s: following %s", self.id, listed([s.name for s in wanted]))
            self.held = [s.name for s in wanted]
            self.commands.keep([s.name for s in self.whole.sources])

    def _publish_cell(self) -> None:
        """Nothing to publish: replicas greet their viewers from their own cell file."""

    def _describe(self, source: str) -> dict[str, object] | None:
        running = self.sources.get(source)
        if running is None:
            return None
        health = running.health
        status = {
            key: cut(value) if isinstance(value, str) else value
            for key, value in health.status().model_dump().items()
        }
        return {
            "status": status,
            "robots": {
                name: {
                    "ok": robot.ok,
                    "error": None if robot.error is None else cut(robot.error),
                    "frames": robot.frames,
                    "values": None if robot.values is None else robot.values.tolist(),
                }
                for name, robot in health.robots.items()
            },
            "worker": self.id,
        }

    async def follow_leases(self) -> None:
        """Hold a fair share of the cell's sources for as long as the broker lets us.

        Sources start and stop in a task of their own (``_rearrange``): many
        of them take a while to start, and leases must be renewed meanwhile.
        """
        retry = tick_s = self.lease_s / 4
        valid_until = 0.0
        rearranging: asyncio.Task[None] | None = None
        while True:
            sent = time.monotonic()
            try:
                tick = await self.leases.tick([s.name for s in self.whole.sources])
            except (RedisError, OSError) as exc:
                self.broker.failed(exc, retry)
                if self.held and time.monotonic() + tick_s >= valid_until:
                    log.warning("%s: leases not renewed in time; stopping every source", self.id)
                    await self.hold([])
                await asyncio.sleep(retry)
                retry = min(retry * 2, RETRY_MAX_S)
                continue
            retry = tick_s
            self.broker.reached()
            valid_until = sent + self.lease_s
            self.publisher.json_wanted = tick.json_wanted
            lost = set(self.held) - set(tick.held)
            if lost:
                log.warning("%s: lease of %s lost", self.id, listed(sorted(lost)))
            if rearranging is None or rearranging.done():
                rearranging = asyncio.create_task(self._rearrange(tick))
            await asyncio.sleep(max(0.0, sent + tick_s - time.monotonic()))

    async def _rearrange(self, tick: Tick) -> None:
        """Follow what ``tick`` gave us; hand the excess over once it is stopped."""
        handed = tick.excess
        try:
            await self.hold([s for s in tick.held + tick.taken if s not in handed])
            if handed:
                await self.leases.release(handed)
                log.info("%s: handed %s over (fair share %d)", self.id, listed(handed), tick.fair)
        except (RedisError, OSError):
            pass  # the next tick reports the broker's state, and hands over again
        except Exception:  # the lease loop must outlive any one source that fails to start
            log.exception("%s: following %s failed", self.id, listed(tick.held + tick.taken))

    async def follow_commands(self) -> None:
        """Take the moves replicas send for sources held; reconnects after the broker."""
        while True:
            pubsub = self.redis.pubsub(ignore_subscribe_messages=True)
            try:
                await pubsub.subscribe(command_channel(self.id))
                while True:
                    message = await pubsub.get_message(timeout=1.0)
                    if message is not None and message["type"] == "message":
                        self.commands.take(message["data"])
                        # Buffered messages come without a wait: a flood must not hold the loop.
                        await asyncio.sleep(0)
            except (RedisError, OSError):
                pass  # the lease loop reports the broker's state
            finally:
                with contextlib.suppress(RedisError, OSError):
                    await pubsub.aclose()  # type: ignore[no-untyped-call]
            await asyncio.sleep(self.lease_s / 4)

    def _source_of(self, robot: str) -> str | None:
        """The source of ``robot`` in the cell file (held or being taken over), None if none."""
        found = next((r for r in self.whole.robots if r.name == robot), None)
        return None if found is None else found.source

    async def _execute(self, command: MoveCommand) -> tuple[int, str]:
        """Move a robot as ``command`` asks; the answer owed: HTTP status and detail."""
        async with self._lock:  # a source being taken over is ready once the lock is free
            robot = self.robot(command.robot)
            following = robot is not None and robot.source in self.sources
        try:
            if robot is None or not following:
                raise MoveError(503, f"this worker no longer follows {command.robot!r}")
            await self.move(robot, command.joints)
        except MoveError as exc:
            return exc.status, str(exc)
        except Exception as exc:  # an answer is owed whatever happens
            log.exception("%s: move failed", self.id)
            return 500, f"internal error: {exc!r}"
        return 202, "ok"

    async def close(self) -> None:
        """Stop following, give the leases up so others take over at once, then clean up.

        Logging out of controllers and stopping embedded mocks takes a while;
        the leases go back as soon as no acquisition runs, not after that.
        """
        async with self._lock:
            running = [s.task for s in self.sources.values() if s.task is not None]
            for task in running:
                task.cancel()
            await asyncio.gather(*running, return_exceptions=True)
            with contextlib.suppress(RedisError, OSError):
                await self.leases.leave(self.held)
            stopping = [source.stop() for source in self.sources.values()]
            await asyncio.gather(*stopping, return_exceptions=True)  # logouts: 2 s at most each
            self.sources, self.held = {}, []
        await self.commands.close()
        await self.redis.aclose()
        await self.lease_redis.aclose()


async def run_worker(
    cell: Cell, defaults: SourceDefaults, broker: BrokerSettings, load: Callable[[], Cell]
) -> None:
    """Run a worker until SIGINT or SIGTERM; ``load`` rereads the cell file when it changes."""
    worker = Worker(cell, defaults, broker)
    count = len(cell.sources)
    log.info("%s: acquisition worker for %d sources via %s", worker.id, count, broker.url)
    stop = asyncio.Event()
    loop = asyncio.get_running_loop()
    for sig in (signal.SIGINT, signal.SIGTERM):
        loop.add_signal_handler(sig, stop.set)
    loop_pacer().start()
    tasks = [
        supervised("publish", worker.publisher.run, worker.restarts),
        supervised("leases", worker.follow_leases, worker.restarts),
        supervised("commands", worker.follow_commands, worker.restarts),
        supervised("answers", worker.commands.answer_all, worker.restarts),
    ]
    if cell.path is not None:
        path: Path = cell.path
        tasks.append(asyncio.create_task(follow_cell_file(worker, path, load, stop)))
    try:
        await stop.wait()
    finally:
        log.info("%s: stopping", worker.id)
        for task in tasks:
            task.cancel()
        await asyncio.gather(*tasks, return_exceptions=True)
        await worker.close()
