"""``python -m server discover opc.tcp://HOST:PORT``: a server's robots, and a starter cell."""

from __future__ import annotations

import argparse
import asyncio
import os
import sys
from pathlib import Path
from urllib.parse import urlsplit

from ...opcua import SECURITY_MODES, OpcuaSettings, check_opcua_url, parse_node
from ...opcua.nodes import NodeIdKey
from ...opcua.session import open_session
from ...sources import SourceError
from ...text import printable
from ..writer import plain_name
from .browse import Found, robotics, under
from .cell import SourceSpec, listing, starter_cell

PASSWORD_ENV = "LINKVIEW_OPCUA_PASSWORD"


def main(argv: list[str]) -> int:
    """Run ``discover opc.tcp://...``; returns the exit status."""
    parser = argparse.ArgumentParser(
        prog="python -m server discover",
        description="Browse an OPC UA server for the robots of the Robotics companion "
        "specification (or the numeric variables under a folder), list them and write a "
        f"starter cell. A user logs in with the password from {PASSWORD_ENV}.",
    )
    parser.add_argument("url", help="the server, e.g. opc.tcp://192.168.1.10:4840")
    parser.add_argument("-o", "--output", default="cell.toml", metavar="FILE")
    parser.add_argument("--force", action="store_true", help="overwrite FILE if it exists")
    parser.add_argument("--source", default=None, help="name of the cell's [[source]]")
    parser.add_argument(
        "--under",
        metavar="NODEID",
        help="for a server without the Robotics model: the folder whose numeric variables "
        'become joints, e.g. "ns=2;s=Robots"',
    )
    parser.add_argument("--security", choices=SECURITY_MODES, default="None")
    parser.add_argument("--server-certificate", metavar="FILE", help="the server's, to trust")
    parser.add_argument("--user", help=f"log in as USER (password: {PASSWORD_ENV})")
    args = parser.parse_args(argv)
    try:
        check_opcua_url(args.url)
        folder = None if args.under is None else _folder(args.under)
    except ValueError as exc:
        parser.error(str(exc))
    output = Path(args.output)
    if output.exists() and not args.force:
        parser.error(f"{output} exists; give another --output or --force")
    if args.user and PASSWORD_ENV not in os.environ:
        parser.error(f"--user needs the password in {PASSWORD_ENV}")
    name = args.source or plain_name(urlsplit(args.url).hostname or "", "opcua")
    certificate = None if args.server_certificate is None else Path(args.server_certificate)
    settings = OpcuaSettings(
        args.url,
        source=name,
        security=args.security,
        user=args.user,
        password=os.environ.get(PASSWORD_ENV) if args.user else None,
        server_certificate=certificate,
        client_certificate=output.resolve().parent / "linkview-opcua-client.der",
    )
    try:
        found = asyncio.run(_browse(settings, folder))
    except SourceError as exc:
        print(f"linkview: {printable(str(exc))}", file=sys.stderr)
        return 1
    print("\n".join(map(printable, listing(found))))  # names, makers: the server's text
    spec = SourceSpec(
        name,
        args.url,
        args.security,
        None if certificate is None else str(certificate.resolve()),
        args.user,
        PASSWORD_ENV if args.user else None,
    )
    command = " ".join(["python -m server discover", args.url, *_under_args(args.under)])
    output.write_text(starter_cell(found, spec, command), encoding="utf-8")
    print(f"wrote {output}: check it with `python -m server check {output}`; TODOs need a person")
    return 0


async def _browse(settings: OpcuaSettings, folder: str | None) -> Found:
    session = await open_session(settings)
    try:
        if folder is None:
            return await robotics(session.client, settings.url)
        return await under(session.client, settings.url, folder)
    except (OSError, TimeoutError) as exc:
        raise SourceError(f"{settings.url}: {exc}") from None
    finally:
        await session.close()


def _folder(text: str) -> str:
    """``--under``: a NodeId as asyncua reads it (``nsu=`` stays for the session to resolve)."""
    key = parse_node(text)
    if not isinstance(key, NodeIdKey) or key.uri is not None:
        raise ValueError(f"--under takes a NodeId with its namespace index, not {text!r}")
    return text


def _under_args(folder: str | None) -> list[str]:
    return [] if folder is None else ["--under", repr(folder)]
