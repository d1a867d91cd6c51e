"""Acquisition (one task per data source), frame encoding, and the viewer hub."""

from .acquisition import Acquisition, PollSettings
from .hub import Hub, Message, Viewer
from .messages import PROTOCOL_VERSIONS, cell_message, hello_message
from .status import RobotHealth, SourceHealth, load_summary

__all__ = [
    "PROTOCOL_VERSIONS",
    "Acquisition",
    "Hub",
    "Message",
    "PollSettings",
    "RobotHealth",
    "SourceHealth",
    "load_summary",
    "Viewer",
    "cell_message",
    "hello_message",
]
