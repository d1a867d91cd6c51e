"""``python -m server.mock_ctrlx``: run the mock ctrlX REST API on its own."""

from __future__ import annotations

import argparse
import asyncio
import tempfile
from pathlib import Path

from ..logs import setup_logging
from .app import build_app, serve
from .machine import demo_groups, many_axes
from .options import add_machine_options, machine_from
from .tls import certificate_in


async def _run(args: argparse.Namespace) -> None:
    context, note = None, ""
    with tempfile.TemporaryDirectory(prefix="mock-ctrlx-") as tmp:
        if args.tls:
            cert, made = certificate_in(Path(args.tls_dir) if args.tls_dir else Path(tmp))
            context = cert.server_context()
            kept = "a new certificate" if made else "the certificate kept"
            note = f" with {kept} in {cert.ca_file.parent} (trust it: --ctrlx-ca {cert.ca_file})"
        app = build_app(
            machine_from(args, demo_groups() + many_axes(args.axes)),
            token_lifetime_s=args.token_lifetime,
            changes_only=args.changes_only,
            subscription_lifetime_s=args.subscription_lifetime,
        )
        runner, url = await serve(app, args.host, args.port, context)
        print(f"mock ctrlX data layer at {url}{note}", flush=True)
        try:
            await asyncio.Event().wait()
        finally:
            await runner.cleanup()


def main() -> None:
    parser = argparse.ArgumentParser(prog="python -m server.mock_ctrlx", description=__doc__)
    parser.add_argument("--host", default="127.0.0.1")
    parser.add_argument("--port", type=int, default=8443)
    parser.add_argument(
        "--token-lifetime", type=float, default=3600.0, metavar="S", help="seconds a token lives"
    )
    parser.add_argument(
        "--subscription-lifetime",
        type=float,
        default=60.0,
        metavar="S",
        help="seconds a created subscription outlives its last event stream",
    )
    parser.add_argument(
        "--tls", action="store_true", help="serve HTTPS with a self-signed certificate"
    )
    parser.add_argument(
        "--tls-dir",
        metavar="DIR",
        help="keep the certificate here and reuse it at the next start, as a device does "
        "(default: a new one in a temporary folder)",
    )
    add_machine_options(parser, "setpoints (state/values/ipo/pos)")
    parser.add_argument(
        "--axes",
        type=int,
        default=0,
        metavar="N",
        help="serve N more axes (big<k>_a<j>, six to a group): a big controller for discover",
    )
    parser.add_argument(
        "--changes-only",
        action="store_true",
        help="subscriptions publish a node only when its value changed",
    )
    args = parser.parse_args()
    setup_logging()
    try:
        asyncio.run(_run(args))
    except KeyboardInterrupt:
        pass


if __name__ == "__main__":
    main()
