"""The ``xacro`` package's own expansion of a file, run in a subprocess as its command runs.

Only ``$(find)`` is given: the package asks ROS's ament index for it; here (no
ROS) it asks linkview's package search (``server.sandbox.packages``), the same
folders ``package://`` meshes come from. Everything else is the package's own.
"""

from __future__ import annotations

import json
import subprocess
import sys
from collections.abc import Mapping
from pathlib import Path

ROOT = Path(__file__).resolve().parents[2]
RUN = """
import json, sys
from pathlib import Path
import xacro
from xacro import substitution_args
from server.sandbox.packages import Packages
given = {name: Path(folder) for name, folder in json.loads(sys.argv[1]).items()}
packages = Packages(given, Path(sys.argv[2]).parent)
find = lambda name: str(packages.require(name))
substitution_args._eval_find = substitution_args._eval_dict["find"] = find
sys.argv = ["xacro", *sys.argv[2:]]
xacro.main()
"""


def real_xacro(
    path: Path, args: Mapping[str, str], packages: Mapping[str, Path]
) -> subprocess.CompletedProcess[str]:
    """``xacro PATH name:=value ...`` with ``$(find name)`` answered from ``packages``."""
    folders = json.dumps({name: str(folder) for name, folder in packages.items()})
    mappings = [f"{name}:={value}" for name, value in args.items()]
    return subprocess.run(
        [sys.executable, "-c", RUN, folders, str(path), *mappings],
        cwd=ROOT,
        capture_output=True,
        text=True,
        timeout=120,
        check=False,
    )
