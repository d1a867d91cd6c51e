"""The viewer WebSocket: hello, then the newest frames and status messages."""

from __future__ import annotations

import asyncio
import logging
import time
from collections.abc import Callable

from fastapi import APIRouter, WebSocket, WebSocketDisconnect
from fastapi.responses import PlainTextResponse

from ..flood import SEND_TIMEOUT_S
from ..protocol import PROTOCOLS
from ..runtime import Runtime
from ..stream import Message
from ..stream.buckets import Buckets
from ..stream.hub import Payload
from .wire import EXTENSION, FrameWriter, ws_frames

log = logging.getLogger(__name__)

router = APIRouter()


def negotiate(offered: list[str]) -> tuple[str | None, int]:
    """The subprotocol to accept and the protocol version it means (1 when none is known)."""
    for name in offered:
        if name in PROTOCOLS:
            return name, PROTOCOLS[name]
    return None, 1


@router.websocket("/ws")
async def viewer_socket(websocket: WebSocket) -> None:
    """Stream to one viewer; it only ever gets the newest frame per key."""
    runtime: Runtime = websocket.app.state.runtime
    state = websocket.app.state
    if runtime.hub.viewer_count + state.foxglove_clients() >= state.max_viewers:
        await websocket.send_denial_response(
            PlainTextResponse("too many viewers; try again later", status_code=503)
        )
        return
    subprotocol, protocol = negotiate(list(websocket.scope.get("subprotocols", [])))
    await websocket.accept(subprotocol=subprotocol)
    viewer = runtime.hub.join(protocol, _direct_sender(websocket, runtime.hub.delay))
    receiver = asyncio.create_task(_drain_incoming(websocket))
    receiver.add_done_callback(lambda _: viewer.close())
    try:
        while not viewer.closed:
            batch = await viewer.take()
            viewer.busy = True
            async with asyncio.timeout(SEND_TIMEOUT_S):
                for message in batch:
                    if message.t_source is not None:
                        runtime.hub.delay.observe(time.time() - message.t_source)
                    await _send(websocket, message.payload)
            viewer.busy = False
    except (WebSocketDisconnect, RuntimeError, ConnectionError):
        pass
    except TimeoutError:
        log.warning("viewer %d too slow for %.0f s; disconnected", viewer.id, SEND_TIMEOUT_S)
    finally:
        receiver.cancel()
        runtime.hub.leave(viewer)


async def _send(websocket: WebSocket, payload: Payload) -> None:
    if isinstance(payload, bytes):
        await websocket.send_bytes(payload)
    elif isinstance(payload, str):
        await websocket.send_text(payload)
    else:
        for text in payload:
            await websocket.send_text(text)


def _direct_sender(websocket: WebSocket, delay: Buckets) -> Callable[[Message], bool] | None:
    """Writes a message's frame straight to the socket, where the server offers that."""
    extension = websocket.scope.get("extensions", {}).get(EXTENSION)
    if extension is None:
        return None
    write: FrameWriter = extension["write"]

    def send_now(message: Message) -> bool:
        wire = message.wire
        if wire is None:
            wire = message.wire = ws_frames(message.payload)
        if not write(wire):
            return False
        if message.t_source is not None:
            delay.observe(time.time() - message.t_source)
        return True

    return send_now


async def _drain_incoming(websocket: WebSocket) -> None:
    """Read (and ignore) whatever the viewer sends, text or binary, until it disconnects."""
    try:
        while (await websocket.receive())["type"] != "websocket.disconnect":
            pass
    except (WebSocketDisconnect, RuntimeError):
        return
