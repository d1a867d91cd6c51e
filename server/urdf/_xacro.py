"""xacro files expanded to URDF text by the ``xacro`` package, in a sandboxed worker process.

A xacro file can hold expressions, includes and environment lookups: it is
expanded by ``server.sandbox`` (a worker with no secrets and bounded costs,
expressions without code), never in this process. ``$(find pkg)`` asks
``Packages``, as ``package://`` does.
"""

from __future__ import annotations

from collections.abc import Mapping
from pathlib import Path

from ..sandbox import Confinement, Packages, SandboxError, expand_xacro
from ..sandbox.confinement import Expansion
from .model import UrdfError

XACRO_SUFFIX = ".xacro"
Expanded = Expansion


def is_xacro(path: Path) -> bool:
    """True for ``.xacro`` files (``.urdf.xacro`` included)."""
    return path.suffix.lower() == XACRO_SUFFIX


def expand(
    path: Path,
    args: Mapping[str, str],
    packages: Packages,
    confinement: Confinement | None = None,
) -> Expansion:
    """What xacro file ``path`` expands to with ``args`` (``text`` as the ``xacro`` command prints).

    UrdfError names the file xacro was reading when it failed and xacro's own
    message (which gives the line for malformed XML), a read it refused, or the
    worker's limit that stopped it.
    """
    if not path.is_file():
        raise UrdfError(f"xacro file {path} not found")
    try:
        return expand_xacro(path, args, packages, confinement or Confinement())
    except SandboxError as exc:
        raise UrdfError(str(exc)) from None
