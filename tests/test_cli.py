"""The command line refuses bad settings with a readable message, not a traceback."""

from __future__ import annotations

import os
import socket
import subprocess
import sys
from pathlib import Path
from urllib.parse import urlsplit

import pytest

from server.web.listen import browser_urls
from tests.conftest import free_port

ROOT = Path(__file__).resolve().parent.parent


def run_server(*args: str, env: dict[str, str] | None = None) -> subprocess.CompletedProcess[str]:
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
    assert lines[0] == (
        f"{cell}: source[0] \"a\".url: controller URL 'ftp://plc': scheme 'ftp' is not http "
        "or https"
    )
    assert lines[1].startswith(f'{cell}: source[0] "a".ca: ') and "x.pem" in lines[1]


def test_binding_beyond_loopback_without_a_token_warns(
    monkeypatch: pytest.MonkeyPatch, caplog: pytest.LogCaptureFixture
) -> None:
    from server import __main__ as cli

    class Bound:  # what listen() would have bound, without binding beyond loopback in a test
        def getsockname(self) -> tuple[str, int]:
            return ("0.0.0.0", 8000)

    monkeypatch.setattr(cli, "listen", lambda host, port: [Bound()])
    monkeypatch.setattr(cli.AnnouncingServer, "run", lambda self, sockets: None)
    main = cli.main
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


def start_server(*args: str, env: dict[str, str] | None = None) -> subprocess.Popen[str]:
    """``python -m server ARGS`` as a process, its output in one pipe."""
    return subprocess.Popen(
        [sys.executable, "-m", "server", *args],
        cwd=ROOT,
        env=None if env is None else {**os.environ, **env},
        stdout=subprocess.PIPE,
        stderr=subprocess.STDOUT,
        text=True,
    )


def lines_until(proc: subprocess.Popen[str], start: str) -> list[str]:
    """Output lines up to the first that starts with ``start`` (the test fails if none comes)."""
    assert proc.stdout is not None
    seen: list[str] = []
    for line in proc.stdout:
        seen.append(line.rstrip("\n"))
        if line.startswith(start):
            return seen
    raise AssertionError(f"no line starting with {start!r}: {seen}")


def stop(proc: subprocess.Popen[str]) -> None:
    proc.terminate()
    proc.wait(30)
    if proc.stdout is not None:
        proc.stdout.close()


def test_the_open_line_comes_once_the_port_is_bound() -> None:
    port = free_port()
    proc = start_server("--port", str(port))
    try:
        lines = lines_until(proc, "linkview: open ")
        # At once, no retry: whoever follows the line must find this server, not nothing.
        with socket.create_connection(("127.0.0.1", port), timeout=10):
            pass
        assert lines[-1].startswith(f"linkview: open http://127.0.0.1:{port}/ ")
        assert "data from demo (embedded mock)" in lines[-1]
    finally:
        stop(proc)


def test_a_taken_port_is_one_clear_line_and_no_controller_is_contacted() -> None:
    with socket.socket() as taken:
        taken.bind(("127.0.0.1", 0))
        taken.listen()
        port = taken.getsockname()[1]
        result = run_server("--port", str(port))
    assert result.returncode == 1
    assert result.stdout == ""
    assert result.stderr.splitlines() == [
        f"linkview: cannot listen on 127.0.0.1:{port}: address already in use; another "
        "program, perhaps another linkview, listens there; choose another port with --port"
    ]


def test_bound_to_every_interface_the_addresses_are_this_machines_own() -> None:
    for host, loopback in (("0.0.0.0", "127.0.0.1"), ("::", "[::1]")):
        urls = browser_urls(host, 8003)
        assert urls[0] == f"http://{loopback}:8003/"
        for url in urls[1:]:
            address = urlsplit(url).hostname
            assert address is not None and address != host, urls
            family = socket.AF_INET6 if ":" in address else socket.AF_INET
            with socket.socket(family) as probe:  # only this machine's own addresses bind
                probe.bind((address, 0))
    assert browser_urls("127.0.0.1", 8003) == ["http://127.0.0.1:8003/"]
    assert browser_urls("::1", 8003) == ["http://[::1]:8003/"]


def test_the_default_controller_password_is_said_when_used() -> None:
    port = free_port()
    warned = "with the default password"
    for env, says in (({}, True), ({"LINKVIEW_CTRLX_PASSWORD": "other"}, False)):
        proc = start_server(
            "--port", str(port), "--ctrlx", "http://127.0.0.1:9", env=env
        )  # fmt: skip
        try:
            lines = lines_until(proc, "linkview: open ")
        finally:
            stop(proc)
        said = [line for line in lines if warned in line]
        assert bool(said) == says, lines
        if says:
            assert "as boschrexroth" in said[0] and "LINKVIEW_CTRLX_PASSWORD" in said[0]
