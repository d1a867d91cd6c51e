"""``discover opc.tcp://...``: an OPC UA server's Robotics devices (or a folder), a starter cell."""

from .browse import Axis, Device, Found, robotics, under
from .cell import SourceSpec, starter_cell
from .cli import main

__all__ = ["Axis", "Device", "Found", "SourceSpec", "main", "robotics", "starter_cell", "under"]
