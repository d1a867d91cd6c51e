"""Light viewers for bench/viewers.py: many WebSocket clients in one process that barely parse.

``--viewers N`` connect, ``ready`` is printed once each has its hello, then
``START END`` (unix s) is read from stdin; what arrives in that window is
counted, summarised as JSON on stdout, and every sample-to-receipt delay (s,
float64) is written to ``--out``. The WebSocket client is our own (RFC 6455,
client side only): a library client parses and queues every message, which at
500 viewers x 150 messages/s would measure the client, not the server. The
first frame of every viewer is also decoded in full and must agree.
"""

from __future__ import annotations

import argparse
import asyncio
import base64
import json
import math
import os
import sys
import time
from array import array

import orjson

sys.path.insert(0, os.path.join(os.path.dirname(os.path.abspath(__file__)), ".."))
from server.protocol import FRAMES_HEADER, ROBOT_HEADER, decode_frames  # noqa: E402

WINDOW = [math.inf, math.inf]
"""The measuring window (unix s), shared by every viewer of the process."""


class Viewer(asyncio.Protocol):
    """One viewer: counts frames per robot, their bytes on the wire and the links they carry."""

    def __init__(self, port: int, protocol: int, delays: array[float]) -> None:
        self.port, self.protocol, self.delays = port, protocol, delays
        self.buf, self.upgraded = bytearray(), False
        self.transport: asyncio.Transport | None = None
        self.hello: asyncio.Future[None] = asyncio.get_running_loop().create_future()
        self.names: list[str] = []
        self.links_of: dict[str, int] = {}
        self.frames: dict[str, int] = {}
        self.frame_bytes = self.links = 0
        self.checked, self.mismatch, self.lost = False, "", False

    def connection_made(self, transport: asyncio.BaseTransport) -> None:
        assert isinstance(transport, asyncio.Transport)
        self.transport = transport
        key = base64.b64encode(os.urandom(16)).decode()
        offer = "Sec-WebSocket-Protocol: linkview.2\r\n" if self.protocol == 2 else ""
        transport.write(
            f"GET /ws HTTP/1.1\r\nHost: 127.0.0.1:{self.port}\r\nUpgrade: websocket\r\n"
            f"Connection: Upgrade\r\nSec-WebSocket-Key: {key}\r\n"
            f"Sec-WebSocket-Version: 13\r\n{offer}\r\n".encode()
        )

    def connection_lost(self, exc: Exception | None) -> None:
        self.lost = time.time() < WINDOW[1]
        if not self.hello.done():
            self.hello.set_exception(ConnectionError(f"lost before the hello: {exc}"))

    def data_received(self, data: bytes) -> None:
        now = time.time()  # one receipt time per read: these bytes arrived together
        buf, pos = self.buf, 0
        buf += data
        if not self.upgraded:
            if (pos := buf.find(b"\r\n\r\n") + 4) < 4:
                return
            head = buf[:pos].decode("latin-1").lower()
            if not head.startswith("http/1.1 101") or (
                self.protocol == 2 and "sec-websocket-protocol: linkview.2" not in head
            ):
                raise ConnectionError(f"no WebSocket (protocol {self.protocol}): {head!r}")
            self.upgraded = True
        size = len(buf)
        while size - pos >= 2:
            length, head_size = buf[pos + 1] & 0x7F, 2  # server frames are never masked
            if length == 126:
                length, head_size = int.from_bytes(buf[pos + 2 : pos + 4], "big"), 4
            elif length == 127:
                length, head_size = int.from_bytes(buf[pos + 2 : pos + 10], "big"), 10
            if (end := pos + head_size + length) > size:
                break
            self.message(buf[pos] & 0x0F, pos + head_size, end, head_size, now)
            pos = end
        del buf[:pos]

    def message(self, opcode: int, start: int, end: int, head_size: int, now: float) -> None:
        """Count one whole message, ``buf[start:end]``."""
        buf, in_window = self.buf, WINDOW[0] <= now < WINDOW[1]
        if opcode == 2:  # protocol 2: every robot of the source, fixed-size headers
            _, _, count, _, t_source, _ = FRAMES_HEADER.unpack_from(buf, start)
            at, links, name = start + FRAMES_HEADER.size, 0, ""
            for _ in range(count):
                index, _, n_joints, n_links, n_error = ROBOT_HEADER.unpack_from(buf, at)
                at += ROBOT_HEADER.size + 4 * (n_joints + 7 * n_links + 7) + n_error
                self.frames[self.names[index]] += in_window
                links += n_links
        elif opcode == 1 and buf.startswith(b'{"type":"frame"', start):  # protocol 1
            name_at = buf.find(b'"robot":"', start, end) + 9
            name = buf[name_at : buf.find(b'"', name_at)].decode()
            t_at = buf.find(b'"t_source":', name_at, end) + 11
            t_source = float(buf[t_at : buf.find(b",", t_at)])
            links = self.links_of[name]
            self.frames[name] += in_window
        elif opcode == 1 and not self.names:
            robots = orjson.loads(buf[start:end])["robots"]
            self.names = [r["name"] for r in robots]
            self.links_of = {r["name"]: len(r["links"]) for r in robots}
            self.frames = dict.fromkeys(self.names, 0)
            self.hello.set_result(None)
            return
        else:
            if opcode == 9:  # ping: answer with a pong carrying the same payload
                self.send(0xA, bytes(buf[start:end]))
            return
        if not self.checked:
            self.check(bytes(buf[start:end]), name, t_source)
        if in_window:
            self.delays.append(now - t_source)
            self.frame_bytes += head_size + end - start
            self.links += links

    def check(self, payload: bytes, name: str, t_source: float) -> None:
        """Once: the light parse finds what a full decode (orjson, decode_frames) finds."""
        if name:
            frame = orjson.loads(payload)
            full = (frame["robot"], frame["t_source"])
        else:
            full = ("", decode_frames(payload).t_source)
        if full != (name, t_source):
            self.mismatch = f"light parse {(name, t_source)} != full decode {full}"
        self.checked = True

    def send(self, opcode: int, payload: bytes) -> None:
        """A masked client frame (under 126 bytes: control frames only)."""
        mask = os.urandom(4)
        masked = bytes(b ^ mask[i % 4] for i, b in enumerate(payload))
        if self.transport is not None and not self.transport.is_closing():
            self.transport.write(bytes([0x80 | opcode, 0x80 | len(payload)]) + mask + masked)


async def run(port: int, count: int, protocol: int, out: str) -> dict[str, object]:
    """Connect ``count`` viewers, measure the window given on stdin, return the summary."""
    loop = asyncio.get_running_loop()
    delays: array[float] = array("d")
    gate = asyncio.Semaphore(50)  # do not storm the server's accept queue

    async def join() -> Viewer:
        async with gate:
            _, viewer = await loop.create_connection(
                lambda: Viewer(port, protocol, delays), "127.0.0.1", port
            )
            await asyncio.wait_for(viewer.hello, 30)
            return viewer

    viewers = await asyncio.gather(*(join() for _ in range(count)))
    print("ready", flush=True)
    WINDOW[:] = map(float, (await loop.run_in_executor(None, sys.stdin.readline)).split())
    await asyncio.sleep(max(0.0, WINDOW[1] - time.time()) + 0.2)
    for viewer in viewers:
        viewer.send(0x8, (1000).to_bytes(2, "big"))  # close, normal
        if viewer.transport is not None:
            viewer.transport.close()
    with open(out, "wb") as file:
        delays.tofile(file)
    return {
        "viewers": [
            {"frames": v.frames, "bytes": v.frame_bytes, "links": v.links, "lost": v.lost}
            for v in viewers
        ],
        "unchecked": sum(not v.checked for v in viewers),
        "mismatches": sorted({v.mismatch for v in viewers if v.mismatch}),
    }


if __name__ == "__main__":
    parser = argparse.ArgumentParser(description=__doc__)
    parser.add_argument("--port", type=int, required=True)
    parser.add_argument("--viewers", type=int, required=True)
    parser.add_argument("--protocol", type=int, choices=[1, 2], required=True)
    parser.add_argument("--out", required=True, help="file for the delays (float64, s)")
    args = parser.parse_args()
    summary = asyncio.run(run(args.port, args.viewers, args.protocol, args.out))
    print(json.dumps(summary), flush=True)
