"""``python -m server discover URL``: ask a controller for its axes and kinematics, write a cell."""

from .browse import Axis, Controller, Kinematics, describe
from .starter import KNOWN_TRAFOS, SourceSpec, starter_cell

__all__ = [
    "KNOWN_TRAFOS",
    "Axis",
    "Controller",
    "Kinematics",
    "SourceSpec",
    "describe",
    "starter_cell",
]
