"""Cell folders whose xacro file attacks the server, and ``python -m server check`` on them.

Each cell is a one-joint arm on an embedded mock; the attack is one more line
of its xacro file. The secrets are set in the environment of ``check`` (and of
the server), as a deployment sets its controller password and viewer token.
"""

from __future__ import annotations

import asyncio
import os
import secrets
import subprocess
import sys
from collections.abc import AsyncIterator
from contextlib import asynccontextmanager
from pathlib import Path

from tests.test_cli import ROOT

ARM = """<?xml version="1.0"?>
<robot name="arm" xmlns:xacro="http://www.ros.org/wiki/xacro">
  <link name="base"/>
  <link name="tool"/>
  <joint name="j1" type="revolute">
    <parent link="base"/><child link="tool"/>
    <origin xyz="0 0 0.3"/><axis xyz="0 0 1"/>
    <limit lower="-3" upper="3" effort="1" velocity="1"/>
  </joint>
{attack}
</robot>
"""

CELL = """[[source]]
name = "mock"

[[robot]]
name = "arm"
source = "mock"
kinematics = {{ type = "urdf", file = "arm.urdf.xacro"{extra} }}
joints = [ {{ node = "motion/axs/Axis_1/state/values/actual/pos", unit = "rad" }} ]
"""


def secret_env() -> dict[str, str]:
    """linkview's secrets as a deployment sets them, each a fresh random value."""
    return {
        "LINKVIEW_CTRLX_PASSWORD": "pw-" + secrets.token_hex(8),
        "LINKVIEW_VIEWER_TOKEN": "tok-" + secrets.token_hex(8),
    }


def hostile_cell(folder: Path, attack: str, extra: str = "") -> Path:
    """A cell folder whose arm's xacro file holds ``attack``; the cell file's path."""
    folder.mkdir(parents=True, exist_ok=True)
    (folder / "arm.urdf.xacro").write_text(ARM.format(attack=attack))
    cell = folder / "cell.toml"
    cell.write_text(CELL.format(extra=extra))
    return cell


def check(
    cell: Path, env: dict[str, str], timeout_s: float = 120.0
) -> subprocess.CompletedProcess[str]:
    """``python -m server check CELL`` with ``env`` added to the environment."""
    return subprocess.run(
        [sys.executable, "-m", "server", "check", str(cell)],
        cwd=ROOT,
        env={**os.environ, **env},
        text=True,
        capture_output=True,
        timeout=timeout_s,
    )


@asynccontextmanager
async def serving(
    cell: Path, port: int, log: Path, env: dict[str, str]
) -> AsyncIterator[subprocess.Popen[bytes]]:
    """``python -m server --cell CELL --port PORT`` (``env`` added, output to ``log``).

    Stopped at the end with SIGTERM (killed if still running 15 s later), unless
    the block stopped it.
    """
    with open(log, "wb") as out:
        proc = subprocess.Popen(
            [sys.executable, "-m", "server", "--cell", str(cell), "--port", str(port)],
            cwd=ROOT,
            env={**os.environ, "PYTHONPATH": str(ROOT), **env},
            stdout=out,
            stderr=subprocess.STDOUT,
        )
    try:
        yield proc
    finally:
        proc.terminate()
        try:
            await asyncio.to_thread(proc.wait, 15)
        except subprocess.TimeoutExpired:
            proc.kill()
            await asyncio.to_thread(proc.wait)
