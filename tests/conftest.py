"""Fixtures shared across test folders: free loopback ports and a running linkview server."""

from __future__ import annotations

import asyncio
import dataclasses
import random
import shutil
import socket
import tempfile
from collections.abc import AsyncIterator, Callable, Iterator
from contextlib import asynccontextmanager
from pathlib import Path

import pytest
import uvicorn
from aiohttp import web
from hypothesis import settings as hypothesis_settings
from hypothesis.configuration import set_hypothesis_home_dir

from server.cell import Cell, Robot, load_cell
from server.config import Settings
from server.mock_ctrlx import build_app, serve
from server.paths import DEMO_CELL
from server.web import create_app
from server.web.serve import server_config

# Hypothesis' 200 ms per example is a timing floor: on a loaded 2-core machine it fails
# properties that hold. Examples are bounded by count (max_examples), not by time. No
# example database: it would be written into the checkout (.hypothesis/), and tests write
# only in temporary folders; a failing example is printed with the failure instead.
hypothesis_settings.register_profile("linkview", deadline=None, database=None)
hypothesis_settings.load_profile("linkview")
# Hypothesis keeps a cache of our code's constants in its home folder, by default
# ``.hypothesis/`` in the working directory (the checkout); it fills it while it collects
# the tests, before any fixture runs, so the folder is set here.
_HYPOTHESIS_HOME = Path(tempfile.mkdtemp(prefix="linkview-hypothesis-"))
set_hypothesis_home_dir(_HYPOTHESIS_HOME)


@pytest.fixture(scope="session", autouse=True)
def _hypothesis_home_removed() -> Iterator[None]:
    """Hypothesis' temporary home, removed when the session ends."""
    yield
    shutil.rmtree(_HYPOTHESIS_HOME, ignore_errors=True)


@pytest.fixture(scope="session", autouse=True)
def user_cache(tmp_path_factory: pytest.TempPathFactory) -> Iterator[Path]:
    """The user's cache, moved to a temporary folder for the session (subprocesses included).

    Tests write only under their own temporary folders; whatever lands here came
    from a test that forgot to pass one (see ``no_writes_to_the_user_cache``).
    """
    cache = tmp_path_factory.mktemp("xdg-cache")
    with pytest.MonkeyPatch.context() as env:
        env.setenv("XDG_CACHE_HOME", str(cache))
        env.delenv("LINKVIEW_CACHE_DIR", raising=False)
        yield cache / "linkview"


@pytest.fixture(autouse=True)
def no_writes_to_the_user_cache(user_cache: Path) -> Iterator[None]:
    """Fails the test that wrote to linkview's default cache (``~/.cache/linkview``)."""
    yield
    if user_cache.exists():
        written = sorted(str(p.relative_to(user_cache)) for p in user_cache.rglob("*"))
        shutil.rmtree(user_cache)  # charge the next test only with what it writes
        pytest.fail(f"wrote to the user's cache (pass a temporary cache_dir): {written}")


@pytest.fixture(scope="session")
def opcua_cache(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """Where mock OPC UA servers keep their address space (built once per test session)."""
    return tmp_path_factory.mktemp("opcua-cache")


def demo_cell() -> Cell:
    """The shipped demo cell, as ``python -m server`` runs it without ``--cell``."""
    return load_cell(DEMO_CELL)


def cell_with(*robots: Robot) -> Cell:
    """The demo cell plus ``robots`` (on its one source), with no file behind it to follow."""
    cell = demo_cell()
    return dataclasses.replace(cell, path=None, robots=(*cell.robots, *robots))


FIXED_PORTS_FROM = 20000
"""Well above the ports services register (redis 6379, 8080, ...)."""


def _outside_ephemeral() -> range:
    """Ports the kernel never picks on its own: below its ephemeral range (32768 to 60999 by
    default), or above it where a system starts the range lower."""
    try:
        low, high = map(int, Path("/proc/sys/net/ipv4/ip_local_port_range").read_text().split())
    except (OSError, ValueError):
        low, high = 32768, 60999
    if low - FIXED_PORTS_FROM >= 1000:
        return range(FIXED_PORTS_FROM, low)
    return range(high + 1, 65536) if 65535 - high >= 1000 else range(FIXED_PORTS_FROM, 65536)


_PORTS = _outside_ephemeral()
_handed_out: set[int] = set()


def free_port() -> int:
    """A TCP port on 127.0.0.1 that nothing listens on now, for a server a test starts later.

    Drawn outside the kernel's ephemeral range: a port from that range (``bind`` to port 0)
    may be taken, between this call and the server's bind, by any socket another process
    binds to port 0 or connects out from. CI saw it: an embedded mock of a cluster worker
    got a replica's port, and the replica's health check was answered by the mock.
    """
    while True:
        port = random.choice(_PORTS)
        if port in _handed_out:
            continue
        with socket.socket() as sock:
            try:
                sock.bind(("127.0.0.1", port))
            except OSError:
                continue
        _handed_out.add(port)
        return port


@asynccontextmanager
async def running_mock(
    app: web.Application | None = None,
) -> AsyncIterator[tuple[web.Application, str]]:
    """A mock ctrlX data layer (default: ``build_app()``) on a free loopback port."""
    app = app if app is not None else build_app()
    runner, url = await serve(app, "127.0.0.1", 0)
    try:
        yield app, url
    finally:
        await runner.cleanup()


@asynccontextmanager
async def running_server(settings: Settings, cell: Cell | None = None) -> AsyncIterator[str]:
    """linkview served by uvicorn on a free loopback port; yields its http base URL."""
    port = free_port()
    config = server_config(
        create_app(settings, cell), "127.0.0.1", port, lifespan="on", timeout_graceful_shutdown=2
    )
    server = uvicorn.Server(config)
    task = asyncio.create_task(server.serve())
    try:
        async with asyncio.timeout(10):
            while not server.started:
                await asyncio.sleep(0.02)
        yield f"http://127.0.0.1:{port}"
    finally:
        server.should_exit = True
        await asyncio.wait_for(task, 10)


async def wait_until(predicate: Callable[[], bool], timeout_s: float = 10.0) -> None:
    """Poll ``predicate`` until it holds; fails the test after ``timeout_s``."""
    async with asyncio.timeout(timeout_s):
        while not predicate():
            await asyncio.sleep(0.02)
