"""The command line refuses bad settings with a readable message, not a traceback."""

from __future__ import annotations

import subprocess
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent


def run_server(*args: str) -> subprocess.CompletedProcess[str]:
    return subprocess.run(
        [sys.executable, "-m", "server", *args],
        cwd=ROOT,
        text=True,
        capture_output=True,
        timeout=30,
    )


def test_credentials_in_the_controller_url_are_refused() -> None:
    result = run_server("--ctrlx", "https://admin:hunter2@192.0.2.1")
    assert result.returncode == 2
    assert "LINKVIEW_CTRLX_USER" in result.stderr
    assert "Traceback" not in result.stderr


def test_bad_port_is_refused() -> None:
    result = run_server("--port", "70000")
    assert result.returncode == 2 and "port" in result.stderr
    assert "Traceback" not in result.stderr
