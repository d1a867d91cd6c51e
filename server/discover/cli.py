"""The ``discover`` command: list a controller's motion, then write a starter cell file."""

from __future__ import annotations

import argparse
import asyncio
import sys
from pathlib import Path
from urllib.parse import urlsplit

from pydantic import ValidationError

from ..config import Settings
from ..ctrlx import Credentials, DataLayerClient, DataLayerError, client_ssl
from ..text import printable
from .browse import Controller, describe
from .starter import SourceSpec, starter_cell
from .writer import plain_name

PASSWORD_ENV = "LINKVIEW_CTRLX_PASSWORD"


def main(argv: list[str]) -> int:
    """Run ``discover`` with ``argv``; returns the exit status."""
    if any(arg.startswith("rtde://") for arg in argv):  # a UR controller: its own options
        from .rtde import main as rtde_main

        return rtde_main(argv)
    if any(arg.startswith("opc.tcp://") for arg in argv):  # an OPC UA server: its own options
        from .opcua import main as opcua_main

        return opcua_main(argv)
    parser = argparse.ArgumentParser(
        prog="python -m server discover",
        description="Browse a ctrlX CORE's data layer for its motion axes and kinematics, list "
        "them, and write a starter cell file. The user and password come from "
        f"LINKVIEW_CTRLX_USER and {PASSWORD_ENV}, as for the server.",
    )
    parser.add_argument("url", help="the controller, e.g. https://192.168.1.1")
    parser.add_argument(
        "-o", "--output", default="cell.toml", metavar="FILE", help="the cell file to write"
    )
    parser.add_argument("--force", action="store_true", help="overwrite FILE if it exists")
    parser.add_argument("--source", default=None, help="name of the cell's [[source]]")
    parser.add_argument("--api", choices=["v2", "v1"], help="REST API generation (v1: older)")
    parser.add_argument("--ctrlx-ca", metavar="FILE", help="trust the certificates in FILE")
    parser.add_argument(
        "--insecure",
        action="store_true",
        default=None,
        help="do not verify the controller's HTTPS certificate (not recommended)",
    )
    args = parser.parse_args(argv)
    overrides = {"ctrlx_url": args.url, "ctrlx_api": args.api, "ctrlx_ca": args.ctrlx_ca}
    overrides["insecure"] = args.insecure
    try:
        settings = Settings(**{k: v for k, v in overrides.items() if v is not None})
    except ValidationError as exc:
        parser.error("; ".join(str(e["msg"]) for e in exc.errors()))
    output = Path(args.output)
    if output.exists() and not args.force:
        parser.error(f"{output} exists; give another --output or --force")
    try:
        controller = asyncio.run(_describe(settings))
    except DataLayerError as exc:
        print(printable(f"linkview: {settings.ctrlx_url}: {exc}"), file=sys.stderr)
        return 1
    print(listing(controller))
    source = SourceSpec(
        name=args.source or _source_name(args.url),
        url=args.url,
        user=settings.ctrlx_user,
        password_env=PASSWORD_ENV,
        api=settings.ctrlx_api,
        ca=None if settings.ctrlx_ca is None else str(settings.ctrlx_ca.resolve()),
        insecure=settings.insecure,
    )
    command = " ".join(["python -m server discover", args.url])
    output.write_text(starter_cell(controller, source, command), encoding="utf-8")
    print(f"wrote {output}: check it with `python -m server check {output}`; TODOs need a person")
    return 0


async def _describe(settings: Settings) -> Controller:
    assert settings.ctrlx_url is not None
    client = DataLayerClient(
        settings.ctrlx_url,
        Credentials(settings.ctrlx_user, settings.ctrlx_password.get_secret_value()),
        api=settings.ctrlx_api,
        ssl_context=client_ssl(settings.ctrlx_ca, settings.insecure),
        timeout_s=settings.request_timeout_s,
    )
    async with client:
        return await describe(client)


def listing(controller: Controller) -> str:
    """What was found, for people: axes with units and values, kinematics with their axes.

    Every line passes ``printable``: what the controller says is shown, never obeyed by
    the terminal (an ANSI escape in a unit cannot clear the screen or hide a line).
    """
    lines = [
        f"{controller.url}: {len(controller.axes)} axes, {len(controller.kinematics)} kinematics"
    ]
    width = max((len(a.name) for a in controller.axes), default=4)
    for axis in controller.axes:
        value = "—" if axis.value is None else f"{axis.value:.6g}"
        setpoint = "setpoint" if axis.setpoint else "no setpoint"
        lines.append(
            f"  axis {axis.name:<{width}}  {axis.kind or '?':<10}  {value:>12} "
            f"{axis.unit or '(no unit)':<5}  {setpoint}  {axis.node}"
        )
    for kin in controller.kinematics:
        trafo = kin.trafo or "no joint transformation"
        lines.append(f"  kinematics {kin.name}: {trafo}; axes {', '.join(kin.axes)}")
    lines += [f"  not read: {note}" for note in controller.notes]
    return "\n".join(map(printable, lines))


def _source_name(url: str) -> str:
    return plain_name(urlsplit(url).hostname or "", "ctrlx")
