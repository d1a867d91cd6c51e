"""Host names in requests: which ones a server answers (the defence against DNS rebinding).

A page at ``evil.example`` whose name is made to resolve to 127.0.0.1 sends
``Host: evil.example`` (and a matching ``Origin``), so only the Host header
tells it apart from the operator's own browser. Like Jupyter and Vite's dev
server, a server bound to loopback answers only loopback names; bound beyond,
it answers IP addresses (a rebinding page cannot use one as its name), this
machine's own names and those the operator allows.
"""

from __future__ import annotations

import ipaddress
import socket
from collections.abc import Iterable

LOOPBACK_NAMES = ("localhost", "127.0.0.1", "[::1]")


def is_loopback(address: str | None) -> bool:
    """True for a loopback IP address (``127.0.0.5``, ``::1``, ``[::1]``) or ``localhost``."""
    if not address:
        return False
    try:
        return ipaddress.ip_address(address.strip("[]").split("%", 1)[0]).is_loopback
    except ValueError:
        return address.lower().rstrip(".") in ("localhost", "localhost.localdomain")


def host_name(host: str) -> str:
    """The name part of a Host header, lower-cased (``[::1]:8443`` -> ``::1``)."""
    host = host.strip().lower()
    if host.startswith("["):
        return host[1:].split("]", 1)[0]
    name = host.rsplit(":", 1)[0] if host.count(":") == 1 else host
    return name.rstrip(".")


def _is_ip(name: str) -> bool:
    try:
        ipaddress.ip_address(name.split("%", 1)[0])
    except ValueError:
        return False
    return True


class HostPolicy:
    """Which ``Host`` names a server bound to ``bind_host`` answers.

    ``allowed`` adds names (``--allow-host``): ``plant.example``; ``.example``
    for it and every name under it; ``*`` for any name (no rebinding defence).
    """

    def __init__(self, bind_host: str, allowed: Iterable[str] = ()) -> None:
        self.loopback_only = is_loopback(bind_host)
        self.allowed = {a.strip().lower().rstrip(".") for a in allowed if a.strip()}
        self.own: set[str] = set()
        if not self.loopback_only:
            self.own = {n.lower() for n in (socket.gethostname(), socket.getfqdn()) if n}

    def allows(self, host: str | None) -> bool:
        """Whether a request with this Host header is answered (None: an HTTP/1.0 client)."""
        if host is None or "*" in self.allowed:
            return True
        name = host_name(host)
        if is_loopback(name) or name in self.allowed or name in self.own:
            return True
        if any(a.startswith(".") and (name == a[1:] or name.endswith(a)) for a in self.allowed):
            return True
        return not self.loopback_only and _is_ip(name)

    def describe(self) -> str:
        """For the start-up log: the names answered."""
        names = list(LOOPBACK_NAMES)
        if not self.loopback_only:
            names += ["this machine's IP addresses", *sorted(self.own)]
        names += sorted(self.allowed)
        return ", ".join(names)

    def refusal(self, host: str) -> str:
        """One line for a refused Host, naming the option that admits it."""
        name = host_name(host)
        return (
            f"Host {name!r} is not served here (a page may be using it to reach this "
            f"server through DNS rebinding); if it is this server's name, start it "
            f"with --allow-host {name} (or LINKVIEW_ALLOW_HOST)"
        )
