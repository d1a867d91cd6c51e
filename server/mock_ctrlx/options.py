"""Command-line options every mock's simulated machine takes (``python -m server.mock_*``)."""

from __future__ import annotations

import argparse
from collections.abc import Sequence

from .app import DEFAULT_LAG_S
from .machine import HOLD_S, AxisGroup, Machine


def add_machine_options(parser: argparse.ArgumentParser, setpoints: str = "setpoints") -> None:
    """``--lag-ms`` and ``--hold-s``: how the actual positions trail ``setpoints``, and how long
    a commanded pose is held."""
    parser.add_argument(
        "--lag-ms",
        type=float,
        default=DEFAULT_LAG_S * 1000.0,
        metavar="MS",
        help=f"how far actual positions trail their {setpoints}",
    )
    parser.add_argument(
        "--hold-s",
        type=float,
        default=HOLD_S,
        metavar="S",
        help="how long a commanded pose is held before the demo cycle resumes",
    )


def machine_from(args: argparse.Namespace, groups: Sequence[AxisGroup] | None = None) -> Machine:
    """A machine of ``groups`` (default: the demo's) with the options' lag and hold."""
    return Machine(groups, lag_s=args.lag_ms / 1000.0, hold_s=args.hold_s)
