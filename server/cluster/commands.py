"""Moves a worker reads from Redis: checked, rate-limited and bounded per source, answered in turn.

A replica publishes a move on the channel of the worker holding the robot's
source (``cmd:<worker>``) and waits for the answer on its own channel
(``reply:<replica>``). Whatever can write to Redis can publish there too, at
any rate; a task per message, each with a request to the controller and a
publish of its answer, would cost memory and Redis connections without
bound, and the leases with them. So:

* a command is a ``MoveCommand`` (schema and sizes) or it is dropped;
* per source, at most MOVES_PER_S moves a second (a burst of MOVE_BURST) and
  IN_FLIGHT at once are executed; the others are answered 429 at once;
* answers are published by one task, in turn, over one connection; at most
  ANSWERS_QUEUED wait, and what does not fit is dropped (that replica answers
  504 after its own timeout).

Everything refused is counted and logged at most once a minute.
"""

from __future__ import annotations

import asyncio
import contextlib
import logging
from collections import deque
from collections.abc import Awaitable, Callable
from typing import Annotated

import orjson
from pydantic import BaseModel, ConfigDict, Field, ValidationError
from redis.asyncio import Redis
from redis.exceptions import RedisError

from ..flood import MessageBudget
from ..logs import Throttled
from .broker import MEMBER, PREFIX

log = logging.getLogger(__name__)

MOVES_PER_S = 10.0
MOVE_BURST = 10
IN_FLIGHT = 2
"""Moves of one source executing (or waiting for the source) at once."""
ANSWERS_QUEUED = 256
MAX_DETAIL = 1000
"""Characters of an answer's detail (an exception's text can be long)."""
REPLY = rf"^{PREFIX}reply:{MEMBER.pattern}$"


class MoveCommand(BaseModel):
    """A move as a replica sends it (``Replica.move``)."""

    model_config = ConfigDict(extra="forbid", frozen=True)

    id: Annotated[str, Field(pattern=rf"^{MEMBER.pattern}$")]
    robot: Annotated[str, Field(min_length=1, max_length=64)]
    joints: Annotated[list[float], Field(max_length=64)]
    reply: Annotated[str, Field(pattern=REPLY)]


Execute = Callable[[MoveCommand], Awaitable[tuple[int, str]]]
"""Executes a move; its answer: HTTP status and detail."""


class Commands:
    """One worker's intake of moves: ``take`` each message read, ``answer_all`` runs meanwhile."""

    def __init__(
        self,
        redis: Redis,
        execute: Execute,
        source_of: Callable[[str], str | None],
        refusals: Throttled,
    ) -> None:
        self._redis = redis
        self._execute = execute
        self._source_of = source_of
        self.refusals = refusals
        self._budgets: dict[str, MessageBudget] = {}
        self._running: dict[str, int] = {}
        self._tasks: set[asyncio.Task[None]] = set()
        self._answers: deque[tuple[str, bytes]] = deque()
        self._wake = asyncio.Event()

    def take(self, data: bytes) -> None:
        """One message read from the worker's command channel."""
        if len(data) > 4096:
            self.refusals.refuse("command", f"a command of {len(data)} bytes")
            return
        try:
            command = MoveCommand.model_validate_json(data)
        except ValidationError as exc:
            first = exc.errors()[0]
            where = ".".join(map(str, first["loc"])) or "(command)"
            self.refusals.refuse("command", f"a malformed command: {where}: {first['msg']}")
            return
        source = self._source_of(command.robot)
        if source is None:
            self.answer(command, 404, f"no robot named {command.robot!r} in the cell")
            return
        budget = self._budgets.get(source)
        if budget is None:  # one per source of the cell: forgotten with ``keep``
            budget = self._budgets[source] = MessageBudget(MOVES_PER_S, MOVE_BURST)
        if self._running.get(source, 0) >= IN_FLIGHT or not budget.spend():
            self.refusals.refuse("rate", f"a move of {command.robot}: too many moves")
            why = f"at most {MOVES_PER_S:g} moves a second and {IN_FLIGHT} at once per source"
            self.answer(command, 429, f"too many moves for source {source}: {why}")
            return
        self._running[source] = self._running.get(source, 0) + 1
        task = asyncio.create_task(self._run(command, source))
        self._tasks.add(task)  # held until done: the loop keeps weak references only
        task.add_done_callback(self._tasks.discard)

    def keep(self, sources: list[str]) -> None:
        """Forget the budgets of sources no longer in the cell."""
        for name in set(self._budgets) - set(sources):
            del self._budgets[name]

    async def _run(self, command: MoveCommand, source: str) -> None:
        try:
            status, detail = await self._execute(command)
        finally:
            left = self._running.get(source, 1) - 1
            if left:
                self._running[source] = left
            else:
                self._running.pop(source, None)
        self.answer(command, status, detail)

    def answer(self, command: MoveCommand, status: int, detail: str) -> None:
        """Queue the answer to ``command`` (dropped if ANSWERS_QUEUED are waiting)."""
        if len(self._answers) >= ANSWERS_QUEUED:
            self.refusals.refuse("answer", "an answer: too many waiting to be sent")
            return
        body = {"id": command.id, "status": status, "detail": detail[:MAX_DETAIL]}
        self._answers.append((command.reply, orjson.dumps(body)))
        self._wake.set()

    async def answer_all(self) -> None:
        """Publish the queued answers in turn, until cancelled."""
        while True:
            await self._wake.wait()
            self._wake.clear()
            while self._answers:
                channel, body = self._answers.popleft()
                with contextlib.suppress(RedisError, OSError):  # the lease loop reports it
                    await self._redis.publish(channel, body)

    async def close(self) -> None:
        """Cancel the moves still running."""
        for task in self._tasks:
            task.cancel()
        await asyncio.gather(*self._tasks, return_exceptions=True)
