"""A mock of the ctrlX CORE REST API (identity manager + data layer) with a simulated machine."""

from .app import DEFAULT_LAG_S, build_app, serve
from .faults import Faults
from .machine import HOLD_S, UNITS, AxisGroup, Machine, SimAxis, Trafo, demo_groups, many_axes
from .nodes import NodeTree, Snapshot
from .state import STATE_KEY, MockState
from .tls import MockCertificate, certificate_in, make_certificate

__all__ = [
    "DEFAULT_LAG_S",
    "HOLD_S",
    "STATE_KEY",
    "UNITS",
    "AxisGroup",
    "Faults",
    "Machine",
    "MockCertificate",
    "MockState",
    "NodeTree",
    "SimAxis",
    "Snapshot",
    "Trafo",
    "build_app",
    "certificate_in",
    "demo_groups",
    "make_certificate",
    "many_axes",
    "serve",
]
