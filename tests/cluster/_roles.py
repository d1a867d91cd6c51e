"""A real redis-server and the roles of a cluster, as processes on free loopback ports."""

from __future__ import annotations

import asyncio
import contextlib
import json
import os
import shutil
import signal
import socket
import subprocess
import sys
import time
from collections.abc import Callable
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import aiohttp
import redis
from websockets.asyncio.client import connect
from websockets.typing import Subprotocol

from server.protocol import decode_frames
from tests.conftest import free_port

ROOT = Path(__file__).resolve().parent.parent.parent
REDIS_SERVER = shutil.which("redis-server") or "/usr/bin/redis-server"
START_TIMEOUT_S = 120.0
"""Starting a role imports most of the server: seconds on a busy machine, more when shared."""


class RedisServer:
    """``redis-server`` on a loopback port, in a folder of its own; stopped and started at will."""

    def __init__(self, folder: Path, port: int) -> None:
        self.folder, self.port = folder, port
        self.process: subprocess.Popen[bytes] | None = None
        folder.mkdir(parents=True, exist_ok=True)

    @property
    def url(self) -> str:
        return f"redis://127.0.0.1:{self.port}/0"

    def start(self) -> None:
        args = ["--port", str(self.port), "--bind", "127.0.0.1", "--save", "", "--appendonly"]
        args += ["no", "--dir", str(self.folder)]
        with open(self.folder / "redis.log", "ab") as log:
            self.process = subprocess.Popen([REDIS_SERVER, *args], stdout=log, stderr=log)
        deadline = time.monotonic() + START_TIMEOUT_S
        while not self.answers():
            if time.monotonic() > deadline or self.process.poll() is not None:
                raise RuntimeError(f"redis-server did not start: {self.log()}")
            time.sleep(0.05)

    def answers(self) -> bool:
        try:
            with socket.create_connection(("127.0.0.1", self.port), timeout=1) as sock:
                sock.sendall(b"PING\r\n")
                return sock.recv(16).startswith(b"+PONG")
        except OSError:
            return False

    def stop(self) -> None:
        if self.process is not None:
            stop(self.process)
            self.process = None

    def client(self) -> redis.Redis:
        return redis.Redis(host="127.0.0.1", port=self.port, socket_timeout=5)

    def log(self) -> str:
        return (self.folder / "redis.log").read_text(errors="replace")


def stop(process: subprocess.Popen[bytes], sig: int = signal.SIGTERM) -> None:
    """Stop a process this test started: ``sig`` first, SIGKILL if it lingers."""
    if process.poll() is None:
        process.send_signal(sig)
        try:
            process.wait(10)
        except subprocess.TimeoutExpired:
            process.kill()
            process.wait(10)


class Role:
    """One ``python -m server`` process (a worker or a replica), its output in a file."""

    def __init__(self, name: str, process: subprocess.Popen[bytes], log: Path, port: int | None):
        self.name, self.process, self.log_path, self.port = name, process, log, port

    @property
    def base(self) -> str:
        return f"http://127.0.0.1:{self.port}"

    def log(self) -> str:
        return self.log_path.read_text(errors="replace")

    def kill(self) -> None:
        """Die at once, as a crashed process does: no lease is given back."""
        stop(self.process, signal.SIGKILL)

    def rss_mib(self) -> float:
        """The process's resident memory now (MiB)."""
        for line in Path(f"/proc/{self.process.pid}/status").read_text().splitlines():
            if line.startswith("VmRSS:"):
                return int(line.split()[1]) / 1024
        raise AssertionError(f"no VmRSS for {self.name}")


class Cluster:
    """The roles one test starts, all against one broker URL and one cell file."""

    def __init__(self, folder: Path, broker: str, cell: Path | None) -> None:
        self.folder, self.broker, self.cell = folder, broker, cell
        self.roles: list[Role] = []

    def start(
        self, name: str, command: list[str], env: dict[str, str], port: int | None = None
    ) -> Role:
        """Start ``python ARGS`` (the repository root as working folder) with ``env`` added."""
        log = self.folder / f"{name}.log"
        environment = {
            **os.environ,
            "PYTHONPATH": str(ROOT),
            "LINKVIEW_CACHE_DIR": str(self.folder / "cache"),
            **env,
        }
        with open(log, "wb") as out:
            process = subprocess.Popen(
                [sys.executable, *command], cwd=ROOT, env=environment, stdout=out, stderr=out
            )
        role = Role(name, process, log, port)
        self.roles.append(role)
        return role

    def worker(self, name: str = "worker") -> Role:
        """``python -m server acquire --cell FILE --broker URL``."""
        return self.start(name, ["-m", "server", "acquire", *self._common()], {})

    def replica(self, name: str = "replica") -> Role:
        """``python -m server --cell FILE --broker URL --port P``."""
        port = free_port()
        return self.start(name, ["-m", "server", *self._common(), "--port", str(port)], {}, port)

    def _common(self) -> list[str]:
        cell = ["--cell", str(self.cell)] if self.cell is not None else []
        return [*cell, "--broker", self.broker]

    def close(self) -> None:
        """Stop every role: all asked at once, then each waited for (killed if it lingers)."""
        for role in self.roles:
            if role.process.poll() is None:
                role.process.terminate()
        for role in self.roles:
            stop(role.process)


def cell_text(sources: int) -> str:
    """A cell of ``sources`` embedded mocks named s0, s1, ..., a five-bar ``m<i>`` on each."""
    parts = []
    for i in range(sources):
        joints = ", ".join(
            f'{{ node = "motion/axs/m{i}_a{k}/state/values/actual/pos", unit = "deg" }}'
            for k in (0, 1)
        )
        parts.append(
            f'[[source]]\nname = "s{i}"\n\n[[robot]]\nname = "m{i}"\nsource = "s{i}"\n'
            f"base = {{ xyz = [{600.0 * i}, 0.0, 0.0] }}\n"
            'kinematics = { type = "type12", limits = [[-40.0, 40.0], [-40.0, 40.0]] }\n'
            f"joints = [{joints}]\n"
            "demo_targets = [[0.0, 0.0], [30.0, -25.0], [-20.0, 30.0]]\n"
        )
    return "\n".join(parts)


async def health_of(role: Role) -> tuple[int, dict[str, Any]]:
    """A replica's /api/health: the status code and the body."""
    async with aiohttp.ClientSession() as http, http.get(role.base + "/api/health") as resp:
        body: dict[str, Any] = await resp.json()
        return resp.status, body


async def wait_for(
    role: Role, predicate: Any, timeout_s: float = START_TIMEOUT_S
) -> dict[str, Any]:
    """Poll a replica's health until ``predicate(body)`` holds (connection refused: not yet)."""
    async with asyncio.timeout(timeout_s):
        while True:
            try:
                _, body = await health_of(role)
                if predicate(body):
                    return body
            except (aiohttp.ClientConnectionError, aiohttp.ContentTypeError):
                # Not listening yet, or (a proxy) no server behind it yet.
                if role.process.poll() is not None:
                    raise RuntimeError(f"{role.name} exited:\n{role.log()}") from None
            await asyncio.sleep(0.1)


def all_live(body: dict[str, Any]) -> bool:
    """Every source connected, and the broker too."""
    return body["broker"]["state"] == "connected" and all(
        s["state"] == "connected" for s in body["sources"]
    )


def holders(server: RedisServer, sources: list[str]) -> dict[str, str | None]:
    """The worker holding each source's lease, read from Redis itself."""
    with server.client() as client:
        values = client.mget([f"linkview:lease:{s}" for s in sources])
    return {s: None if v is None else v.decode() for s, v in zip(sources, values, strict=True)}


@dataclass
class Seen:
    """What one protocol-2 viewer got: its hello, and each frames message with its arrival."""

    hello: dict[str, Any]
    frames: list[tuple[float, int, int, bytes]] = field(default_factory=list)
    """(monotonic arrival, source's first robot index, seq, the message's bytes)."""
    statuses: list[dict[str, Any]] = field(default_factory=list)

    json_frames: list[dict[str, Any]] = field(default_factory=list)
    """Protocol 1's frame messages."""

    def add(self, data: str | bytes) -> None:
        if isinstance(data, bytes):
            frames = decode_frames(data)
            index = frames.robots[0].robot_index
            self.frames.append((time.monotonic(), index, frames.seq, data))
        elif (message := json.loads(data))["type"] == "status":
            self.statuses.append(message["sources"][0])
        elif message["type"] == "frame":
            self.json_frames.append(message)

    def arrivals(self, index: int) -> list[float]:
        """When the frames of the source whose first robot is ``index`` arrived (monotonic)."""
        return [t for t, i, _, _ in self.frames if i == index]


async def watch(
    base: str, seconds: float, until: Callable[[Seen], bool] | None = None, protocol: int = 2
) -> Seen:
    """Watch a replica as a viewer for ``seconds``, or until ``until(seen)`` holds."""
    url = base.replace("http", "ws") + "/ws"
    offer = [Subprotocol("linkview.2")] if protocol == 2 else None
    async with connect(url, subprotocols=offer) as ws:
        hello = json.loads(await asyncio.wait_for(ws.recv(), 10))
        assert hello["type"] == "hello"
        seen = Seen(hello)
        with contextlib.suppress(TimeoutError):
            async with asyncio.timeout(seconds):
                async for data in ws:
                    seen.add(data)
                    if until is not None and until(seen):
                        break
    return seen
