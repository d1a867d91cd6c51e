"""Tasks that must run as long as their role does: a task that dies is logged and started again.

A replica's listener, a worker's lease loop: if one of them ended on an
exception nobody expected, the role would go on running without it, silent
(a replica whose listener died streams nothing and says nothing). Each is
run by ``supervised``: an exception is logged with its traceback, and the
task starts again after a pause that doubles up to RESTART_MAX_S while it
keeps dying young, so a bug that fails at once cannot spin.
"""

from __future__ import annotations

import asyncio
import logging
import time
from collections.abc import Awaitable, Callable

log = logging.getLogger(__name__)

RESTART_MIN_S = 0.5
RESTART_MAX_S = 10.0
HEALTHY_S = 30.0
"""A task that ran this long before dying starts again after RESTART_MIN_S."""


def supervised(
    name: str,
    run: Callable[[], Awaitable[None]],
    restarts: dict[str, int] | None = None,
) -> asyncio.Task[None]:
    """A task that runs ``run()`` again whenever it raises or returns, until cancelled.

    ``restarts`` counts the restarts by name (for health), if given.
    """

    async def keep_running() -> None:
        pause = RESTART_MIN_S
        while True:
            started = time.monotonic()
            try:
                await run()
                log.error("task %s ended; starting it again in %.1f s", name, pause)
            except Exception:
                log.exception("task %s failed; starting it again in %.1f s", name, pause)
            if restarts is not None:
                restarts[name] = restarts.get(name, 0) + 1
            await asyncio.sleep(pause)
            young = time.monotonic() - started < HEALTHY_S
            pause = min(pause * 2, RESTART_MAX_S) if young else RESTART_MIN_S

    return asyncio.create_task(keep_running(), name=name)
