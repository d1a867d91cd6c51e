"""``python -m server``: serve the viewer; ``check FILE``: check a cell file; ``discover URL``."""

from __future__ import annotations

import argparse
import asyncio
import contextlib
import functools
import gc
import logging
import os
import socket
import sys
from collections.abc import Callable
from pathlib import Path

import uvicorn
from pydantic import ValidationError

from .cell import Cell, CellError, load_cell
from .cell.load import unreadable
from .cluster import broker_settings, run_worker
from .config import Settings
from .hosts import HostPolicy, is_loopback
from .logs import setup_logging
from .runtime.source import SourceDefaults
from .runtime.startup import configured_cell, history_problems, source_defaults
from .text import plural, printable
from .web import create_app
from .web.listen import ListenError, browser_urls, listen
from .web.serve import server_config

log = logging.getLogger("server")


def parse_settings(argv: list[str] | None = None, worker: bool = False) -> Settings:
    """Settings from ``LINKVIEW_*`` variables, overridden by command-line flags.

    ``worker``: the flags of ``python -m server acquire`` (no web server's).
    """
    parser = argparse.ArgumentParser(
        prog="python -m server acquire" if worker else "python -m server",
        description=ACQUIRE_HELP
        if worker
        else "Serve the live 3D view. `python -m server check FILE` checks a cell file; "
        "`python -m server discover URL` writes one for a controller; "
        "`python -m server acquire` runs an acquisition worker of a cluster.",
    )
    parser.set_defaults(host=None, port=None, viewer_token=None, allow_origin=None, allow_host=None)
    parser.set_defaults(max_viewers=None)
    web = parser.add_argument_group("web server") if not worker else None
    if web is not None:
        web.add_argument("--host", help="address to bind (default 127.0.0.1)")
        web.add_argument("--port", type=int, help="port to bind (default 8000)")
    parser.add_argument(
        "--cell", metavar="FILE", help="the cell file (TOML, docs/cell.md; default: the demo cell)"
    )
    parser.add_argument(
        "--allow-commands",
        action="store_true",
        default=None,
        help="let the page move robots of real controllers (embedded mocks always may)",
    )
    if web is not None:
        web.add_argument(
            "--allow-edits",
            action="store_true",
            default=None,
            help="let the page change the cell file and save it (docs/commissioning.md)",
        )
    if web is not None:
        web.add_argument(
            "--viewer-token",
            metavar="SECRET",
            help="require this token on the page, /ws and /api (open the page with ?token=SECRET)",
        )
        web.add_argument(
            "--allow-origin",
            metavar="URL",
            action="append",
            help="also let pages from this origin open the stream (repeatable)",
        )
        web.add_argument(
            "--allow-host",
            metavar="NAME",
            action="append",
            help="also answer requests naming this server NAME (repeatable; .example.com for "
            "every name under it); bound to loopback, only loopback names are answered",
        )
        web.add_argument("--max-viewers", type=int, help="refuse viewers beyond this (1000)")
    parser.add_argument(
        "--ctrlx", metavar="URL", help="controller URL for a one-source cell (default: its own)"
    )
    parser.add_argument(
        "--mode",
        choices=["subscribe", "poll", "get"],
        help="how to follow the joints: subscribe (default, falls back to poll), poll (bulk "
        "reads) or get (one request per node)",
    )
    parser.add_argument(
        "--api", choices=["v2", "v1"], help="REST API generation (v1: older firmware)"
    )
    parser.add_argument(
        "--ctrlx-ca", metavar="FILE", help="trust the certificates in FILE (the device's own)"
    )
    parser.add_argument(
        "--insecure",
        action="store_true",
        default=None,
        help="do not verify the controller's HTTPS certificate (not recommended)",
    )
    look_back = parser.add_argument_group("look back (docs/recording.md)")
    look_back.add_argument(
        "--history", type=float, metavar="SECONDS", help="seconds the timeline reaches back (600)"
    )
    look_back.add_argument(
        "--record", metavar="DIR", help="record every source to MCAP files in DIR"
    )
    look_back.add_argument(
        "--replay", metavar="FILE", help="serve an MCAP recording as if live (--cell: its cell)"
    )
    look_back.add_argument(
        "--foxglove", type=int, metavar="PORT", help="serve the data live to Foxglove on PORT"
    )
    parser.add_argument(
        "--broker",
        metavar="URL",
        required=worker and "LINKVIEW_BROKER" not in os.environ,
        help="redis://HOST:PORT/DB: share the work with other processes through this Redis "
        "server (docs/cluster.md)",
    )
    args = parser.parse_args(argv)
    overrides = {
        "host": args.host,
        "port": args.port,
        "cell": args.cell,
        "allow_commands": args.allow_commands,
        "allow_edits": getattr(args, "allow_edits", None),
        "viewer_token": args.viewer_token,
        "allow_origin": args.allow_origin,
        "allow_host": args.allow_host,
        "max_viewers": args.max_viewers,
        "ctrlx_url": args.ctrlx,
        "ctrlx_mode": args.mode,
        "ctrlx_api": args.api,
        "ctrlx_ca": args.ctrlx_ca,
        "insecure": args.insecure,
        "history_s": args.history,
        "record": args.record,
        "replay": args.replay,
        "foxglove_port": args.foxglove,
        "broker": args.broker,
    }
    try:
        return Settings(**{k: v for k, v in overrides.items() if v is not None})
    except ValidationError as exc:  # a readable line per bad setting, not a traceback
        problems = "; ".join(f"{'.'.join(map(str, e['loc']))}: {e['msg']}" for e in exc.errors())
        parser.error(problems)


def check(argv: list[str]) -> int:
    """Check cell files: one line per robot and its warnings, or every mistake; the exit status.

    History bounds use the ``LINKVIEW_*`` settings (``LINKVIEW_HISTORY_S``), as the server would.
    """
    parser = argparse.ArgumentParser(prog="python -m server check", description=check.__doc__)
    parser.add_argument("files", nargs="+", metavar="FILE", help="cell files to check")
    files = parser.parse_args(argv).files
    try:
        defaults = source_defaults(Settings(**{}))  # the environment's, as the server reads it
    except ValidationError as exc:
        settings = "; ".join(f"{'.'.join(map(str, e['loc']))}: {e['msg']}" for e in exc.errors())
        print(f"linkview: the server would not start with these settings ({settings}); "
              "checking with the defaults", file=sys.stderr)  # fmt: skip
        defaults = SourceDefaults()
    status = 0
    for name in files:
        try:
            cell = checked_cell(Path(name), defaults)
        except CellError as exc:
            print(exc, file=sys.stderr)
            status = 1
            continue
        for robot in cell.robots:
            count = sum(m is not None for m in robot.meshes)
            meshes = plural(count, "mesh", "meshes") if count else "no meshes"
            joints = plural(len(robot.joints), "joint")
            where = f"source {robot.source}"
            print(printable(f"{name}: {robot.name}: {robot.family}, {joints}, {where}, {meshes}"))
            for warning in robot.warnings:
                print(printable(f"{name}: {robot.name}: warning: {warning}"))
    return status


def checked_cell(path: Path, defaults: SourceDefaults) -> Cell:
    """The cell at ``path`` if the server could run it; CellError, one line per mistake, else.

    Whatever else goes wrong (a file no check foresaw) is one line too, never a traceback.
    """
    try:
        cell = load_cell(path, stand_ins=False)  # a missing URDF is a mistake here
    except CellError:
        raise
    except Exception as exc:
        raise unreadable(path, exc) from exc
    problems = history_problems(cell, defaults)
    if problems:
        raise CellError(path, problems)
    return cell


def discover(argv: list[str]) -> int:
    """Write a starter cell for a controller's axes and kinematics; the exit status."""
    from .discover.cli import main as discover_main  # only this command needs it

    setup_logging()
    return discover_main(argv)


def main(argv: list[str] | None = None) -> None:
    """Run the server until interrupted (or check cell files)."""
    argv = sys.argv[1:] if argv is None else argv
    if argv[:1] == ["check"]:
        sys.exit(check(argv[1:]))
    if argv[:1] == ["discover"]:
        sys.exit(discover(argv[1:]))
    if argv[:1] == ["acquire"]:
        sys.exit(acquire(argv[1:]))
    settings = parse_settings(argv)
    setup_logging()
    try:
        cell = configured_cell(settings)
    except CellError as exc:  # refuse to start, with the same message as `check`
        print(f"linkview: cannot start with this cell:\n{exc}", file=sys.stderr)
        sys.exit(2)
    try:  # before any controller is contacted: a taken port is all there is to say
        sockets = listen(settings.host, settings.port)
    except ListenError as exc:
        print(f"linkview: {exc}", file=sys.stderr)
        sys.exit(1)
    port = int(sockets[0].getsockname()[1])
    if not settings.viewer_token and not is_loopback(settings.host):
        log.warning(
            "listening on %s without a viewer token: anyone who can reach port %d can watch "
            "this cell (and move its simulated robots); set --viewer-token or "
            "LINKVIEW_VIEWER_TOKEN",
            settings.host,
            port,
        )
    if not is_loopback(settings.host) or settings.allow_host:
        hosts = HostPolicy(settings.host, settings.allow_host).describe()
        log.info("answering requests for the host names %s (--allow-host adds names)", hosts)
    if settings.ctrlx_url is not None and "ctrlx_password" not in settings.model_fields_set:
        log.warning(
            "logging in to %s as %s with the default password; set LINKVIEW_CTRLX_USER and "
            "LINKVIEW_CTRLX_PASSWORD if the controller has other credentials",
            settings.ctrlx_url,
            settings.ctrlx_user,
        )
    app = create_app(settings, cell)
    config = server_config(app, settings.host, port, settings.client_timeout_s)
    where = ", ".join(
        s.url or (f"{s.name} (replay of {s.replay})" if s.replay else f"{s.name} (embedded mock)")
        for s in cell.sources
    )
    if settings.broker is not None:  # a web replica: the workers follow the sources
        where = f"the acquisition workers of {settings.broker}"
    urls = browser_urls(settings.host, port)
    here = urls[0] if len(urls) == 1 else f"{urls[0]} here, or {' or '.join(urls[1:])} from others"

    def started() -> None:  # bound and serving: only now is the address worth opening
        print(f"linkview: open {here}  (data from {where})", flush=True)
        started_up()

    AnnouncingServer(config, started).run(sockets=sockets)


def started_up() -> None:
    """Keep what start-up made out of the garbage collector's passes (``gc.freeze``).

    Modules and the cell live as long as the process; scanning their 180 000
    objects stalled the event loop up to 150 ms (a full pass) or 15 ms (a
    young one) while streaming; frozen, the collector's time fell sixfold.
    """
    gc.freeze()


class AnnouncingServer(uvicorn.Server):
    """uvicorn's server, calling ``on_started`` once it serves (sources up, port bound)."""

    def __init__(self, config: uvicorn.Config, on_started: Callable[[], None]) -> None:
        super().__init__(config)
        self._on_started = on_started

    async def startup(self, sockets: list[socket.socket] | None = None) -> None:
        await super().startup(sockets)
        if self.started:
            self._on_started()


ACQUIRE_HELP = (
    "Run an acquisition worker of a cluster: follow the sources of the cell this worker holds "
    "leases for in the broker, and publish their frames there for the web replicas "
    "(python -m server --broker URL)."
)


def acquire(argv: list[str]) -> int:
    """Run an acquisition worker until interrupted; the exit status."""
    settings = parse_settings(argv, worker=True)
    broker = broker_settings(settings)
    if broker is None:  # parse_settings requires one; this tells mypy
        return 2
    setup_logging()
    try:
        cell = configured_cell(settings)
    except CellError as exc:
        print(f"linkview: cannot start with this cell:\n{exc}", file=sys.stderr)
        return 2
    load = functools.partial(configured_cell, settings, cell.path)
    started_up()
    with contextlib.suppress(KeyboardInterrupt):
        asyncio.run(run_worker(cell, source_defaults(settings), broker, load))
    return 0


if __name__ == "__main__":
    main()
