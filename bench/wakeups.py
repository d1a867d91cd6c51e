"""What a wake-up of a sleeping thread costs: the reason a flooded event loop is paced.

A thread on CPU 0 sleeps ``every`` and wakes, again and again, for a few
seconds; its CPU time (``time.thread_time``) over the wake-ups counted is the
cost of one. Alone on its core, each wake-up also leaves idle; beside a busy
process (a counting loop on the same core), it does not, and the counting
loop's lost share is the cost to everything else on the core. An event loop
waiting in epoll between chunks of 100 event streams wakes about 2 000 times a
second (bench/plant.py's "loop wake-ups/s"); server/loop_pacing.py makes that
about 500 under such a flood.

Usage: ``python bench/wakeups.py [--seconds 3] [--quick]``; writes docs/benchmarks.md
except in quick runs.
"""

from __future__ import annotations

import argparse
import functools
import os
import select
import statistics
import subprocess
import sys
import time
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent))
from _report import markdown_table, publish  # noqa: E402

CPU = 0
ROUNDS = 3
COUNTER = """
import sys, time
count, end = 0, time.perf_counter() + float(sys.argv[1])
while time.perf_counter() < end:
    count += 1
print(count)
"""


def wake_cost(every_s: float, seconds: float, epoll: bool = False) -> tuple[float, float]:
    """(wake-ups per second, CPU µs per wake-up) of this thread sleeping ``every_s`` at a time."""
    with select.epoll() as poller:  # empty: a poll only waits
        wait = (
            functools.partial(poller.poll, every_s)
            if epoll
            else functools.partial(time.sleep, every_s)
        )
        count, cpu0 = 0, time.thread_time()
        end = time.perf_counter() + seconds
        while time.perf_counter() < end:
            wait()
            count += 1
        cpu = time.thread_time() - cpu0
    return count / seconds, 1e6 * cpu / count


def counted(seconds: float) -> subprocess.Popen[str]:
    """A counting loop on CPU 0 for ``seconds``, started now: the core is never idle."""
    return subprocess.Popen(
        ["taskset", "-c", str(CPU), sys.executable, "-c", COUNTER, str(seconds)],
        stdout=subprocess.PIPE,
        text=True,
    )


def main() -> None:
    """Each case on CPU 0, printed and (unless quick) written to docs/benchmarks.md."""
    parser = argparse.ArgumentParser(description=__doc__)
    parser.add_argument("--seconds", type=float, default=3.0, help="per case")
    parser.add_argument("--quick", action="store_true", help="no docs, 1 s per case")
    args = parser.parse_args()
    seconds = 1.0 if args.quick else args.seconds
    os.sched_setaffinity(0, {CPU})
    load0, rows = os.getloadavg(), []
    cases = [
        ("time.sleep(0.5 ms)", 0.0005, False),
        ("time.sleep(2 ms)", 0.002, False),
        ("epoll wait, 2 ms", 0.002, True),
        ("time.sleep(10 ms)", 0.010, False),
    ]
    found: dict[str, list[tuple[float, float]]] = {label: [] for label, _, _ in cases}
    for _ in range(ROUNDS):  # alternating: the machine's speed drifts
        for label, every, epoll in cases:
            found[label].append(wake_cost(every, seconds, epoll))
    for label, runs in found.items():
        rate, cost = (statistics.median(column) for column in zip(*runs, strict=True))
        rows.append([label, "nothing (idle between)", f"{rate:.0f}", f"{cost:.1f}"])
    beside = []
    for _ in range(ROUNDS):
        busy = counted(seconds)
        beside.append(wake_cost(0.0005, seconds))
        busy.communicate()
    rate, cost = (statistics.median(column) for column in zip(*beside, strict=True))
    rows.append(["time.sleep(0.5 ms)", "a counting loop", f"{rate:.0f}", f"{cost:.1f}"])
    load1 = os.getloadavg()
    header = ["sleep", "CPU 0 shared with", "wake-ups/s", "CPU µs per wake-up"]
    notes = (
        f"One thread pinned to CPU {CPU}, {seconds:g} s per case, medians of {ROUNDS} "
        "alternating rounds; CPU µs per wake-up: the thread's own CPU time over its "
        "wake-ups. The machine is shared with other jobs. Load average (1 min) "
        f"{load0[0]:.2f} before, {load1[0]:.2f} after."
    )
    body = f"{notes}\n\n{markdown_table(header, rows)}\n"
    if args.quick:
        print(body)
    else:
        publish("bench/wakeups.py", "What a wake-up costs (why a flooded loop is paced)", body)


if __name__ == "__main__":
    main()
