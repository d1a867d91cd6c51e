"""Build hook: ship static/, assets/ and cells/ inside the ``server`` package of a wheel.

They live at the top of the repository (the layout people browse and the
Dockerfile copies), so setuptools' package data cannot reach them; this copies
them to ``server/_data/`` in the build, where ``server.paths`` looks first.
Everything else is declared in pyproject.toml.
"""

from __future__ import annotations

import shutil
from pathlib import Path

from setuptools import setup
from setuptools.command.build_py import build_py

ROOT = Path(__file__).resolve().parent
DATA = ("static", "assets", "cells")
SKIP = shutil.ignore_patterns("__pycache__", "*.py", "*.pyc", "node_modules")


class BuildWithData(build_py):
    """``build_py`` that also copies the page, the meshes and the shipped cells."""

    def run(self) -> None:
        super().run()
        if self.editable_mode:  # an editable install reads them from the checkout
            return
        target = Path(self.build_lib) / "server" / "_data"
        for folder in DATA:
            shutil.copytree(ROOT / folder, target / folder, ignore=SKIP, dirs_exist_ok=True)


setup(cmdclass={"build_py": BuildWithData})
