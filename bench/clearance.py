"""What the clearance check costs: CPU per check of the demo cell, and the closest approach.

The demo cell's robots are moved as the embedded mock moves them (its demo
cycle, sampled every 0.1 s over ``--seconds`` of simulated time), and each
pose set is measured as the server does ten times a second (``ClearanceService``:
poses from the kinematics, then python-fcl on each link's convex hull). CPU time
is process time, so other work on a shared machine distorts it less than wall
time. A second row puts the positioner back where the demo cell had it before
(0.85 m from the arm), where the arm's wrist went through its table.

Usage: ``python bench/clearance.py [--quick]``; writes docs/benchmarks.md.
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

from server.cell import Cell, load_cell  # noqa: E402
from server.clearance import ClearanceService  # noqa: E402
from server.mock_ctrlx.machine import Machine  # noqa: E402
from server.paths import DEMO_CELL  # noqa: E402
from server.stream import Hub  # noqa: E402

WITHIN_M = 0.05
PERIOD_S = 0.1


def run(cell: Cell, seconds: float) -> tuple[list[float], float, str]:
    """CPU seconds per check, the closest approach (m) and the pair that made it."""
    machine = Machine(clock=lambda: 0.0)
    service = ClearanceService(Hub(), within_m=10.0)  # every pair measured, however far
    service.measure(cell.robots, {})  # reads the meshes: not part of a check
    axes = {
        r.name: [next(a for a in machine.axes if f"/{a}/" in node) for node in r.nodes]
        for r in cell.robots
    }
    costs, closest, pair = [], np.inf, ""
    for t in np.arange(0.0, seconds, PERIOD_S):
        snapshot = machine.snapshot(float(t))
        values = {name: np.array([snapshot[a] for a in names]) for name, names in axes.items()}
        start = time.process_time()
        result = service.measure(cell.robots, values)
        costs.append(time.process_time() - start)
        for near in result.near:
            if near.distance_m < closest:
                closest = near.distance_m
                named = zip(near.robots, near.link_names, strict=True)
                pair = " and ".join(f"{robot} {link}" for robot, link in named)
    return costs, closest, pair


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--quick", action="store_true", help="30 s of motion; no docs update")
    parser.add_argument("--seconds", type=float, default=300.0, help="simulated seconds")
    args = parser.parse_args()
    seconds = 30.0 if args.quick else args.seconds
    load = os.getloadavg()[0]
    demo = load_cell(DEMO_CELL)
    before = dataclasses.replace(
        demo,
        robots=tuple(
            dataclasses.replace(r, base=(0.85, 0.0, 0.0, 0.0, 0.0, 0.0, 1.0))
            if r.name == "positioner"
            else r
            for r in demo.robots
        ),
    )
    rows = []
    for name, cell in (("demo cell", demo), ("positioner at 0.85 m (before)", before)):
        costs, closest, pair = run(cell, seconds)
        median_ms = statistics.median(costs) * 1000
        rows.append(
            [
                name,
                f"{median_ms:.2f}",
                f"{max(costs) * 1000:.2f}",
                f"{median_ms / (PERIOD_S * 1000) * 100:.1f}%",
                f"{closest * 1000:.0f} mm" if closest > 0 else "touching",
                pair,
            ]
        )
    header = [
        "cell",
        "CPU ms per check (median)",
        "(max)",
        "CPU at 10 Hz (one core)",
        "closest approach",
        "between",
    ]
    body = (
        markdown_table(header, rows)
        + f"\n\n{len(costs)} checks over {seconds:.0f} s of the embedded mock's demo cycle "
        f"(every 0.1 s), 3 robots, 15 links, every robot pair measured. CPU is process time. "
        f"Load average {load:.1f} at the start."
    )
    if args.quick:
        print(body)
        return
    publish("bench/clearance.py", "Clearance between robots", body)


if __name__ == "__main__":
    main()
