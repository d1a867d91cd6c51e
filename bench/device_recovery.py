"""Seconds from a broken device behaving again to linkview streaming again.

Runs the whole server (uvicorn, acquisition, client) against the fake device of
tests/ctrlx/fake_device.py with one fault at a time, waits until the fault shows
in ``/api/health``, heals the device and times the way back to every robot
streaming. tests/ctrlx/test_hostile_device.py asserts only a generous bound
(10 s); the design aims at 2 s (the acquisition retries within 1.5 s, logins
within 1.5 s).

Usage: ``python bench/device_recovery.py [--rounds 5] [--quick]``; writes docs/benchmarks.md
except in quick runs.
"""

from __future__ import annotations

import argparse
import asyncio
import logging
import os
import statistics
import sys
import time
from collections.abc import Callable
from pathlib import Path
from typing import Any

ROOT = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(Path(__file__).resolve().parent))
sys.path.insert(0, str(ROOT))
from _report import markdown_table, publish  # noqa: E402

from tests.ctrlx.fake_device import Behaviour, FakeDevice  # noqa: E402
from tests.ctrlx.test_hostile_device import (  # noqa: E402
    SHOW_S,
    Health,
    failed_with,
    linkview,
    streaming,
)

FAULTS: list[tuple[str, Behaviour, Callable[[Health], bool], dict[str, Any]]] = [
    ("login answers 500", Behaviour(login="500"), failed_with("500"), {}),
    ("HTML pages instead of JSON", Behaviour(html=True), failed_with("text/html"), {}),
    ("event stream reset", Behaviour(events="reset"), failed_with("event stream"), {}),
    ("endless event line", Behaviour(events="endless_line"), failed_with("64 KiB"), {}),
    (
        "endless bulk answer",
        Behaviour(bulk="endless"),
        failed_with("4 MiB"),
        {"ctrlx_mode": "poll"},
    ),
]


async def recovery_s(fault: Behaviour, shows: Callable[[Health], bool], **settings: Any) -> float:
    """Seconds from ``device.heal()`` to every robot streaming again."""
    device = FakeDevice()
    device.behaviour = fault
    async with linkview(device, **settings) as lv:
        await lv.until(shows, timeout_s=SHOW_S)
        device.heal()
        healed = time.monotonic()
        await lv.until(streaming, timeout_s=60.0)
        return time.monotonic() - healed


async def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__)
    parser.add_argument("--rounds", type=int, default=5, help="runs per fault")
    parser.add_argument("--quick", action="store_true", help="one run per fault; no docs update")
    args = parser.parse_args()
    rounds = 1 if args.quick else args.rounds
    logging.disable(logging.WARNING)  # the faults are the point; their errors are expected
    rows = []
    for name, fault, shows, settings in FAULTS:
        times = [await recovery_s(fault, shows, **settings) for _ in range(rounds)]
        rows.append([name, f"{statistics.median(times):.2f}", f"{max(times):.2f}"])
        print(rows[-1], flush=True)
    load = ", ".join(f"{x:.1f}" for x in os.getloadavg())
    body = (
        f"Median and worst of {rounds} runs per fault, 0.2 s keepalive, 1 s request timeout; "
        f"load average {load}.\n\n"
        + markdown_table(["fault", "back to streaming (s)", "worst (s)"], rows)
    )
    publish(
        "bench/device_recovery.py", "Broken devices: time back to streaming", body, quick=args.quick
    )


if __name__ == "__main__":
    asyncio.run(main())
