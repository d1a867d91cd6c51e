"""A mock OPC UA server: the simulated machine as Robotics MotionDevices (official nodesets)."""

from .address_space import COMPANIONS, DI_URI, IA_URI, ROBOTICS_URI, companion_server
from .robotics import MOCK_URI, build_robots
from .server import MockOptions, OpcuaMock

__all__ = [
    "COMPANIONS",
    "DI_URI",
    "IA_URI",
    "MOCK_URI",
    "ROBOTICS_URI",
    "MockOptions",
    "OpcuaMock",
    "build_robots",
    "companion_server",
]
