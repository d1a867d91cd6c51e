"""``python -m server --broker URL``: a web replica of a cluster.

A replica follows no controller. It feeds the frames and status the workers
publish into its own hub, which fans them out to its viewers as one process
does. Everything a viewer gets is either from the broker (frames, status,
robot health) or from the cell file every role reads (hello, cell notice),
and the session id is derived from the cell: replicas are interchangeable, and
a viewer may reconnect to any of them and carry on.

Each source's state is judged on the replica's own clock from the frames
it receives, so a source whose worker died shows as stale here, and every
source shows the broker's error while the broker is unreachable.

What arrives from the broker is checked before use (``inbound``): anything
no worker of this cell would publish is counted, dropped and logged at most
once a minute. The listener and the other tasks are ``supervised``: a task
that fails is logged and started again.
"""

from __future__ import annotations

import asyncio
import contextlib
import hashlib
import logging
import time
from collections import Counter
from collections.abc import Callable
from typing import Any

import orjson
from redis.asyncio import Redis
from redis.exceptions import RedisError

from ..cell import Cell, Robot
from ..logs import Throttled
from ..runtime import MoveError, Runtime, SourceDefaults, may_command, move_target
from ..stream import Message, SourceHealth
from . import envelope
from .broker import (
    FRAMES,
    RETRY_MAX_S,
    RETRY_MIN_S,
    WANTS_JSON,
    BrokerSettings,
    BrokerState,
    command_channel,
    connect,
    health_key,
    lease_key,
    member_id,
    member_of,
    reply_channel,
)
from .inbound import ITEMS_PER_SOURCE, Inbound, Refused, answer_of
from .supervise import supervised

log = logging.getLogger(__name__)

WATCH_S = 0.1
"""How often each source's state is checked (stale) on the replica's clock."""
STATUS_EVERY_S = 1.0
"""Each source's status is sent to viewers at least this often (a live sample age)."""
POLL_S = 0.5
"""How often the replica reads who holds each source and says whether it has JSON viewers."""
COMMAND_TIMEOUT_S = 5.0
NO_WORKER = "no acquisition worker follows this source (start one: python -m server acquire)"
WAITING = "waiting for the acquisition worker"


def session_of(cell: Cell) -> str:
    """The same on every replica serving the same cell (however each names the broker)."""
    infos = [info.model_dump() for info in cell.infos(lambda _: False)]
    return hashlib.sha256(orjson.dumps(infos)).hexdigest()[:16]


class Replica(Runtime):
    """A Runtime without sources: its hub is fed from the broker."""

    def __init__(self, cell: Cell, defaults: SourceDefaults, broker: BrokerSettings) -> None:
        super().__init__(cell, defaults)
        self.id = member_id("web")
        self.redis: Redis = connect(broker.url, broker.password, COMMAND_TIMEOUT_S)
        self.broker = BrokerState(broker.url, f"replica {self.id}")
        self.holders: dict[str, str | None] = {}
        """The worker following each source, as last read."""
        self._health: dict[str, SourceHealth] = {}
        self._sent: dict[str, tuple[str, float]] = {}
        """Per source: the state and time of the last status sent to viewers."""
        self._replies: dict[str, asyncio.Future[tuple[int, str]]] = {}
        self._tasks: list[asyncio.Task[None]] = []
        self.inbound = Inbound(cell)
        self.refusals = Throttled(log, f"replica {self.id}: from the message broker")
        """What was read from the broker and dropped, by kind."""
        self.restarts: dict[str, int] = {}
        """Supervised tasks started again after they failed, by name."""

    @classmethod
    async def open(cls, cell: Cell, defaults: SourceDefaults, broker: BrokerSettings) -> Replica:
        """A replica serving ``cell``, listening to the broker (and retrying until it answers)."""
        replica = cls(cell, defaults, broker)
        await replica.apply(cell)
        replica._tasks = [
            supervised("broker:listen", replica._listen, replica.restarts),
            supervised("broker:watch", replica._watch, replica.restarts),
            supervised("broker:poll", replica._poll, replica.restarts),
        ]
        return replica

    async def apply(self, cell: Cell) -> None:
        """Serve ``cell``: hello and the sources' health come from it (no source is started)."""
        health = {}
        for source in cell.sources:
            kept = self._health.get(source.name)
            if kept is None:
                url = source.url or "embedded mock"
                kept = SourceHealth(source.name, url=url, mock=source.url is None)
                kept.error = WAITING if self.broker.up else self.broker.error
                kept.state = "connecting" if self.broker.up else "error"
            kept.period_s = source.period_s or self.defaults.period_s
            health[source.name] = kept
        self._health = health
        self.inbound = Inbound(cell)
        self.cell, self.cell_error = cell, None
        self.session = session_of(cell)
        self.hub.restart()
        self._publish_cell()
        for name in health:
            self._send_status(name)

    async def stop(self) -> None:
        """Stop listening; close the broker connection."""
        for task in self._tasks:
            task.cancel()
        await asyncio.gather(*self._tasks, return_exceptions=True)
        await self.redis.aclose()

    def healths(self) -> list[SourceHealth]:
        """Every source's health as this replica sees it, in cell order."""
        return list(self._health.values())

    def commandable(self, robot: Robot) -> bool:
        """As in one process; the worker holding the source checks it again."""
        source = next((s for s in self.cell.sources if s.name == robot.source), None)
        return source is not None and may_command(source, self.defaults.allow_commands)

    def report(self) -> dict[str, object]:
        """The broker's state, and which worker follows each source."""
        return {
            "broker": {
                **self.broker.report(),
                "workers": dict(self.holders),
                **self.refusals.report(),
                "restarts": dict(self.restarts),
            }
        }

    async def move(self, robot: Robot, q: list[float]) -> None:
        """Route the move to the worker that holds ``robot``'s source; its answer is ours."""
        if not self.commandable(robot):
            raise MoveError(
                403,
                f"{robot.name} is driven by a controller; start with --allow-commands to move it",
            )
        move_target(robot, q)  # refuse what no worker would take without asking one
        ident = member_id("move")
        answer: asyncio.Future[tuple[int, str]] = asyncio.get_running_loop().create_future()
        self._replies[ident] = answer
        try:
            holder = member_of(await self.redis.get(lease_key(robot.source)))
            if holder is None:
                raise MoveError(503, f"source {robot.source}: {NO_WORKER}")
            command = {"id": ident, "robot": robot.name, "joints": q, "reply": self._reply}
            if not await self.redis.publish(command_channel(holder), orjson.dumps(command)):
                raise MoveError(503, f"the worker following {robot.source} has gone")
            async with asyncio.timeout(COMMAND_TIMEOUT_S):
                status, detail = await answer
        except TimeoutError:  # before OSError, of which it is one
            raise MoveError(504, f"the worker following {robot.source} did not answer") from None
        except (RedisError, OSError) as exc:
            raise MoveError(503, f"message broker unreachable: {exc}") from exc
        finally:
            self._replies.pop(ident, None)
        if status != 202:
            raise MoveError(status, detail)

    @property
    def _reply(self) -> str:
        return reply_channel(self.id)

    async def _listen(self) -> None:
        """Receive batches (and answers to moves) for as long as the replica runs."""
        retry = RETRY_MIN_S
        while True:
            pubsub = self.redis.pubsub(ignore_subscribe_messages=True)
            try:
                await pubsub.subscribe(FRAMES, self._reply)
                await self._catch_up()
                retry = RETRY_MIN_S
                while True:
                    message = await pubsub.get_message(timeout=1.0)
                    if message is None or message["type"] != "message":
                        continue
                    if message["channel"] == FRAMES.encode():
                        self._on_batch(message["data"])
                    else:
                        self._checked(self._on_answer, message["data"])
                    # Buffered messages come without a wait: a burst must not hold the loop
                    # (and the viewers' writes) until it is all read.
                    await asyncio.sleep(0)
            except (RedisError, OSError) as exc:
                self._lost_broker(exc, retry)
            finally:
                with contextlib.suppress(RedisError, OSError):
                    await pubsub.aclose()  # type: ignore[no-untyped-call]
            await asyncio.sleep(retry)
            retry = min(retry * 2, RETRY_MAX_S)

    async def _catch_up(self) -> None:
        """The broker answers: start from the status records it keeps."""
        names = list(self._health)
        records = await self.redis.mget([health_key(n) for n in names]) if names else []
        self._found_broker()
        for name, record in zip(names, records, strict=True):
            if record is not None:
                self._checked(self._on_record, name, record)
        for name in names:
            self._send_status(name)

    def _lost_broker(self, exc: BaseException, retry_s: float) -> None:
        if self.broker.failed(exc, retry_s):
            for name, health in self._health.items():
                health.mark_error(self.broker.error or "message broker unreachable")
                self._send_status(name)

    def _found_broker(self) -> None:
        if self.broker.reached():
            for health in self._health.values():
                health.state, health.error = "connecting", WAITING

    def _on_batch(self, data: bytes) -> None:
        """A worker's batch: each item checked, then fed to the hub (or health) as it came."""
        per_source: Counter[str] = Counter()
        try:
            for item in envelope.unpack(data):
                source = item[0].partition(":")[2]
                per_source[source] += 1
                if per_source[source] > ITEMS_PER_SOURCE:  # a worker sends each key once
                    raise Refused("batch", f"a batch of more than 3 items of {source[:80]!r}")
                self._checked(self._on_item, item)
        except Refused as exc:
            self.refusals.refuse(exc.kind, str(exc))
        except ValueError as exc:
            self.refusals.refuse("batch", f"a garbled batch: {exc}")

    def _checked(self, handle: Callable[..., None], *args: Any) -> None:
        """``handle(*args)``; what it refuses is counted and logged, once a minute at most."""
        try:
            handle(*args)
        except Refused as exc:
            self.refusals.refuse(exc.kind, str(exc))

    def _on_item(self, item: envelope.Item) -> None:
        kind, source = self.inbound.item(item)
        key, message, protocol = item
        health = self._health[source]
        if kind == "status":
            assert isinstance(message.payload, str)  # checked by inbound.item
            self._on_record(source, message.payload)
            return
        self.hub.publish(key, message, protocol)
        if health.mark_sample():
            self._send_status(source)

    def _on_record(self, source: str, data: bytes | str) -> None:
        """A worker's status record: robots' health, the source's error, its URL."""
        record = self.inbound.record(source, data)
        health, status = self._health[source], record.status
        health.url, health.mock = status.url, status.mock
        health.warning = status.warning
        health.device = status.device
        health.halted = status.halted
        health.overloaded = status.overloaded  # the worker's count, not ours
        health.robots = {name: robot.health() for name, robot in record.robots.items()}
        self.holders[source] = member_of(record.worker)
        if status.state in ("error", "connecting"):
            health.state, health.error = status.state, status.error
        self._send_status(source)

    def _on_answer(self, data: bytes) -> None:
        ident, status, detail = answer_of(data)
        waiting = self._replies.get(ident)
        if waiting is not None and not waiting.done():
            waiting.set_result((status, detail))

    def _send_status(self, source: str) -> None:
        health = self._health[source]
        self._sent[source] = (health.current_state(), time.monotonic())
        self.hub.publish(f"status:{source}", Message(health.status_message()))

    async def _watch(self) -> None:
        """Send a source's status when its state changes here (stale) and once a second."""
        while True:
            await asyncio.sleep(WATCH_S)
            now = time.monotonic()
            for name, health in self._health.items():
                state, at = self._sent.get(name, ("", 0.0))
                if health.current_state() != state or now - at >= STATUS_EVERY_S:
                    self._send_status(name)

    async def _poll(self) -> None:
        """Read who holds each source; tell workers whether JSON frames are wanted."""
        missing: set[str] = set()
        while True:
            await asyncio.sleep(POLL_S)
            names = list(self._health)
            try:
                if self.hub.viewers_of(1):
                    await self.redis.set(WANTS_JSON, b"1", px=round(6 * POLL_S * 1000))
                holders = await self.redis.mget([lease_key(n) for n in names]) if names else []
            except (RedisError, OSError) as exc:  # also when Redis hangs: no error on the listener
                self._lost_broker(exc, POLL_S)
                continue
            self._found_broker()
            for name, holder in zip(names, holders, strict=True):
                self.holders[name] = member_of(holder)
                health = self._health[name]
                if holder is None and name in missing and not health.live:
                    if health.error != NO_WORKER:
                        health.mark_error(NO_WORKER)
                        self._send_status(name)
                if holder is None:
                    missing.add(name)
                else:
                    missing.discard(name)
