"""A file sent to a client in chunks read off the event loop, then removed.

For what the server writes to a temporary file before sending (a saved
recording): at most CHUNK bytes of it are in memory at a time, a client that
takes nothing for ``flood.SEND_TIMEOUT_S`` is dropped, and ``done`` runs
whatever happens (the file's folder removed, a slot given back).
"""

from __future__ import annotations

import asyncio
from collections.abc import Awaitable, Callable
from pathlib import Path

from starlette.responses import Response
from starlette.types import Receive, Scope, Send

from ..flood import SEND_TIMEOUT_S

CHUNK = 256 * 1024


class FileDownload(Response):
    """``path`` as an attachment named ``name``; ``done()`` is awaited once it is over."""

    def __init__(self, path: Path, name: str, done: Callable[[], Awaitable[None]]) -> None:
        super().__init__(
            media_type="application/octet-stream",
            headers={
                "content-disposition": f'attachment; filename="{name}"',
                "content-length": str(path.stat().st_size),
            },
        )
        self.path = path
        self.done = done

    async def __call__(self, scope: Scope, receive: Receive, send: Send) -> None:
        try:
            with self.path.open("rb") as file:
                await send(
                    {"type": "http.response.start", "status": 200, "headers": self.raw_headers}
                )
                while True:
                    data = await asyncio.to_thread(file.read, CHUNK)
                    async with asyncio.timeout(SEND_TIMEOUT_S):  # a client that reads nothing
                        await send(
                            {"type": "http.response.body", "body": data, "more_body": bool(data)}
                        )
                    if not data:
                        return
        finally:
            await self.done()
