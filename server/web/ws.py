"""The viewer WebSocket: hello, then the newest frames and status messages."""

from __future__ import annotations

import asyncio
import logging
import secrets

import orjson
from fastapi import APIRouter, WebSocket, WebSocketDisconnect

from ..protocol import PROTOCOL_VERSION, Hello
from ..runtime import Runtime

log = logging.getLogger(__name__)

SEND_TIMEOUT_S = 10.0
"""A viewer that cannot take one batch in this time is disconnected."""

router = APIRouter()


def hello_message(runtime: Runtime) -> str:
    """The ``hello`` message for a new viewer."""
    hello = Hello(
        type="hello",
        protocol=PROTOCOL_VERSION,
        session=secrets.token_hex(8),
        robots=[r.info() for r in runtime.robots],
    )
    return orjson.dumps(hello.model_dump()).decode()


@router.websocket("/ws")
async def viewer_socket(websocket: WebSocket) -> None:
    """Stream to one viewer; it only ever gets the newest frame per robot."""
    runtime: Runtime = websocket.app.state.runtime
    await websocket.accept()
    viewer = runtime.hub.join()
    receiver = asyncio.create_task(_drain_incoming(websocket))
    receiver.add_done_callback(lambda _: viewer.close())
    try:
        await websocket.send_text(hello_message(runtime))
        while not viewer.closed:
            batch = await viewer.take()
            async with asyncio.timeout(SEND_TIMEOUT_S):
                for message in batch:
                    await websocket.send_text(message)
    except (WebSocketDisconnect, RuntimeError, ConnectionError):
        pass
    except TimeoutError:
        log.warning("viewer %d too slow for %.0f s; disconnected", viewer.id, SEND_TIMEOUT_S)
    finally:
        receiver.cancel()
        runtime.hub.leave(viewer)


async def _drain_incoming(websocket: WebSocket) -> None:
    """Read (and ignore) whatever the viewer sends, text or binary, until it disconnects."""
    try:
        while (await websocket.receive())["type"] != "websocket.disconnect":
            pass
    except (WebSocketDisconnect, RuntimeError):
        return
