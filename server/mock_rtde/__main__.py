"""``python -m server.mock_rtde``: a mock UR5e and a MotionPlus positioner over RTDE, on its own."""

from __future__ import annotations

import argparse
import asyncio
import signal
import time

from ..logs import setup_logging
from ..mock_ctrlx import DEFAULT_LAG_S, HOLD_S, Machine
from ..rtde import wire
from .outputs import POSITIONER_REGISTERS, demo_groups
from .server import RtdeMock

CB3_VERSION = (3, 15, 7, 0)


async def _run(args: argparse.Namespace) -> None:
    machine = Machine(demo_groups(), hold_s=HOLD_S, lag_s=DEFAULT_LAG_S)
    mock = RtdeMock(machine, CB3_VERSION) if args.cb3 else RtdeMock(machine)
    url = await mock.start(args.host, args.port)
    tilt, turn = POSITIONER_REGISTERS
    print(
        f"mock UR controller (RTDE) at {url}: a UR5e on actual_q, a positioner's tilt and turn "
        f"on output_double_register_{tilt} and _{turn} (rad), {1 / mock.tick_s:g} Hz",
        flush=True,
    )
    try:
        await asyncio.Event().wait()
    finally:
        await mock.close()
        seconds = time.monotonic() - (mock.first_sent or time.monotonic())
        print(f"sent {mock.sent} data packages in {seconds:.1f} s", flush=True)


def main() -> None:
    parser = argparse.ArgumentParser(prog="python -m server.mock_rtde", description=__doc__)
    parser.add_argument("--host", default="127.0.0.1")
    parser.add_argument("--port", type=int, default=wire.PORT)
    parser.add_argument("--cb3", action="store_true", help="say a CB3 version: 125 Hz at most")
    args = parser.parse_args()
    setup_logging()
    # Stopped by SIGTERM as by Ctrl-C: the count of packages sent is printed either way.
    signal.signal(signal.SIGTERM, signal.default_int_handler)
    try:
        asyncio.run(_run(args))
    except KeyboardInterrupt:
        pass


if __name__ == "__main__":
    main()
