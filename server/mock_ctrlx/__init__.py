"""A mock of the ctrlX CORE REST API (identity manager + data layer) with a simulated machine."""

from .app import STATE_KEY, build_app, serve
from .machine import Machine, SimAxis

__all__ = ["STATE_KEY", "Machine", "SimAxis", "build_app", "serve"]
