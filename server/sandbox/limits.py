"""How much a worker expanding a robot description may take before it is stopped.

The defaults leave the largest published descriptions tried (a 101-joint
dual-arm TIAGo, 2 048-link test robots) a wide margin: the corpus's largest
xacro file expands in well under a second on one core. Each limit can be set
by its ``LINKVIEW_XACRO_*`` variable (``check`` and the server read the same).
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass, fields


class SandboxError(Exception):
    """A description the worker could not expand; the message names the file and the limit."""


@dataclass(frozen=True)
class Limits:
    """The worker's limits: CPU seconds, wall-clock seconds, address space and output (MB)."""

    cpu_s: float = 20.0
    """CPU time (RLIMIT_CPU): SIGXCPU, then SIGKILL a second later."""
    wall_s: float = 60.0
    """Wall-clock time, from start to answer (a loaded machine may give the worker little CPU)."""
    memory_mb: int = 1024
    """Address space (RLIMIT_AS), the interpreter's own included."""
    output_mb: int = 64
    """The expanded URDF text."""

    @classmethod
    def from_env(cls, env: Mapping[str, str]) -> Limits:
        """The defaults, each replaced by its ``LINKVIEW_XACRO_<NAME>`` variable where set.

        Raises ValueError naming a variable that is not a positive number.
        """
        values: dict[str, float | int] = {}
        for f in fields(cls):
            name = variable(f.name)
            if name not in env:
                continue
            try:
                value = float(env[name]) if f.type == "float" else int(env[name])
            except ValueError:
                value = -1
            if not value > 0:
                raise ValueError(f"{name} must be a positive number, not {env[name]!r}")
            values[f.name] = value
        return cls(**values)  # type: ignore[arg-type]


def variable(name: str) -> str:
    """The environment variable setting limit ``name`` (``cpu_s`` -> ``LINKVIEW_XACRO_CPU_S``)."""
    return f"LINKVIEW_XACRO_{name.upper()}"
