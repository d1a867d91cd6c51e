"""A mock Universal Robots controller's RTDE interface, moving a simulated machine."""

from .outputs import POSITIONER_REGISTERS, UR5E_DEMO_TARGETS, Outputs, SafetyState, demo_groups
from .server import E_SERIES_VERSION, RtdeMock

__all__ = [
    "E_SERIES_VERSION",
    "POSITIONER_REGISTERS",
    "UR5E_DEMO_TARGETS",
    "Outputs",
    "RtdeMock",
    "SafetyState",
    "demo_groups",
]
