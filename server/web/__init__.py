"""Web layer: FastAPI routes, the viewer WebSocket and static files. No kinematics here."""

from .app import create_app

__all__ = ["create_app"]
