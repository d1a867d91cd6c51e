"""Universal Robots' RTDE (Real-Time Data Exchange) as a linkview source: an asyncio client."""

from .connector import NotFound, RtdeConnector, RtdeSettings, modes_text
from .link import Controller, LinkClosed, RtdeLink, handshake
from .recipe import RECIPE_FIELDS, Recipe, recipe_fields
from .wire import PORT, Key, WireError, parse_key, register_key

__all__ = [
    "PORT",
    "RECIPE_FIELDS",
    "Controller",
    "Key",
    "LinkClosed",
    "NotFound",
    "Recipe",
    "RtdeConnector",
    "RtdeLink",
    "RtdeSettings",
    "WireError",
    "handshake",
    "modes_text",
    "parse_key",
    "recipe_fields",
    "register_key",
]
