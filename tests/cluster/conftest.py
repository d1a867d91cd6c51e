"""Fixtures of the cluster tests: a real redis-server, a cell file, and the roles to start.

Every process a test starts is killed when the test ends, whatever happened;
every file (Redis's folder, logs, cells) is under the test's ``tmp_path``.
"""

from __future__ import annotations

from collections.abc import Iterator
from pathlib import Path

import pytest

from tests.cluster._roles import Cluster, RedisServer, cell_text
from tests.conftest import free_port


@pytest.fixture
def redis_server(tmp_path: Path) -> Iterator[RedisServer]:
    """A running redis-server on a free loopback port."""
    server = RedisServer(tmp_path / "redis", free_port())
    server.start()
    try:
        yield server
    finally:
        server.stop()


@pytest.fixture
def cell_file(tmp_path: Path) -> Path:
    """Four sources (embedded mocks), one Type 12 mechanism on each."""
    path = tmp_path / "cell" / "cell.toml"  # a folder of its own: every role watches it
    path.parent.mkdir()
    path.write_text(cell_text(4))
    return path


@pytest.fixture
def cluster(tmp_path: Path, redis_server: RedisServer, cell_file: Path) -> Iterator[Cluster]:
    """Roles to start against ``redis_server`` and ``cell_file``; all killed at the end."""
    roles = Cluster(tmp_path, redis_server.url, cell_file)
    try:
        yield roles
    finally:
        roles.close()
