"""The listening sockets, bound before anything starts, and the addresses a browser can open.

Binding first means a taken port is one clear line before any controller is
contacted, and the "open" line names a port that is really ours. Bound to
every interface (``0.0.0.0``, ``::``), the server is reached through this
machine's own addresses, which are what people need to type.
"""

from __future__ import annotations

import errno
import ipaddress
import os
import socket

ALL_INTERFACES = frozenset({"0.0.0.0", "::", ""})


class ListenError(Exception):
    """The port cannot be bound; the message is one line for people."""


def listen(host: str, port: int, backlog: int = 2048) -> list[socket.socket]:
    """Sockets bound to ``host``:``port`` and listening (as asyncio's ``create_server`` would).

    Raises ListenError: the port is taken, not allowed, or ``host`` is no
    address of this machine.
    """
    try:
        infos = socket.getaddrinfo(
            host or None, port, type=socket.SOCK_STREAM, flags=socket.AI_PASSIVE
        )
    except socket.gaierror as exc:
        raise ListenError(f"cannot listen on {host}: {exc.strerror or exc}") from None
    sockets: list[socket.socket] = []
    try:
        for family, kind, proto, _, address in dict.fromkeys(infos):
            sock = socket.socket(family, kind, proto)
            sockets.append(sock)
            sock.setsockopt(socket.SOL_SOCKET, socket.SO_REUSEADDR, 1)
            if family == socket.AF_INET6:
                sock.setsockopt(socket.IPPROTO_IPV6, socket.IPV6_V6ONLY, 1)
            try:
                sock.bind(address)
            except OSError as exc:
                raise ListenError(_bind_failure(host, port, exc)) from None
            sock.listen(backlog)
            sock.setblocking(False)
    except BaseException:
        for sock in sockets:
            sock.close()
        raise
    return sockets


def _bind_failure(host: str, port: int, exc: OSError) -> str:
    where = f"{_bracketed(host)}:{port}"
    reason = os.strerror(exc.errno) if exc.errno else str(exc)
    hint = {
        errno.EADDRINUSE: "another program, perhaps another linkview, listens there; "
        "choose another port with --port",
        errno.EACCES: "ports below 1024 need privileges; choose another with --port",
        errno.EADDRNOTAVAIL: "this machine has no such address; check --host",
    }.get(exc.errno or 0)
    return f"cannot listen on {where}: {reason.lower()}" + (f"; {hint}" if hint else "")


def browser_urls(host: str, port: int) -> list[str]:
    """Addresses to open the page at: this machine's own when bound to every interface."""
    if host not in ALL_INTERFACES:
        return [f"http://{_bracketed(host)}:{port}/"]
    v6 = host == "::"
    local = "::1" if v6 else "127.0.0.1"
    return [f"http://{_bracketed(a)}:{port}/" for a in [local, *host_addresses(v6)]]


def host_addresses(v6: bool = False) -> list[str]:
    """This machine's addresses others may reach it at (no loopback, no link-local)."""
    family = socket.AF_INET6 if v6 else socket.AF_INET
    found: list[str] = []
    try:
        infos = socket.getaddrinfo(socket.gethostname(), None, family, socket.SOCK_STREAM)
        found += [str(info[4][0]) for info in infos]
    except OSError:
        pass
    # The address of the default route, whatever the host name resolves to (no packet is sent).
    probe = "2001:db8::1" if v6 else "192.0.2.1"
    try:
        with socket.socket(family, socket.SOCK_DGRAM) as sock:
            sock.connect((probe, 9))
            found.append(str(sock.getsockname()[0]))
    except OSError:
        pass
    addresses = []
    for text in dict.fromkeys(found):
        address = ipaddress.ip_address(text.split("%", 1)[0])
        if not (address.is_loopback or address.is_link_local or address.is_unspecified):
            addresses.append(str(address))
    return addresses


def _bracketed(host: str) -> str:
    return f"[{host}]" if ":" in host else host
