"""Who may connect: the Host a request names, the Origin a browser names, the viewer token.

One set of rules for every door of the server: the web layer's
``Gatekeeper`` (the page, ``/ws``, ``/api``) and the Foxglove endpoint's
guard both ask an ``Access``, each from the headers it reads its own way.

* ``Host`` must be a name this server answers (``hosts.HostPolicy``): a page
  that reached it through DNS rebinding names its own domain there.
* ``Origin``, where a browser sends one, must be the server's own origin or
  one given with ``--allow-origin``; ``null`` (a sandboxed frame, a file:
  page, a redirect across sites) never is. A missing Origin is a client that
  is not a browser, which the token (if any) guards.
* The token comes as a ``?token=`` query, an ``Authorization: Bearer``
  header, or the page's cookie, and is compared in constant time.
"""

from __future__ import annotations

import secrets
from collections.abc import Iterable
from http.cookies import CookieError, SimpleCookie
from urllib.parse import parse_qs, urlsplit

from .hosts import HostPolicy

TOKEN_COOKIE = "linkview_token"


def origin_of(url: str) -> str:
    """``scheme://host[:port]`` of a URL, lower-cased, default ports dropped."""
    parts = urlsplit(url.strip())
    scheme = (parts.scheme or "http").lower()
    host = (parts.hostname or "").lower()
    default = {"http": 80, "https": 443, "ws": 80, "wss": 443}.get(scheme)
    port = "" if parts.port in (None, default) else f":{parts.port}"
    return f"{scheme}://{host}{port}"


def token_given(
    query: str, authorization: str | None, cookie: str | None
) -> tuple[str | None, bool]:
    """The token a request carries, and whether it came in the query (then set as a cookie)."""
    found = parse_qs(query)
    if "token" in found:
        return found["token"][0], True
    if authorization is not None and authorization.lower().startswith("bearer "):
        return authorization[7:].strip(), False
    try:
        morsel = SimpleCookie(cookie or "").get(TOKEN_COOKIE)
    except CookieError:
        return None, False
    return (morsel.value if morsel is not None else None), False


class Access:
    """The rules above for one server: its token, the origins and the hosts it allows."""

    def __init__(
        self,
        token: str | None = None,
        allowed_origins: Iterable[str] = (),
        hosts: HostPolicy | None = None,
    ) -> None:
        self.token = token or None
        self.allowed = {origin_of(o) for o in allowed_origins}
        self.hosts = hosts or HostPolicy("127.0.0.1")

    def host_refusal(self, host: str | None) -> str | None:
        """Why a request naming ``host`` is refused (403), None if it is answered."""
        return None if self.hosts.allows(host) else self.hosts.refusal(host or "")

    def origin_ok(self, origin: str | None, host: str | None, secure: bool) -> bool:
        """Whether a request from ``origin`` to ``host`` (over TLS: ``secure``) may go on."""
        if origin is None:
            return True
        if origin == "null":
            return False
        scheme = "https" if secure else "http"
        try:
            own = origin_of(f"{scheme}://{host or ''}")
            return origin_of(origin) in self.allowed | {own}
        except ValueError:  # a malformed Origin or Host (a bad port, an open bracket)
            return False

    def token_ok(self, given: str | None) -> bool:
        """True without a token set; else whether ``given`` is it."""
        if self.token is None:
            return True
        return given is not None and secrets.compare_digest(given.encode(), self.token.encode())
