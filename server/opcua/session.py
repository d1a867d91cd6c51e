"""One OPC UA session (asyncua's Client): security, login, keep-alive, failures named.

A session is opened with the cell's security mode (``None``, or ``Basic256Sha256``
with ``Sign`` or ``SignAndEncrypt``), the user and password where the cell gives
them (anonymous otherwise). asyncua's watchdog reads the server's state every
``keepalive_s``: a dead connection or a session the server dropped
(``BadSessionIdInvalid``) ends the session's ``lost`` future with the reason. We
reconnect ourselves (asyncua's auto-reconnect is off): the acquisition follows
the source again, so a server restart is a new session, resolved afresh.
"""

from __future__ import annotations

import asyncio
import contextlib
import logging
from dataclasses import dataclass, field
from pathlib import Path
from typing import Literal
from urllib.parse import urlsplit

from asyncua import ua
from asyncua.client.client import Client
from asyncua.crypto import uacrypto
from asyncua.crypto.security_policies import SecurityPolicyBasic256Sha256
from asyncua.ua.uaerrors import UaStatusCodeError
from cryptography import x509

from ..sources import SourceError
from .security import (
    CLIENT_CERTIFICATE,
    CLIENT_URI,
    client_identity,
    first_certificate,
    is_trusted,
    load_certificates,
    refusal,
    save_refused,
    thumbprint,
)

log = logging.getLogger(__name__)
# asyncua logs every connection step at INFO (and a password sent in clear as a bare
# warning): our own log says what matters, once, with the source's name.
logging.getLogger("asyncua").setLevel(logging.ERROR)

SecurityMode = Literal["None", "Sign", "SignAndEncrypt"]
SECURITY_MODES: tuple[SecurityMode, ...] = ("None", "Sign", "SignAndEncrypt")
POLICY = SecurityPolicyBasic256Sha256
SESSION_TIMEOUT_MS = 30_000
"""A session the server keeps for us after we vanish (it then frees our subscription)."""
CLOSE_S = 1.0
"""How long a closing session may take (a stalled server does not answer)."""


@dataclass(frozen=True)
class OpcuaSettings:
    """How to reach one OPC UA server (``opc.tcp://host:port[/path]``)."""

    url: str
    source: str = "opcua"
    """The cell's name for it (in messages, and the file a refused certificate is saved to)."""
    security: SecurityMode = "None"
    user: str | None = None
    password: str | None = field(default=None, repr=False)
    server_certificate: Path | None = None
    """The server certificate(s) to trust (PEM or DER); None: refuse any, naming it."""
    client_certificate: Path = Path(CLIENT_CERTIFICATE)
    """linkview's own certificate (made there once), for Sign and SignAndEncrypt."""
    timeout_s: float = 5.0
    keepalive_s: float = 1.0
    """How often the server's state is read to know the session is alive."""


def check_opcua_url(url: str) -> str:
    """``url`` if it is an ``opc.tcp://host[:port][/path]`` address; else ValueError saying why."""
    parts = urlsplit(url)
    if parts.scheme != "opc.tcp":
        raise ValueError(f"an OPC UA server's address starts with opc.tcp://, not {url!r}")
    try:
        parts.port  # noqa: B018 (raises ValueError for a port that is no number)
    except ValueError:
        raise ValueError(f"{url!r} has no valid port") from None
    if not parts.hostname:
        raise ValueError(f"{url!r} names no host")
    return url


class Session:
    """An open session; ``lost`` completes with the reason when the session is gone."""

    def __init__(self, client: Client, settings: OpcuaSettings, warning: str | None) -> None:
        self.client = client
        self.settings = settings
        self.warning = warning
        """A standing caveat (a password sent unencrypted)."""
        self.lost: asyncio.Future[str] = asyncio.get_running_loop().create_future()
        client.connection_lost_callback = self._on_lost

    async def _on_lost(self, exc: Exception) -> None:
        self.lose(exc)

    def lose(self, exc: Exception) -> None:
        """The session cannot go on because of ``exc`` (named as the user needs it)."""
        if isinstance(exc, TimeoutError):  # asyncua's keep-alive read went unanswered
            why = "the server stopped answering (its keep-alive read timed out)"
        elif isinstance(exc, ConnectionError) and not isinstance(exc, ConnectionRefusedError):
            why = "the connection closed (the server restarted or went away)"
        else:
            why = describe_failure(exc, self.settings)
        self.mark_lost(why)

    def mark_lost(self, why: str) -> None:
        """The session cannot go on (the first reason given is kept)."""
        if not self.lost.done():
            self.lost.set_result(why)

    async def close(self) -> None:
        """Close the session and the connection (promptly, also when the server is gone)."""
        with contextlib.suppress(Exception):
            await asyncio.wait_for(self.client.disconnect(), CLOSE_S)
        self.client.disconnect_socket()


async def open_session(settings: OpcuaSettings) -> Session:
    """A session with the server; raises SourceError naming what failed."""
    client = Client(
        settings.url, timeout=settings.timeout_s, watchdog_intervall=settings.keepalive_s
    )
    client.application_uri = CLIENT_URI
    client.name = client.description = "linkview"
    client.session_timeout = SESSION_TIMEOUT_MS
    if settings.user is not None:
        client.set_user(settings.user)
        client.set_password(settings.password or "")
    try:
        async with asyncio.timeout(2 * settings.timeout_s):
            if settings.security != "None":
                await _secure(client, settings)
            await client.connect()
    except SourceError:
        client.disconnect_socket()
        raise
    except (Exception, TimeoutError) as exc:
        client.disconnect_socket()
        raise SourceError(f"{settings.url}: {describe_failure(exc, settings)}") from None
    return Session(client, settings, _password_warning(client, settings))


async def _secure(client: Client, settings: OpcuaSettings) -> None:
    """Basic256Sha256 in the cell's mode, if the server offers it and its certificate is trusted."""
    mode = getattr(ua.MessageSecurityMode, settings.security)
    endpoints = await client.connect_and_get_server_endpoints()
    offered = [e for e in endpoints if e.SecurityMode == mode and e.SecurityPolicyUri == POLICY.URI]
    if not offered:
        has = sorted({f"{_policy(e.SecurityPolicyUri)} {e.SecurityMode.name}" for e in endpoints})
        raise SourceError(
            f"{settings.url}: the server offers no Basic256Sha256 {settings.security} endpoint "
            f"(it offers: {', '.join(has) or 'none'})"
        )
    der = first_certificate(offered[0].ServerCertificate or b"")
    trusted = [] if settings.server_certificate is None else _trusted(settings)
    if not is_trusted(der, trusted):
        folder = settings.client_certificate.parent
        saved = save_refused(der, folder, settings.source)
        raise SourceError(f"{settings.url}: {refusal(der, saved, settings.source)}")
    try:
        identity = await client_identity(settings.client_certificate)
    except OSError as exc:
        raise SourceError(
            f"{settings.url}: cannot keep linkview's certificate at {settings.client_certificate}: "
            f"{exc.strerror or exc}"
        ) from None
    await client.set_security(
        POLICY,
        str(identity.certificate),
        str(identity.key),
        server_certificate=uacrypto.CertProperties(der, extension="der"),
        mode=mode,
    )


def _trusted(settings: OpcuaSettings) -> list[x509.Certificate]:
    assert settings.server_certificate is not None
    try:
        return list(load_certificates(settings.server_certificate))
    except ValueError as exc:
        raise SourceError(f"{settings.url}: server_certificate: {exc}") from None


def _policy(uri: str | None) -> str:
    return (uri or "").rsplit("#", 1)[-1] or "None"


def _password_warning(client: Client, settings: OpcuaSettings) -> str | None:
    """A caveat when the password crosses the network readable by anyone on the way."""
    if settings.user is None or settings.security != "None":
        return None
    try:
        policy = client.server_policy(ua.UserTokenType.UserName)
    except Exception:  # asyncua found no UserName policy: the login went anonymous or failed
        return None
    if _policy(policy.SecurityPolicyUri) == "None":
        return "the password is sent unencrypted (security None, and the server encrypts no login)"
    return None


def status_name(code: int) -> str:
    """``BadNodeIdUnknown`` for its status code."""
    return ua.StatusCode(ua.UInt32(code)).name


def describe_failure(exc: BaseException, settings: OpcuaSettings) -> str:
    """What went wrong, with OPC UA's name for it and what to do."""
    if isinstance(exc, UaStatusCodeError):
        name = status_name(exc.code)
        hint = _HINTS.get(name)
        if name == "BadUserAccessDenied" and settings.user is None:
            hint = "the server refuses anonymous sessions: give user and password_env"
        elif name == "BadUserAccessDenied":
            hint = f"the server refused user {settings.user!r} (wrong user or password?)"
        elif hint is not None and "{client}" in hint:
            der = _own_certificate(settings.client_certificate)
            print_ = f", thumbprint {thumbprint(der)}" if der else ""
            hint = hint.format(client=f"{settings.client_certificate}{print_}")
        doc = ua.StatusCode(ua.UInt32(exc.code)).doc.rstrip(".")
        return f"{name}: {hint or doc}"
    if isinstance(exc, TimeoutError | asyncio.TimeoutError):
        return f"no answer within {settings.timeout_s:g} s"
    if isinstance(exc, ConnectionRefusedError):
        return "connection refused (is the server running, and is that its port?)"
    if isinstance(exc, ConnectionError | OSError):
        return (
            f"connection lost: {exc.strerror if isinstance(exc, OSError) and exc.strerror else exc}"
        )
    return f"{type(exc).__name__}: {exc}"


_HINTS = {
    "BadSessionIdInvalid": "the server no longer knows the session (it restarted or dropped it)",
    "BadSessionClosed": "the server closed the session",
    "BadIdentityTokenRejected": "the server does not accept this kind of login",
    "BadIdentityTokenInvalid": "the server does not accept this kind of login",
    "BadCertificateUntrusted": "the server does not trust linkview's certificate ({client}): "
    "trust it on the server",
    "BadSecurityChecksFailed": "the server refused the secure channel; does it trust linkview's "
    "certificate ({client})?",
    "BadShutdown": "the server is shutting down",
    "BadTooManySessions": "the server has no room for another session",
}


def _own_certificate(path: Path) -> bytes | None:
    try:
        return path.read_bytes()
    except OSError:
        return None
