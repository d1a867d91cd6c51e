"""Client for the ctrlX CORE REST API: identity manager login and data-layer reads."""

from .auth import API_PATHS, ApiVersion, LoginBackoff, Token, TokenManager
from .checks import check_base_url
from .client import BulkRead, Credentials, DataLayerClient, Traffic
from .connector import CtrlxConnector
from .events import SubscriptionSettings
from .follow import MODES, REPROBE_S, Mode, follow, follow_into
from .interruptions import RetryPolicy, transient
from .paths import encode_node_path, name_problem, node_problem
from .problem import (
    AuthError,
    BadAddress,
    BadValue,
    DataLayerError,
    NodeNotFound,
    ProblemError,
    StreamEnded,
    Unsupported,
)
from .sample import Sample
from .sse import SseEvent, SseParser
from .timestamps import filetime_from_unix, unix_from_filetime
from .tls import client_ssl

__all__ = [
    "API_PATHS",
    "MODES",
    "REPROBE_S",
    "ApiVersion",
    "AuthError",
    "BadAddress",
    "BadValue",
    "BulkRead",
    "Credentials",
    "CtrlxConnector",
    "DataLayerClient",
    "DataLayerError",
    "LoginBackoff",
    "Mode",
    "NodeNotFound",
    "ProblemError",
    "RetryPolicy",
    "Sample",
    "SseEvent",
    "SseParser",
    "StreamEnded",
    "SubscriptionSettings",
    "Token",
    "TokenManager",
    "Traffic",
    "Unsupported",
    "check_base_url",
    "client_ssl",
    "encode_node_path",
    "filetime_from_unix",
    "follow",
    "follow_into",
    "name_problem",
    "node_problem",
    "transient",
    "unix_from_filetime",
]
