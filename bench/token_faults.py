"""Logins per minute while the device's tokens (or its login) misbehave.

Runs the whole acquisition (``Runtime.start`` of the demo cell: client, follow(), acquisition
with its retries) against the fake device of tests/ctrlx/fake_device.py, one
token fault at a time, and counts what reached the device: login attempts,
tokens issued, event streams opened, and frames per second per robot. A
controller whose clock was behind ours once caused 750 logins a second; the
table shows what each fault costs now.

Usage: ``python bench/token_faults.py [--seconds 10] [--quick]``; writes docs/benchmarks.md except
in quick runs.
"""

from __future__ import annotations

import argparse
import asyncio
import logging
import sys
import time
from dataclasses import dataclass
from pathlib import Path

from pydantic import SecretStr

ROOT = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(Path(__file__).resolve().parent))
sys.path.insert(0, str(ROOT))
from _report import markdown_table, publish  # noqa: E402

from server.config import Settings  # noqa: E402
from server.runtime import Runtime  # noqa: E402
from server.runtime.startup import configured_cell, source_defaults  # noqa: E402
from tests.ctrlx.fake_device import Behaviour, FakeDevice, serving  # noqa: E402


@dataclass(frozen=True)
class Fault:
    name: str
    behaviour: Behaviour
    wrong_password: bool = False


FAULTS = [
    Fault("none (1 h tokens)", Behaviour()),
    Fault("expired on arrival (device clock 1 h behind)", Behaviour(clock_offset_s=-3600.0)),
    Fault("exp far in the past, device rejects them", Behaviour(exp=1000.0)),
    Fault("exp far in the past, device accepts them", Behaviour(exp=1000.0, check_exp=False)),
    Fault("no exp", Behaviour(lifetime_s=None)),
    Fault("tiny lifetime (1 s)", Behaviour(lifetime_s=1.0)),
    Fault("tiny lifetime (0.05 s)", Behaviour(lifetime_s=0.05)),
    Fault("login answers 500", Behaviour(login="500")),
    Fault("wrong password", Behaviour(), wrong_password=True),
]


@dataclass(frozen=True)
class Result:
    fault: str
    attempts_per_min: float
    logins_per_min: float
    streams_per_min: float
    frames_per_s: float
    state: str
    note: str


async def measure(fault: Fault, seconds: float) -> Result:
    device = FakeDevice()
    device.behaviour = fault.behaviour
    async with serving(device) as url:
        password = "not-the-password" if fault.wrong_password else device.password
        settings = Settings(
            ctrlx_url=url,
            ctrlx_user=device.user,
            ctrlx_password=SecretStr(password),
            keepalive_s=0.5,
            request_timeout_s=2.0,
        )
        runtime = await Runtime.start(configured_cell(settings), source_defaults(settings))
        start = time.monotonic()
        try:
            await asyncio.sleep(seconds)
        finally:
            elapsed = time.monotonic() - start
            health = runtime.healths()[0]
            frames = min((r.frames for r in health.robots.values()), default=0)
            await runtime.stop()
    per_min = 60.0 / elapsed
    note = health.error or health.warning or ""
    return Result(
        fault=fault.name,
        attempts_per_min=device.counts.login_attempts * per_min,
        logins_per_min=device.counts.logins * per_min,
        streams_per_min=device.counts.stream_opens * per_min,
        frames_per_s=frames / elapsed,
        state=health.state,
        note=note if len(note) <= 70 else note[:67] + "...",
    )


def table(results: list[Result]) -> str:
    header = [
        "token fault",
        "login attempts/min",
        "tokens issued/min",
        "streams opened/min",
        "frames/s per robot",
        "state",
        "error or warning shown",
    ]
    rows = [
        [
            r.fault,
            f"{r.attempts_per_min:.0f}",
            f"{r.logins_per_min:.0f}",
            f"{r.streams_per_min:.0f}",
            f"{r.frames_per_s:.0f}",
            r.state,
            r.note.replace("|", "/"),
        ]
        for r in results
    ]
    return markdown_table(header, rows)


async def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__)
    parser.add_argument("--seconds", type=float, default=10.0, help="time per fault")
    parser.add_argument(
        "--quick", action="store_true", help="the first three faults, 2 s each; no docs update"
    )
    args = parser.parse_args()
    faults = FAULTS[:3] if args.quick else FAULTS
    if args.quick:
        args.seconds = 2.0
    logging.disable(logging.CRITICAL)  # the faults are the point; their log lines are not
    results = []
    for fault in faults:
        results.append(await measure(fault, args.seconds))
        print(f"{fault.name}: done", file=sys.stderr, flush=True)
    text = table(results)
    body = (
        f"{args.seconds:g} s per fault, demo cell (3 robots, 11 nodes), subscribe mode at "
        "50 Hz, 0.5 s keepalive. Logins after failures are spaced 1 to 1.5 s apart; a token's "
        "renewal is planned from its lifetime (exp - iat) on our monotonic clock.\n\n" + text
    )
    publish("bench/token_faults.py", "Token faults: logins per minute", body, quick=args.quick)


if __name__ == "__main__":
    asyncio.run(main())
