"""The parent's side: start a worker, hand it a job, read its answer within the limits.

A worker is a fresh interpreter (``python -I``): nothing of the server's memory,
environment or open files goes with it. The caller waits in its own thread
(``check``, start-up, or the reload's thread), never on the event loop; the
wait wakes for each chunk of output, so a worker that runs past the wall-clock
limit, or writes past the output limit, is killed at once. ``stop_all`` kills
every running worker, so that a server stopping does not wait for one.
"""

from __future__ import annotations

import json
import os
import selectors
import signal
import subprocess
import sys
import threading
import time
from collections.abc import Mapping
from pathlib import Path
from typing import Any

from . import worker
from .limits import Limits, SandboxError, variable

WORKER = Path(worker.__file__).resolve()
CHUNK = 1 << 16
STDERR_KEPT = 4096

_running: set[subprocess.Popen[bytes]] = set()
_stopped: set[int] = set()
"""Process ids of workers ``stop_all`` killed: their callers are told so, not of a limit."""
_lock = threading.Lock()


def stop_all() -> int:
    """Kill every worker of this process (the server is stopping); how many there were."""
    with _lock:
        running = list(_running)
        _stopped.update(p.pid for p in running)
    for process in running:
        _kill(process)
    return len(running)


def _kill(process: subprocess.Popen[bytes]) -> None:
    try:
        os.killpg(process.pid, signal.SIGKILL)  # its own session: nothing it started survives
    except (ProcessLookupError, PermissionError):
        process.kill()


def run(job: Mapping[str, Any], limits: Limits, label: str, env: Mapping[str, str]) -> Any:
    """The worker's answer to ``job``; SandboxError naming ``label`` and any limit reached.

    ``env`` is the worker's whole environment (the variables a cell lets a
    description see).
    """
    request = dict(job, parent=os.getpid(), limits=vars(limits))
    process = subprocess.Popen(
        [sys.executable, "-I", str(WORKER)],
        stdin=subprocess.PIPE,
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
        env=dict(env),
        cwd="/",
        close_fds=True,
        start_new_session=True,
    )
    with _lock:
        _running.add(process)
    try:
        outcome = _collect(process, json.dumps(request).encode(), limits)
    finally:
        if process.poll() is None:
            _kill(process)
        process.wait()
        for stream in (process.stdin, process.stdout, process.stderr):
            if stream is not None:
                stream.close()
        with _lock:
            _running.discard(process)
            stopped = process.pid in _stopped
            _stopped.discard(process.pid)
    if stopped:
        raise SandboxError(f"{label}: expanding it was stopped: linkview is stopping")
    return _answer(process.returncode, outcome, limits, label)


class _Outcome:
    def __init__(self) -> None:
        self.out = bytearray()
        self.err = bytearray()
        self.reason: str | None = None
        """Why the parent killed the worker (a limit's name), if it did."""


def _collect(process: subprocess.Popen[bytes], request: bytes, limits: Limits) -> _Outcome:
    assert process.stdin and process.stdout and process.stderr
    outcome = _Outcome()
    try:
        process.stdin.write(request)
        process.stdin.close()
    except BrokenPipeError:  # it died at once: its exit status says why
        pass
    cap = limits.output_mb * 1024 * 1024 + CHUNK
    deadline = time.monotonic() + limits.wall_s
    with selectors.DefaultSelector() as selector:
        selector.register(process.stdout, selectors.EVENT_READ, outcome.out)
        selector.register(process.stderr, selectors.EVENT_READ, outcome.err)
        while selector.get_map():
            left = deadline - time.monotonic()
            if left <= 0:
                outcome.reason = "wall_s"
                break
            for key, _ in selector.select(timeout=min(left, 0.5)):
                chunk = os.read(key.fd, CHUNK)
                if not chunk:
                    selector.unregister(key.fileobj)
                    continue
                key.data.extend(chunk)
                if key.data is outcome.err:
                    del outcome.err[:-STDERR_KEPT]
            if len(outcome.out) > cap:
                outcome.reason = "output_mb"
                break
    if outcome.reason is not None:
        _kill(process)
    return outcome


LIMIT_TEXT = {
    "cpu_s": "{value:g} s of CPU time",
    "wall_s": "{value:g} s of wall-clock time",
    "memory_mb": "{value} MB of memory",
    "output_mb": "{value} MB of output",
}
EXIT_REASON = {
    worker.EXIT_CPU: "cpu_s",
    -signal.SIGXCPU: "cpu_s",
    worker.EXIT_MEMORY: "memory_mb",
    worker.EXIT_OUTPUT: "output_mb",
}


def _answer(code: int, outcome: _Outcome, limits: Limits, label: str) -> Any:
    reason = outcome.reason or EXIT_REASON.get(code)
    if reason is None and code == -signal.SIGKILL:
        reason = "cpu_s"  # the hard CPU limit, a second past the soft one
    if reason is not None:
        value = getattr(limits, reason)
        raise SandboxError(
            f"{label}: expanding it was stopped at the limit of "
            f"{LIMIT_TEXT[reason].format(value=value)} ({variable(reason)})"
        )
    if code != 0:
        said = outcome.err.decode(errors="replace").strip().splitlines()[-1:] or ["no message"]
        raise SandboxError(f"{label}: the expanding worker failed (exit {code}): {said[0]}")
    try:
        return json.loads(outcome.out)
    except ValueError:
        raise SandboxError(f"{label}: the expanding worker gave no answer") from None
