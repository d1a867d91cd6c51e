"""What a description may read and see while it is expanded, and the call that expands it."""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass, field
from pathlib import Path

from .limits import Limits, SandboxError
from .packages import Packages
from .run import run


@dataclass(frozen=True)
class Confinement:
    """The folders a description may read besides its own, its variables, the worker's limits.

    A description always may read its own folder, the packages the cell gives
    (their author chose them) and the ROS packages its ``$(find)`` finds (a folder
    with a ``package.xml``); a folder found only by its name (``$(find etc)``) is not.
    """

    folders: tuple[Path, ...] = ()
    """The cell's folder, for a robot of a cell."""
    env: Mapping[str, str] = field(default_factory=dict, hash=False)
    """Each variable ``$(env)``/``$(optenv)`` may see, by name (the cell's ``xacro_env``)."""
    limits: Limits = Limits()


@dataclass(frozen=True)
class Expansion:
    """A xacro file's URDF text, the files it included, what xacro warned about."""

    text: str
    included: tuple[Path, ...]
    warnings: tuple[str, ...]


def expand_xacro(
    path: Path, args: Mapping[str, str], packages: Packages, confinement: Confinement
) -> Expansion:
    """What xacro file ``path`` expands to with ``args``, in a worker (see ``server.sandbox``).

    Raises SandboxError naming the file and what went wrong (xacro's message,
    the refused read, or the limit that stopped the worker). The packages the
    worker found are added to ``packages``.
    """
    given = {name: str(folder) for name, folder in packages.given.items()}
    roots = [path.parent, *confinement.folders, *packages.given.values()]
    job = {
        "file": str(path),
        "args": {k: str(v) for k, v in args.items()},
        "packages": given,
        "start": str(packages.start),
        "roots": [str(root) for root in roots],
        "env": sorted(confinement.env),
    }
    answer = run(job, confinement.limits, str(path), confinement.env)
    if "error" in answer:
        raise SandboxError(str(answer["error"]))
    packages.learn({name: Path(folder) for name, folder in answer["packages"].items()})
    return Expansion(
        text=str(answer["text"]),
        included=tuple(Path(name) for name in answer["included"]),
        warnings=tuple(map(str, answer["warnings"])),
    )
