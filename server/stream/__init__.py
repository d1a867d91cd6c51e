"""Acquisition (one task per data source), frame encoding, and the viewer hub."""

from .acquisition import Acquisition, PollSettings
from .hub import Hub, Viewer
from .status import RobotHealth, SourceHealth

__all__ = ["Acquisition", "Hub", "PollSettings", "RobotHealth", "SourceHealth", "Viewer"]
