"""Where the page, the meshes and the shipped cells live, in a checkout and in a wheel."""

from __future__ import annotations

from pathlib import Path

PACKAGE_DIR = Path(__file__).resolve().parent
_BUNDLED = PACKAGE_DIR / "_data"
"""A wheel carries static/, assets/ and cells/ here (see setup.py); a checkout has them on top."""
DATA_ROOT = _BUNDLED if _BUNDLED.is_dir() else PACKAGE_DIR.parent

STATIC_DIR = DATA_ROOT / "static"
ASSETS_DIR = DATA_ROOT / "assets"
CELLS_DIR = DATA_ROOT / "cells"
DEMO_CELL = CELLS_DIR / "demo.toml"
