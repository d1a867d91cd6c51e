"""An OPC UA client (asyncua) as a source kind: sessions, security, node keys, units, following."""

from .connector import OpcuaConnector
from .nodes import BrowsePathKey, NodeIdKey, NodeKey, check_node, node_id_key, parse_node
from .resolve import UnitRule
from .security import CLIENT_CERTIFICATE, CLIENT_URI, load_certificates, thumbprint
from .session import SECURITY_MODES, OpcuaSettings, SecurityMode, check_opcua_url

__all__ = [
    "CLIENT_CERTIFICATE",
    "CLIENT_URI",
    "SECURITY_MODES",
    "BrowsePathKey",
    "NodeIdKey",
    "NodeKey",
    "OpcuaConnector",
    "OpcuaSettings",
    "SecurityMode",
    "UnitRule",
    "check_node",
    "check_opcua_url",
    "load_certificates",
    "node_id_key",
    "parse_node",
    "thumbprint",
]
