"""What a setpoint ghost costs the server: CPU per sample and bytes on the wire, per robot.

For each robot of the demo cell, one sample is turned into a frame and its
protocol-2 bytes (``compute_frame`` + ``encode_binary``, what the acquisition
does per robot and sample), once as it is and once with setpoint nodes (the
actual and setpoint poses computed as a batch of two). CPU time is process
time (``time.process_time``), the median of several repeats of many samples,
so other processes on a shared machine distort it less than wall time.

Usage: ``python bench/setpoints.py [--quick]``; writes docs/benchmarks.md except in quick runs.
"""

from __future__ import annotations

import argparse
import dataclasses
import os
import statistics
import sys
import time
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))
sys.path.insert(0, str(Path(__file__).resolve().parent.parent))
from _report import markdown_table, publish  # noqa: E402

from server.cell import Robot, load_cell  # noqa: E402
from server.paths import DEMO_CELL  # noqa: E402
from server.stream.frames import compute_frame, encode_binary  # noqa: E402
from server.stream.types import RobotSample  # noqa: E402


def with_setpoints(robot: Robot) -> Robot:
    """``robot`` with a setpoint node beside every joint node."""
    joints = tuple(dataclasses.replace(j, setpoint=f"{j.node}/ipo") for j in robot.joints)
    return dataclasses.replace(robot, joints=joints)


def cpu_us(robot: Robot, sample: RobotSample, number: int, repeats: int) -> float:
    """Median process-CPU microseconds per frame computed and encoded."""
    times = []
    for _ in range(repeats):
        start = time.process_time()
        for _ in range(number):
            encode_binary([(0, compute_frame(robot, sample))], 1, 1.7e9, 1.7e9)
        times.append((time.process_time() - start) / number)
    return 1e6 * statistics.median(times)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--quick", action="store_true", help="fewer samples; no docs update")
    quick = parser.parse_args().quick
    number, repeats = (300, 3) if quick else (3000, 7)
    load = os.getloadavg()[0]
    rows = []
    for robot in load_cell(DEMO_CELL).robots:
        n = len(robot.joints)
        values = np.full(n, 10.0)
        plain = RobotSample(1, 1.7e9, values)
        both = RobotSample(1, 1.7e9, values, setpoints=values + 0.5)
        ghost = with_setpoints(robot)
        assert compute_frame(ghost, both).setpoint is not None
        cost = [cpu_us(robot, plain, number, repeats), cpu_us(ghost, both, number, repeats)]
        size = [
            len(encode_binary([(0, compute_frame(r, s))], 1, 1.7e9, 1.7e9)) - 24
            for r, s in ((robot, plain), (ghost, both))
        ]
        rows.append(
            [
                f"{robot.name} ({robot.family}, {len(robot.link_names)} links)",
                f"{cost[0]:.0f}",
                f"{cost[1]:.0f}",
                f"{cost[1] / cost[0]:.2f}",
                str(size[0]),
                str(size[1]),
            ]
        )
    header = ["robot", "CPU µs, actual only", "CPU µs, with setpoint", "ratio",
              "bytes, actual only", "bytes, with setpoint"]  # fmt: skip
    body = markdown_table(header, rows) + (
        f"\n\nPer robot and sample: compute_frame + encode_binary, median of {repeats} x "
        f"{number} samples; bytes are the robot's part of a protocol-2 message. Load average "
        f"{load:.1f} at the start. A robot without setpoints is unchanged (the first columns)."
    )
    publish("bench/setpoints.py", "Setpoint ghost: cost per robot and sample", body, quick=quick)


if __name__ == "__main__":
    main()
