"""Reads a controller with ur_rtde's RTDEReceiveInterface (run in its own process by a test).

ur_rtde's constructor blocks, holding the GIL, until the first data package, and
its port is fixed at 30004: hence a process of its own, and a loopback address of
its own. Prints one JSON line: ``[[timestamp, actual_q, register, register], ...]``.
"""

from __future__ import annotations

import json
import sys
import time

import rtde_receive


def main() -> None:
    host, seconds = sys.argv[1], float(sys.argv[2])
    registers = [int(r) for r in sys.argv[3:]]
    fields = ["timestamp", "actual_q", *(f"output_double_register_{r}" for r in registers)]
    # Upper register range: ur_rtde reads output_double_register_42 to 46 there.
    receive = rtde_receive.RTDEReceiveInterface(host, 500.0, fields, False, True)
    readings = []
    end = time.monotonic() + seconds
    while time.monotonic() < end:
        readings.append(
            [
                receive.getTimestamp(),
                receive.getActualQ(),
                *(receive.getOutputDoubleRegister(r) for r in registers),
            ]
        )
        time.sleep(0.0005)
    receive.disconnect()
    print(json.dumps(readings))


if __name__ == "__main__":
    main()
