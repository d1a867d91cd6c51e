"""Client for the ctrlX CORE REST API: identity manager login and data-layer reads."""

from .client import Credentials, DataLayerClient
from .follow import Sample, follow
from .paths import encode_node_path
from .problem import AuthError, BadValue, DataLayerError, NodeNotFound, ProblemError

__all__ = [
    "AuthError",
    "BadValue",
    "Credentials",
    "DataLayerClient",
    "DataLayerError",
    "NodeNotFound",
    "ProblemError",
    "Sample",
    "encode_node_path",
    "follow",
]
