"""Robot descriptions evaluated in a worker process: no code, no secrets, bounded cost.

A xacro file is a program (expressions, includes, environment variables), and
cell folders come from vendors, colleagues and downloads. ``run`` expands one
in a fresh interpreter whose environment holds only what the cell names, with
CPU, memory, output and wall-clock limits (``limits``); inside it,
``expressions`` evaluates ``${...}`` without reaching Python's object graph and
``xacro_job`` confines reads to the cell's folder and the description's
packages. ``packages`` finds ROS packages, for the worker and for
``package://`` meshes alike. Only the standard library, lxml, PyYAML, xacro
and simpleeval are imported here, so a worker starts in a fraction of a second.
"""

from .confinement import Confinement, expand_xacro
from .limits import Limits, SandboxError
from .packages import PackageNotFound, Packages
from .run import stop_all

__all__ = [
    "Confinement",
    "Limits",
    "PackageNotFound",
    "Packages",
    "SandboxError",
    "expand_xacro",
    "stop_all",
]
