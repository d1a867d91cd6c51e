"""The command line refuses bad settings with a readable message, not a traceback."""

from __future__ import annotations

import os
import subprocess
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parent.parent


def run_server(
    *args: str, env: dict[str, str] | None = None
) -> subprocess.CompletedProcess[str]:
    """``python -m server ARGS`` from the repository root (``env`` added), its output captured."""
    return subprocess.run(
        [sys.executable, "-m", "server", *args],
        cwd=ROOT,
        env=None if env is None else {**os.environ, **env},
        text=True,
        capture_output=True,
        timeout=60,
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


def test_a_url_without_scheme_is_one_clear_line() -> None:
    result = run_server("--ctrlx", "192.168.1.1")
    assert result.returncode == 2 and "Traceback" not in result.stderr
    (line,) = [line for line in result.stderr.splitlines() if "error" in line]
    assert "needs a scheme and a host, e.g. https://192.168.1.1" in line


def test_a_missing_ca_file_is_one_clear_line(tmp_path: Path) -> None:
    result = run_server("--ctrlx", "https://192.0.2.1", "--ctrlx-ca", str(tmp_path / "nope.pem"))
    assert result.returncode == 2 and "Traceback" not in result.stderr
    (line,) = [line for line in result.stderr.splitlines() if "error" in line]
    assert "nope.pem" in line


def test_cell_sources_get_the_same_checks(tmp_path: Path) -> None:
    cell = tmp_path / "cell.toml"
    cell.write_text(
        '[[source]]\nname = "a"\nurl = "ftp://plc"\npassword_env = "HOME"\nca = "x.pem"\n'
        '[[robot]]\nname = "r"\nsource = "a"\nkinematics = { type = "type12" }\n'
        'joints = [ { node = "x" }, { node = "y" } ]\n'
    )
    result = run_server("check", str(cell))
    assert result.returncode == 1 and "Traceback" not in result.stderr
    lines = result.stderr.splitlines()
    assert (
        lines[0]
        == f"{cell}: source[0].url: controller URL 'ftp://plc': scheme 'ftp' is not http or https"
    )
    assert lines[1].startswith(f"{cell}: source[0].ca: ") and "x.pem" in lines[1]


def test_binding_beyond_loopback_without_a_token_warns(
    monkeypatch: pytest.MonkeyPatch, caplog: pytest.LogCaptureFixture
) -> None:
    import uvicorn

    from server.__main__ import main

    monkeypatch.setattr(uvicorn.Server, "run", lambda self: None)  # configure, never listen
    for host, token, warned in (("0.0.0.0", None, True), ("0.0.0.0", "s3cret", False),
                                ("127.0.0.1", None, False)):  # fmt: skip
        caplog.clear()
        if token:
            monkeypatch.setenv("LINKVIEW_VIEWER_TOKEN", token)
        else:
            monkeypatch.delenv("LINKVIEW_VIEWER_TOKEN", raising=False)
        main(["--host", host, "--port", "8000"])
        warning = [
            r.getMessage() for r in caplog.records if "without a viewer token" in r.getMessage()
        ]
        assert bool(warning) == warned, (host, token, warning)
        if warned:
            assert "anyone who can reach port 8000 can watch" in warning[0]
