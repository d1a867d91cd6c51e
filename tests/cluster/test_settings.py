"""The broker's URL is checked once, with one clear line; a worker needs one."""

from __future__ import annotations

from pathlib import Path

import pytest
from pydantic import ValidationError

from server.config import Settings
from tests.test_cli import run_server


@pytest.mark.parametrize(
    ("url", "says"),
    [
        ("http://127.0.0.1:6379/0", "use redis://HOST:PORT/DB"),
        ("redis://:s3cret@127.0.0.1:6379/0", "LINKVIEW_BROKER_PASSWORD"),
        ("redis://127.0.0.1:99999/0", "invalid port"),
        ("redis://127.0.0.1:6379/cache", "database number"),
    ],
)
def test_unusable_broker_urls_are_refused(url: str, says: str) -> None:
    with pytest.raises(ValidationError, match=says):
        Settings(broker=url)


def test_a_usable_broker_url_is_kept() -> None:
    assert Settings(broker=" redis://redis:6379/0 ").broker == "redis://redis:6379/0"
    assert Settings().broker is None  # one process does everything, as before


def test_a_worker_without_a_broker_says_what_it_needs() -> None:
    result = run_server("acquire")
    assert result.returncode == 2 and "Traceback" not in result.stderr
    assert "--broker" in result.stderr
    result = run_server("acquire", "--broker", "http://127.0.0.1:6379/0")
    assert result.returncode == 2 and "use redis://HOST:PORT/DB" in result.stderr


def test_a_password_in_the_broker_url_is_refused_without_echoing_it() -> None:
    result = run_server("--broker", "redis://:s3cret@127.0.0.1:6379/0")
    assert result.returncode == 2 and "LINKVIEW_BROKER_PASSWORD" in result.stderr
    assert "s3cret" not in result.stderr


def test_the_look_back_is_refused_with_a_broker(tmp_path: Path) -> None:
    with pytest.raises(ValidationError, match="--record, --foxglove run in one process"):
        Settings(broker="redis://redis:6379/0", record=tmp_path, foxglove_port=8765)
    assert Settings(record=tmp_path).record == tmp_path  # one process: as before
