"""The ur_rtde package (PyPI), an independent RTDE client, accepts the mock UR controller."""

from __future__ import annotations

import asyncio
import json
import random
import socket
import sys
from collections.abc import AsyncIterator
from pathlib import Path

import pytest

from server.mock_ctrlx import Machine
from server.mock_rtde import POSITIONER_REGISTERS, RtdeMock, demo_groups
from server.rtde import PORT

READER = Path(__file__).parent / "ur_rtde_reader.py"


def free_loopback_address() -> str:
    """A 127.x.y.z address whose port 30004 is free (ur_rtde cannot be told another port)."""
    for _ in range(100):
        host = f"127.{random.randint(1, 254)}.{random.randint(0, 254)}.{random.randint(2, 254)}"
        with socket.socket() as sock:
            try:
                sock.bind((host, PORT))
            except OSError:
                continue
            return host
    raise RuntimeError(f"no loopback address with port {PORT} free")


@pytest.fixture
async def mock() -> AsyncIterator[RtdeMock]:
    controller = RtdeMock(Machine(demo_groups()))
    await controller.start(free_loopback_address(), PORT)
    try:
        yield controller
    finally:
        await controller.close()


async def read_with_ur_rtde(host: str, seconds: float) -> list[list[object]]:
    process = await asyncio.create_subprocess_exec(
        sys.executable,
        str(READER),
        host,
        str(seconds),
        *map(str, POSITIONER_REGISTERS),
        stdout=asyncio.subprocess.PIPE,
        stderr=asyncio.subprocess.PIPE,
    )
    try:
        out, err = await asyncio.wait_for(process.communicate(), 30.0)
    finally:
        if process.returncode is None:
            process.kill()
            await process.wait()
    assert process.returncode == 0, err.decode()[-2000:]
    readings: list[list[object]] = json.loads(out.decode().strip().splitlines()[-1])
    return readings


async def test_ur_rtde_reads_actual_q_and_the_positioner_registers_of_the_mock(
    mock: RtdeMock,
) -> None:
    readings = await read_with_ur_rtde(mock.host, 1.0)
    stamps = sorted({float(r[0]) for r in readings})
    assert len(stamps) > 10
    # The machine at every package instant of the run (the controller's 2 ms ticks).
    ticks = [stamps[0] + 0.002 * k for k in range(round((stamps[-1] - stamps[0]) / 0.002) + 50)]
    at = {round(t, 6): mock.machine.snapshot(mock.boot_s + round(t, 9)) for t in ticks}
    for stamp, q, tilt, turn in readings:
        assert isinstance(stamp, float) and isinstance(q, list)
        # What ur_rtde read is the simulated machine at a package's controller time. Its
        # getters are called one after the other while its thread reads on: a value may be
        # of a package newer than the timestamp read before it, never an older one.
        later = [m for t, m in at.items() if t >= round(stamp, 6)]
        arm = [[m[f"ur5e_q{i}"] for i in range(6)] for m in later]
        assert any(q == pytest.approx(joints, abs=1e-12) for joints in arm)
        assert any(tilt == pytest.approx(m["positioner_tilt"], abs=1e-12) for m in later)
        assert any(turn == pytest.approx(m["positioner_turn"], abs=1e-12) for m in later)
    # It asked for 500 Hz (an e-Series version) and got the controller's 2 ms packages.
    steps = {round((b - a) / 0.002) for a, b in zip(stamps, stamps[1:], strict=False)}
    assert 1 in steps
    assert all(abs(t / 0.002 - round(t / 0.002)) < 1e-6 for t in stamps)
