"""``python -m server``: serve the viewer, with an embedded mock unless a controller is named."""

from __future__ import annotations

import argparse

import uvicorn
from pydantic import ValidationError

from .config import Settings
from .logs import setup_logging
from .web import create_app


def parse_settings(argv: list[str] | None = None) -> Settings:
    """Settings from ``LINKVIEW_*`` variables, overridden by command-line flags."""
    parser = argparse.ArgumentParser(prog="python -m server", description=__doc__)
    parser.add_argument("--host", help="address to bind (default 127.0.0.1)")
    parser.add_argument("--port", type=int, help="port to bind (default 8000)")
    parser.add_argument("--ctrlx", metavar="URL", help="ctrlX base URL (default: embedded mock)")
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
    args = parser.parse_args(argv)
    overrides = {
        "host": args.host,
        "port": args.port,
        "ctrlx_url": args.ctrlx,
        "ctrlx_mode": args.mode,
        "ctrlx_api": args.api,
        "ctrlx_ca": args.ctrlx_ca,
        "insecure": args.insecure,
    }
    try:
        return Settings(**{k: v for k, v in overrides.items() if v is not None})
    except ValidationError as exc:  # a readable line per bad setting, not a traceback
        problems = "; ".join(f"{'.'.join(map(str, e['loc']))}: {e['msg']}" for e in exc.errors())
        parser.error(problems)


def main(argv: list[str] | None = None) -> None:
    """Run the server until interrupted."""
    settings = parse_settings(argv)
    setup_logging()
    source = settings.ctrlx_url or "the embedded mock data layer"
    print(
        f"linkview: open http://{settings.host}:{settings.port}/  (data from {source})", flush=True
    )
    uvicorn.run(
        create_app(settings),
        host=settings.host,
        port=settings.port,
        log_level="warning",
        ws="websockets-sansio",
    )


if __name__ == "__main__":
    main()
