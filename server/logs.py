"""Logging set-up shared by the command-line entry points."""

from __future__ import annotations

import logging

FORMAT = "%(asctime)s %(levelname)s %(name)s: %(message)s"


def setup_logging(level: int = logging.INFO) -> None:
    """Log to stderr with timestamps; passwords and tokens are never passed to loggers."""
    logging.basicConfig(level=level, format=FORMAT)
