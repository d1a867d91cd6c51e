"""The Dockerfile's entry command, run directly (no Docker engine on these machines)."""

from __future__ import annotations

import json
import os
import re
import subprocess
import sys
import time
import urllib.request
from pathlib import Path

from tests.conftest import free_port

ROOT = Path(__file__).resolve().parent.parent


def dockerfile_cmd_and_env() -> tuple[list[str], dict[str, str]]:
    text = (ROOT / "Dockerfile").read_text()
    cmd = json.loads(re.search(r"^CMD (\[.*\])$", text, re.M).group(1))  # type: ignore[union-attr]
    env_block = re.search(r"^ENV (.*?)(?:\n(?!\s)|\Z)", text, re.M | re.S).group(1)  # type: ignore[union-attr]
    env = dict(re.findall(r"(\w+)=(\S+)", env_block.replace("\\\n", " ")))
    return cmd, env


def healthcheck_cmd() -> list[str]:
    text = (ROOT / "Dockerfile").read_text()
    match = re.search(r"^HEALTHCHECK .*?CMD (\[.*\])$", text, re.M)
    assert match, "the Dockerfile needs a HEALTHCHECK"
    cmd: list[str] = json.loads(match.group(1))
    return cmd


def test_dockerfile_copies_everything_the_server_reads() -> None:
    text = (ROOT / "Dockerfile").read_text()
    for folder in ("server", "static", "assets", "cells"):
        assert re.search(rf"^COPY {folder} \./{folder}$", text, re.M), folder


def test_dockerfile_entry_command_serves_health() -> None:
    cmd, env = dockerfile_cmd_and_env()
    assert cmd[:3] == ["python", "-m", "server"]
    assert env["LINKVIEW_HOST"] == "0.0.0.0"
    port = free_port()
    # Same command and variables, but bound to loopback only, as tests must be.
    run_env = {**os.environ, **env, "LINKVIEW_HOST": "127.0.0.1", "LINKVIEW_PORT": str(port)}
    check = [sys.executable, *healthcheck_cmd()[1:]]
    before = subprocess.run(check, cwd=ROOT, env=run_env, capture_output=True, timeout=30)
    assert before.returncode == 1, "no server yet: the health check must fail"
    proc = subprocess.Popen(
        [sys.executable, *cmd[1:]],
        cwd=ROOT,
        env=run_env,
        stdout=subprocess.PIPE,
        stderr=subprocess.STDOUT,
    )
    try:
        deadline = time.monotonic() + 30
        while True:
            try:
                with urllib.request.urlopen(f"http://127.0.0.1:{port}/api/health", timeout=2) as r:
                    health = json.load(r)
                    if health["sources"][0]["state"] == "connected":
                        break
            except OSError:
                pass
            assert proc.poll() is None, proc.stdout.read().decode()  # type: ignore[union-attr]
            assert time.monotonic() < deadline, "server did not become healthy"
            time.sleep(0.2)
        assert health["status"] == "ok"
        after = subprocess.run(check, cwd=ROOT, env=run_env, capture_output=True, timeout=30)
        assert after.returncode == 0, after.stderr
    finally:
        proc.terminate()
        proc.wait(10)
        if proc.stdout:
            proc.stdout.close()


def instructions() -> list[str]:
    """The Dockerfile's instructions, continuation lines joined, comments left out."""
    text = (ROOT / "Dockerfile").read_text().replace("\\\n", " ")
    return [line for line in text.splitlines() if line and not line.startswith("#")]


def test_the_image_runs_as_an_unprivileged_user_it_creates() -> None:
    steps = instructions()
    users = [i for i, step in enumerate(steps) if step.startswith("USER ")]
    assert users, "without USER the server runs as root"
    at = users[-1]
    user = steps[at].split()[1].split(":")[0]
    assert user not in ("root", "0"), steps[at]
    adds = [re.search(rf"\buseradd ([^&;]*\b{user})\b", s) for s in steps[:at] if "RUN " in s]
    (created,) = [m.group(1).split() for m in adds if m]  # created once, before USER
    assert "0" not in created and "-o" not in created and "--non-unique" not in created
    cmd = next(i for i, step in enumerate(steps) if step.startswith("CMD "))
    healthcheck = next(i for i, step in enumerate(steps) if step.startswith("HEALTHCHECK "))
    assert at < cmd and at < healthcheck, "the server and its health check run as that user"
