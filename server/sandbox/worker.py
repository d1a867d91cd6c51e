"""The worker process (run as a script: ``python -I worker.py``); one job from stdin, one answer.

The parent starts it with an environment holding only the variables the
robot's ``xacro_env`` names, in the root folder, in a session of its own. Before
it reads a byte of the description it limits itself (CPU time, address space,
no files written, no processes started, no core dumps), lowers its priority so
that streaming keeps the CPU it needs, and dies with the parent. The answer is
one JSON object on stdout; a limit reached is told by the exit status.
"""

from __future__ import annotations

import ctypes
import json
import os
import resource
import signal
import sys
from pathlib import Path
from typing import Any

EXIT_CPU = 70
EXIT_MEMORY = 71
EXIT_OUTPUT = 72
NICENESS = 19
PR_SET_PDEATHSIG = 1


def _limit(limits: dict[str, Any]) -> None:
    cpu = max(1, round(float(limits["cpu_s"])))
    resource.setrlimit(resource.RLIMIT_CPU, (cpu, cpu + 1))
    memory = int(limits["memory_mb"]) * 1024 * 1024
    resource.setrlimit(resource.RLIMIT_AS, (memory, memory))
    resource.setrlimit(resource.RLIMIT_FSIZE, (0, 0))
    resource.setrlimit(resource.RLIMIT_CORE, (0, 0))
    resource.setrlimit(resource.RLIMIT_NPROC, (0, 0))
    signal.signal(signal.SIGXCPU, lambda *_: os._exit(EXIT_CPU))
    # The lowest niceness, not SCHED_IDLE: a server that uses every core (overloaded on
    # purpose, say) would starve an idle-class worker until its wall-clock limit.
    os.nice(NICENESS)


def _die_with(parent: int) -> None:
    """Be killed when the thread that started this process ends (the server stopped hard)."""
    try:
        libc = ctypes.CDLL(None, use_errno=True)
        libc.prctl(PR_SET_PDEATHSIG, signal.SIGKILL)
    except (OSError, AttributeError):
        pass
    if os.getppid() != parent:  # it ended before the line above
        os._exit(1)


def main() -> None:
    """Read the job, limit this process, run the job, write its answer."""
    request = json.loads(sys.stdin.buffer.read())
    _die_with(int(request["parent"]))
    _limit(request["limits"])
    # -I left this checkout off sys.path; only server/sandbox (light imports) is used here.
    sys.path.insert(0, str(Path(__file__).resolve().parents[2]))
    try:
        from server.sandbox.xacro_job import expand

        answer = expand(request)
        out = json.dumps(answer).encode()
    except MemoryError:
        os._exit(EXIT_MEMORY)
    except RecursionError:
        out = json.dumps({"error": f"{request['file']}: xacro: nested too deeply"}).encode()
    if len(out) > int(request["limits"]["output_mb"]) * 1024 * 1024:
        os._exit(EXIT_OUTPUT)
    sys.stdout.buffer.write(out)
    sys.stdout.buffer.flush()


if __name__ == "__main__":
    main()
