"""Many mock controllers in one process, for bench/plant.py: one port and one machine each.

Each mock is the real one (``server.mock_ctrlx.build_app``), simulating a
single KUKA LBR iiwa 7 R800 (seven axes) of the demo cycle, phase-shifted so
the controllers do not all move alike. Prints one JSON line with the base
URLs once every mock listens, then runs until stdin closes (the benchmark
ends it that way, or by a signal).

Usage: ``python bench/_mock_farm.py --count N``.
"""

from __future__ import annotations

import argparse
import asyncio
import dataclasses
import json
import os
import sys

sys.path.insert(0, os.path.join(os.path.dirname(os.path.abspath(__file__)), ".."))
from server.mock_ctrlx import Machine, build_app, demo_groups, serve  # noqa: E402

ARM = "iiwa"
"""The demo group every mock simulates."""


def arm_machine(i: int) -> Machine:
    """The demo cycle of the 7-axis arm only; mock ``i`` starts at another target, dwells longer.

    So the arms do not all move alike (the clock stays true: sample times are compared
    with ours).
    """
    group = next(g for g in demo_groups() if g.name == ARM)
    k = i % len(group.targets)
    targets = group.targets[k:] + group.targets[:k]
    return Machine([dataclasses.replace(group, targets=targets, dwell_s=0.3 + 0.013 * i)])


async def run(count: int) -> None:
    runners, urls = [], []
    for i in range(count):
        runner, url = await serve(build_app(arm_machine(i)), "127.0.0.1", 0)
        runners.append(runner)
        urls.append(url)
    print(json.dumps({"pid": os.getpid(), "urls": urls}), flush=True)
    loop = asyncio.get_running_loop()
    try:
        await loop.run_in_executor(None, sys.stdin.read)
    finally:
        for runner in runners:
            await runner.cleanup()


if __name__ == "__main__":
    parser = argparse.ArgumentParser(description=__doc__)
    parser.add_argument("--count", type=int, required=True, help="mock controllers to serve")
    args = parser.parse_args()
    try:
        import uvloop

        uvloop.install()
    except ImportError:
        pass
    asyncio.run(run(args.count))
