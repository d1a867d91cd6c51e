"""``python -m server.mock_ctrlx``: run the mock ctrlX REST API on its own."""

from __future__ import annotations

import argparse
import asyncio

from ..logs import setup_logging
from .app import build_app, serve


async def _run(host: str, port: int, token_lifetime_s: float) -> None:
    runner, url = await serve(build_app(token_lifetime_s=token_lifetime_s), host, port)
    print(f"mock ctrlX data layer at {url}", flush=True)
    try:
        await asyncio.Event().wait()
    finally:
        await runner.cleanup()


def main() -> None:
    parser = argparse.ArgumentParser(prog="python -m server.mock_ctrlx", description=__doc__)
    parser.add_argument("--host", default="127.0.0.1")
    parser.add_argument("--port", type=int, default=8443)
    parser.add_argument(
        "--token-lifetime",
        type=float,
        default=3600.0,
        metavar="S",
        help="seconds a token stays valid",
    )
    args = parser.parse_args()
    setup_logging()
    try:
        asyncio.run(_run(args.host, args.port, args.token_lifetime))
    except KeyboardInterrupt:
        pass


if __name__ == "__main__":
    main()
