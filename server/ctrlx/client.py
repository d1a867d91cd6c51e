"""Async client for the ctrlX identity manager and data layer REST APIs (aiohttp)."""

from __future__ import annotations

import asyncio
import contextlib
import logging
import ssl
from collections.abc import AsyncIterator
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import aiohttp

from ..lateness import PatientTimeout
from .auth import API_PATHS, ApiPaths, ApiVersion, TokenManager
from .bodies import NOT_JSON, Answer, decode, read_bounded
from .connection import connection_error
from .paths import encode_node_path, node_problem
from .problem import BadAddress, DataLayerError, ProblemError, Unsupported, problem_for_status
from .redact import Redactor
from .tls import ca_context, peer_certificate
from .values import BulkRead, bulk_data, bulk_values, number_from_data, numbers_from_data

log = logging.getLogger(__name__)

NAME_MISMATCH = frozenset({62, 64})
"""OpenSSL's X509_V_ERR_HOSTNAME_MISMATCH and X509_V_ERR_IP_ADDRESS_MISMATCH."""
REFUSED = frozenset({404, 405, 501})
"""Statuses with which a server says it has no such service at all."""


@dataclass(frozen=True)
class Credentials:
    """User name and password; the password never appears in ``repr`` or logs."""

    user: str
    password: str = field(repr=False)

    def __repr__(self) -> str:
        return f"Credentials(user={self.user!r}, password=***)"


@dataclass
class Traffic:
    """What this client sent and received, for tests and benchmarks."""

    requests: int = 0
    bytes_in: int = 0
    """Response body bytes, event streams included."""


@dataclass
class Capabilities:
    """Services the server turned out to offer (None: not tried yet, or to be tried again)."""

    bulk: bool | None = None
    subscribe: bool | None = None
    refused_at: dict[str, float] = field(default_factory=dict)
    """``time.monotonic()`` of the last refusal, by path ("subscriptions", "bulk reads")."""


class DataLayerClient:
    """One logged-in session with a ctrlX device (or the mock).

    Logs in lazily and again shortly before the token runs out, sends
    ``Authorization: Bearer``, retries once after a 401 with a fresh token, and
    revokes the token on ``close()``. ``api="v1"`` speaks the older firmware's
    paths, which offer neither bulk reads nor subscriptions. Whatever the
    device answers, no password or token text reaches an error or a log line.

    ``ca_file`` (instead of ``ssl_context``) trusts the certificates in that
    PEM file; it is read before the first request and again after every failed
    connection, so a device certificate renewed in the file needs no restart, and
    a file that cannot serve is an error of this source, not of the server.
    """

    def __init__(
        self,
        base_url: str,
        credentials: Credentials,
        *,
        api: ApiVersion = "v2",
        ssl_context: ssl.SSLContext | bool = True,
        ca_file: Path | None = None,
        timeout_s: float = 5.0,
    ) -> None:
        self.base_url = base_url.rstrip("/")
        self.api = api
        self.paths: ApiPaths = API_PATHS[api]
        self.timeout_s = timeout_s
        self._credentials = credentials
        self.ca_file = ca_file
        self._ssl = ssl_context
        self._own_ssl: ssl.SSLContext | None = None
        self._reread_ca = ca_file is not None
        """Read ``ca_file`` before the next request (first, and after a failed connection)."""
        self._verified = False
        """True once the device passed verification: a later mismatch means it changed."""
        # aiohttp's own timers would count our event loop's lateness against the device:
        # requests are bounded by PatientTimeout in _transport_errors instead.
        self._timeout = aiohttp.ClientTimeout(total=None)
        self._session: aiohttp.ClientSession | None = None
        self.redact = Redactor(credentials.password)
        self.tokens = TokenManager(self._fetch_token)
        self.traffic = Traffic()
        self.failed_starts = 0
        """``follow()`` runs that failed since the last sample (kept across restarts of it)."""
        self.notes: dict[str, str] = {}
        """Standing caveats by topic (a refused service, ...); ``warning`` joins them."""
        self.capabilities = Capabilities(
            bulk=None if self.paths.bulk else False,
            subscribe=None if self.paths.events else False,
        )

    def __repr__(self) -> str:
        user = self._credentials.user
        return f"DataLayerClient({self.base_url!r}, user={user!r}, api={self.api})"

    async def __aenter__(self) -> DataLayerClient:
        return self

    async def __aexit__(self, *exc: object) -> None:
        await self.close()

    @property
    def warning(self) -> str | None:
        """Standing caveats about the device (its clock, refused services), for health.

        Never secret. Assigning sets a caveat of the caller's own (e.g. plain http).
        """
        parts = [self.tokens.warning, *self.notes.values()]
        return "; ".join(p for p in parts if p) or None

    @warning.setter
    def warning(self, text: str | None) -> None:
        self.note("setting", text)

    def note(self, topic: str, text: str | None) -> None:
        """Set (or with None clear) the standing caveat about ``topic``."""
        if text:
            self.notes[topic] = text
        else:
            self.notes.pop(topic, None)

    @property
    def requests(self) -> int:
        """Requests sent so far."""
        return self.traffic.requests

    def _http(self) -> aiohttp.ClientSession:
        if self._session is None or self._session.closed:
            self._session = aiohttp.ClientSession(timeout=self._timeout)
        return self._session

    async def close(self) -> None:
        """Revoke the token (``DELETE .../auth/token``, best effort) and close the session."""
        token = self.tokens.forget()
        if token is not None and self._session is not None and not self._session.closed:
            try:
                async with asyncio.timeout(min(self.timeout_s, 2.0)):
                    await self._send("DELETE", self.paths.token, token=token)
            except (DataLayerError, TimeoutError) as exc:
                log.debug("logout from %s failed: %s", self.base_url, self.redact.text(str(exc)))
        if self._session is not None:
            await self._session.close()
        self._session = None

    async def _fetch_token(self) -> str:
        body = {"name": self._credentials.user, "password": self._credentials.password}
        path = self.paths.token
        try:
            answer = await self._send("POST", path, json=body)
            data = answer.data
            token = data.get("access_token") if isinstance(data, dict) else None
            if isinstance(token, str):
                self.redact.add(token)  # before any message could quote it
            if answer.status in (200, 201) and isinstance(token, str):
                if not _sendable(token):
                    raise DataLayerError(f"login at {path}: the token cannot be sent as a header")
                # Renewals happen every token lifetime; only the first login is news.
                level = logging.INFO if self.tokens.logins == 0 else logging.DEBUG
                log.log(level, "logged in to %s as %s", self.base_url, self._credentials.user)
                return token
            if answer.status < 300:
                # Never quote the body: it may be the token itself, or our password echoed.
                raise DataLayerError(
                    f"login at {path} answered {answer.status} ({answer.describe()}) "
                    "instead of a JSON object with an access_token"
                )
            self._check(f"POST {path}", answer, "login failed")
            raise AssertionError("unreachable")
        except DataLayerError as exc:
            raise self.redact.error(exc) from None

    async def request(self, method: str, path: str, **kwargs: Any) -> Any:
        """Send an authenticated request; returns the decoded JSON body or raises ProblemError."""
        try:
            token = await self.tokens.current()
            answer = await self._send(method, path, token=token, **kwargs)
            if answer.status == 401:
                token = await self.tokens.renew(stale=token, rejected=True)
                answer = await self._send(method, path, token=token, **kwargs)
            if answer.status != 401:
                self.tokens.accepted()
            self._check(f"{method} {path}", answer, f"{method} {path} failed")
        except DataLayerError as exc:
            raise self.redact.error(exc) from None
        return answer.data

    def _check(self, what: str, answer: Answer, failed: str) -> None:
        """Raise the error an answer that is no usable JSON means; summaries, never bodies."""
        if answer.status >= 400:
            data = answer.data
            if isinstance(data, dict) and ("title" in data or "detail" in data):
                raise problem_for_status(answer.status, data, failed)
            summary = f"{answer.reason or 'error'}; answered {answer.describe()}"
            raise problem_for_status(answer.status, summary, failed)
        if 300 <= answer.status < 400:
            where = (answer.location or "elsewhere").split("?", 1)[0]
            raise DataLayerError(
                f"{what}: redirected ({answer.status}) to {where}; give linkview the final URL"
            )
        if answer.data is NOT_JSON:
            raise DataLayerError(
                f"{what}: answered {answer.describe()}; is {self.base_url} a ctrlX CORE?"
            )

    async def _send(
        self, method: str, path: str, *, token: str | None = None, **kwargs: Any
    ) -> Answer:
        headers = {"Authorization": f"Bearer {token}"} if token else {}
        self.traffic.requests += 1
        async with self._transport_errors(method, path):
            async with self._http().request(
                method,
                self.base_url + path,
                headers=headers,
                ssl=self._ssl,
                allow_redirects=False,  # a redirect would carry the token to another host
                **kwargs,
            ) as resp:
                raw = await read_bounded(resp, f"{method} {path}")
                self.traffic.bytes_in += len(raw)
                return _answer(resp, raw)

    @contextlib.asynccontextmanager
    async def _transport_errors(self, method: str, path: str) -> AsyncIterator[None]:
        """Bound a request by ``timeout_s`` (of on-time loop) and turn timeouts and connection
        failures into DataLayerError naming the device."""
        self._fresh_ca()
        try:
            async with PatientTimeout(self.timeout_s):
                yield
            self._verified = True
        except TimeoutError:
            raise self.no_answer(method, path) from None
        except aiohttp.ClientConnectorCertificateError as exc:
            self._reread_ca = True
            raise await self._certificate_error(exc) from None
        except aiohttp.ClientError as exc:
            self._reread_ca = True
            raise connection_error(self.base_url, exc) from None

    def no_answer(self, method: str, path: str) -> DataLayerError:
        """The error for a request the device did not answer within ``timeout_s``."""
        self._reread_ca = True
        return DataLayerError(
            f"{method} {path}: no answer from {self.base_url} within {self.timeout_s:g} s"
        )

    def stream_ssl(self) -> ssl.SSLContext:
        """The TLS context for a connection of our own to the device (see stream_wire)."""
        self._fresh_ca()
        if isinstance(self._ssl, ssl.SSLContext):
            return self._ssl
        if self._own_ssl is None:  # what aiohttp makes of ssl=True (verify) and False (don't)
            self._own_ssl = ssl.create_default_context()
            if self._ssl is False:
                self._own_ssl.check_hostname = False
                self._own_ssl.verify_mode = ssl.CERT_NONE
        return self._own_ssl

    def _fresh_ca(self) -> None:
        """Read the CA file again after a failed connection (the device may have a new one)."""
        if not self._reread_ca or self.ca_file is None:
            return
        try:
            self._ssl = ca_context(self.ca_file)
        except ValueError as exc:
            raise DataLayerError(str(exc)) from None
        self._reread_ca = False

    async def _certificate_error(
        self, exc: aiohttp.ClientConnectorCertificateError
    ) -> DataLayerError:
        """Why the device's certificate failed, naming the certificate it presents."""
        reason = getattr(exc.certificate_error, "verify_message", None) or exc.certificate_error
        peer = await peer_certificate(self.base_url, self.timeout_s)
        presents = f"it presents {peer}" if peer else "its certificate could not be fetched"
        if getattr(exc.certificate_error, "verify_code", None) in NAME_MISMATCH:
            return DataLayerError(
                f"the TLS certificate of {self.base_url} is not made out to that name or "
                f"address ({reason}); {presents}; use the host name the certificate names"
            )
        if self.ca_file is None:
            return DataLayerError(
                f"cannot verify the TLS certificate of {self.base_url} ({reason}); {presents}; "
                "pass the device's certificate with --ctrlx-ca FILE"
            )
        match = "no longer matches" if self._verified else "does not match"
        return DataLayerError(
            f"the TLS certificate of {self.base_url} {match} the CA file {self.ca_file} "
            f"({reason}); {presents}; if that is the device's new certificate, put it in "
            "that file (it is read again at the next attempt)"
        )

    async def open_stream(
        self, path: str, *, params: dict[str, str] | None = None
    ) -> aiohttp.ClientResponse:
        """Start a ``text/event-stream`` GET; the caller reads and releases the response.

        Only connecting and the response head are bounded by the request
        timeout; the stream itself is watched by its reader (keepalive).
        """
        try:
            return await self._open_stream(path, params)
        except DataLayerError as exc:
            raise self.redact.error(exc) from None

    async def _open_stream(
        self, path: str, params: dict[str, str] | None
    ) -> aiohttp.ClientResponse:
        # No read timeout: the stream is watched by its reader (keepalive).
        timeout = aiohttp.ClientTimeout(total=None, sock_read=None)
        token = await self.tokens.current()
        for attempt in (1, 2):
            self.traffic.requests += 1
            async with self._transport_errors("GET", path):
                resp = await self._http().get(
                    self.base_url + path,
                    params=params,
                    headers={
                        "Authorization": f"Bearer {token}",
                        "Accept": "text/event-stream",
                    },
                    ssl=self._ssl,
                    timeout=timeout,
                    allow_redirects=False,
                )
            if resp.status == 200 and resp.content_type == "text/event-stream":
                self.tokens.accepted()
                return resp
            try:
                async with self._transport_errors("GET", path):
                    raw = await read_bounded(resp, f"GET {path}")
            except DataLayerError:
                raw = b""
            finally:
                resp.release()
            self.traffic.bytes_in += len(raw)
            answer = _answer(resp, raw)
            if resp.status == 401 and attempt == 1:
                token = await self.tokens.renew(stale=token, rejected=True)
                continue
            if resp.status != 401:
                self.tokens.accepted()
            if resp.status in REFUSED or resp.status == 200:
                raise Unsupported(
                    f"GET {path}: no event stream ({resp.status}, {answer.describe()})"
                )
            self._check(f"GET {path}", answer, "GET failed")
            raise DataLayerError(f"GET {path}: answered {resp.status} instead of an event stream")
        raise AssertionError("unreachable")

    # -- nodes ---------------------------------------------------------------

    def node_url_path(self, node: str) -> str:
        """The request path of ``node`` (each segment percent-encoded); BadAddress if refused."""
        problem = node_problem(node)
        if problem is not None:
            raise BadAddress(f"{node!r}: not requested: {problem}")
        return self.paths.nodes + encode_node_path(node)

    async def read(self, node: str) -> Any:
        """The raw Data body of ``node`` (``GET .../nodes/{path}``)."""
        return await self.request("GET", self.node_url_path(node))

    async def read_number(self, node: str) -> float:
        """Read one numeric node; raises NodeNotFound, BadValue or another DataLayerError."""
        body = await self.read(node)
        try:
            return number_from_data(node, body)
        except DataLayerError as exc:
            raise self.redact.error(exc) from None

    async def read_numbers(self, node: str) -> list[float]:
        """Read one float-array node (``arfloat64`` and kin)."""
        body = await self.read(node)
        try:
            return numbers_from_data(node, body)
        except DataLayerError as exc:
            raise self.redact.error(exc) from None

    async def browse(self, node: str) -> list[str]:
        """Names of the children of ``node`` (``?type=browse``)."""
        body = await self.request("GET", self.node_url_path(node), params={"type": "browse"})
        value = body.get("value") if isinstance(body, dict) else None
        return [str(v) for v in value] if isinstance(value, list) else []

    async def metadata(self, node: str) -> dict[str, Any]:
        """The metadata of ``node`` (``?type=metadata``)."""
        body = await self.request("GET", self.node_url_path(node), params={"type": "metadata"})
        value = body.get("value") if isinstance(body, dict) else None
        return value if isinstance(value, dict) else {}

    async def write(self, node: str, type_: str, value: Any) -> Any:
        """Write ``value`` of data-layer type ``type_`` to ``node`` (``PUT .../nodes/{path}``)."""
        body = {"type": type_, "value": value}
        return await self.request("PUT", self.node_url_path(node), json=body)

    async def bulk_read(self, nodes: list[str]) -> BulkRead:
        """Read every node in one round trip (``PUT .../bulk?type=read``).

        A node that fails holds its error; raises Unsupported if the server has
        no bulk service.
        """
        read = bulk_values(nodes, await self._bulk("read", nodes))
        for value in read.values.values():
            if isinstance(value, Exception):
                self.redact.error(value)
        return read

    async def bulk(self, kind: str, nodes: list[str]) -> list[Any]:
        """Each node's Data (``{"type", "value"}``) from one ``PUT .../bulk?type=<kind>``
        (``read``, ``metadata``, ``browse``); a node that failed holds its ProblemError.

        Raises Unsupported if the server has no bulk service.
        """
        entries = await self._bulk(kind, nodes)
        return [self.redact.error(e) if isinstance(e, Exception) else e
                for e in bulk_data(nodes, entries)]  # fmt: skip

    async def _bulk(self, kind: str, nodes: list[str]) -> Any:
        if self.paths.bulk is None or self.capabilities.bulk is False:
            raise Unsupported("this data layer has no bulk service")
        try:
            body = [{"address": n} for n in nodes]
            entries = await self.request("PUT", self.paths.bulk, params={"type": kind}, json=body)
        except ProblemError as exc:
            if exc.status in REFUSED:
                self.capabilities.bulk = False
                raise Unsupported(f"bulk {kind} refused: {exc}") from None
            raise
        self.capabilities.bulk = True
        return entries


def _answer(resp: aiohttp.ClientResponse, raw: bytes) -> Answer:
    return Answer(
        status=resp.status,
        reason=resp.reason or "",
        content_type=resp.content_type,
        size=len(raw),
        data=decode(resp.content_type, raw),
        location=resp.headers.get("Location"),
    )


def _sendable(token: str) -> bool:
    """True for a token that fits an HTTP header (RFC 6750 b64token, plus what JWTs use)."""
    return bool(token) and token.isascii() and token.isprintable() and " " not in token


__all__ = ["BulkRead", "Capabilities", "Credentials", "DataLayerClient", "Traffic"]
