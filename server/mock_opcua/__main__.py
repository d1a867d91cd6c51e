"""``python -m server.mock_opcua``: the mock OPC UA server (Robotics companion model) on its own."""

from __future__ import annotations

import argparse
import asyncio
import os
from pathlib import Path

from ..cell.load import default_cache_dir
from ..logs import setup_logging
from ..mock_ctrlx.options import add_machine_options, machine_from
from ..opcua.security import thumbprint
from ..opcua.session import SECURITY_MODES
from .server import PERIOD_S, MockOptions, OpcuaMock


async def _run(args: argparse.Namespace) -> None:
    users = {}
    if args.user:
        if not args.password_env or args.password_env not in os.environ:
            raise SystemExit(f"--user needs --password-env naming a set variable ({args.user!r})")
        users[args.user] = os.environ[args.password_env]
    options = MockOptions(
        security=tuple(args.security),
        users=users,
        anonymous=not args.no_anonymous,
        certificate_dir=Path(args.certificate_dir) if args.certificate_dir else None,
        cache=None if args.no_cache else default_cache_dir(),
        period_s=args.period_ms / 1000.0,
    )
    mock = OpcuaMock(machine_from(args), options)
    url = await mock.start(args.host, args.port)
    print(f"mock OPC UA server at {url} ({', '.join(options.security)})", flush=True)
    if any(mode != "None" for mode in options.security):
        der = mock.certificate_file.read_bytes()
        print(
            f"its certificate: {mock.certificate_file} (SHA-1 thumbprint {thumbprint(der)}); "
            f'trust it with server_certificate = "{mock.certificate_file}"',
            flush=True,
        )
    try:
        await asyncio.Event().wait()
    finally:
        await mock.close()


def main() -> None:
    parser = argparse.ArgumentParser(prog="python -m server.mock_opcua", description=__doc__)
    parser.add_argument("--host", default="127.0.0.1")
    parser.add_argument("--port", type=int, default=4840)
    parser.add_argument(
        "--security",
        nargs="+",
        choices=SECURITY_MODES,
        default=list(SECURITY_MODES),
        help="the endpoints it offers (Basic256Sha256 for Sign and SignAndEncrypt)",
    )
    parser.add_argument("--user", help="a user that may log in (its password: --password-env)")
    parser.add_argument("--password-env", metavar="VAR", help="the variable holding its password")
    parser.add_argument("--no-anonymous", action="store_true", help="refuse anonymous sessions")
    parser.add_argument(
        "--certificate-dir",
        metavar="DIR",
        help="keep its certificate here and reuse it at the next start, as a controller does "
        "(default: a new one in a temporary folder)",
    )
    parser.add_argument(
        "--no-cache",
        action="store_true",
        help="build the address space anew (default: kept in linkview's cache for a fast start)",
    )
    parser.add_argument("--period-ms", type=float, default=PERIOD_S * 1000.0, metavar="MS")
    add_machine_options(parser)
    args = parser.parse_args()
    setup_logging()
    try:
        asyncio.run(_run(args))
    except KeyboardInterrupt:
        pass


if __name__ == "__main__":
    main()
