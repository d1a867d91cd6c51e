"""Async client for the ctrlX identity manager and data layer REST APIs (aiohttp)."""

from __future__ import annotations

import asyncio
import contextlib
import logging
import os
import ssl
from collections.abc import Iterator
from dataclasses import dataclass, field
from typing import Any

import aiohttp
import orjson

from .auth import API_PATHS, ApiPaths, ApiVersion, TokenManager
from .paths import encode_node_path
from .problem import (
    DataLayerError,
    ProblemError,
    Unsupported,
    problem_for_result,
    problem_for_status,
)
from .timestamps import parse_filetime
from .values import number_from_data, numbers_from_data

log = logging.getLogger(__name__)

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
    """Services the server turned out to offer (None: not tried yet)."""

    bulk: bool | None = None
    subscribe: bool | None = None


@dataclass(frozen=True)
class BulkRead:
    """Values of one bulk read, in request order, and when the data layer sampled them."""

    t_source: float | None
    """Unix time from the answer's FILETIME stamps (the newest); None if it had none."""
    values: dict[str, float | Exception]


class DataLayerClient:
    """One logged-in session with a ctrlX device (or the mock).

    Logs in lazily and again shortly before the token expires, sends
    ``Authorization: Bearer``, retries once after a 401 with a fresh token, and
    revokes the token on ``close()``. ``api="v1"`` speaks the older firmware's
    paths, which offer neither bulk reads nor subscriptions.
    """

    def __init__(
        self,
        base_url: str,
        credentials: Credentials,
        *,
        api: ApiVersion = "v2",
        ssl_context: ssl.SSLContext | bool = True,
        timeout_s: float = 5.0,
    ) -> None:
        self.base_url = base_url.rstrip("/")
        self.api = api
        self.paths: ApiPaths = API_PATHS[api]
        self.timeout_s = timeout_s
        self._credentials = credentials
        self._ssl = ssl_context
        self._timeout = aiohttp.ClientTimeout(total=timeout_s)
        self._session: aiohttp.ClientSession | None = None
        self.tokens = TokenManager(self._fetch_token)
        self.traffic = Traffic()
        self.warning: str | None = None
        """A standing caveat about the device (e.g. its clock), shown in health; never secret."""
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
                log.debug("logout from %s failed: %s", self.base_url, exc)
        if self._session is not None:
            await self._session.close()
        self._session = None

    async def _fetch_token(self) -> str:
        body = {"name": self._credentials.user, "password": self._credentials.password}
        status, data = await self._send("POST", self.paths.token, json=body)
        if status not in (200, 201) or not isinstance(data, dict) or "access_token" not in data:
            raise problem_for_status(status, data, "login failed")
        # Renewals happen every token lifetime; only the first login is news.
        level = logging.INFO if self.tokens.logins == 0 else logging.DEBUG
        log.log(level, "logged in to %s as %s", self.base_url, self._credentials.user)
        return str(data["access_token"])

    async def request(self, method: str, path: str, **kwargs: Any) -> Any:
        """Send an authenticated request; returns the decoded JSON body or raises ProblemError."""
        token = await self.tokens.current()
        status, data = await self._send(method, path, token=token, **kwargs)
        if status == 401:
            token = await self.tokens.renew(stale=token)
            status, data = await self._send(method, path, token=token, **kwargs)
        if status >= 400:
            raise problem_for_status(status, data, f"{method} {path} failed")
        return data

    async def _send(
        self, method: str, path: str, *, token: str | None = None, **kwargs: Any
    ) -> tuple[int, Any]:
        headers = {"Authorization": f"Bearer {token}"} if token else {}
        self.traffic.requests += 1
        with self._transport_errors(method, path):
            async with self._http().request(
                method, self.base_url + path, headers=headers, ssl=self._ssl, **kwargs
            ) as resp:
                raw = await resp.read()
                self.traffic.bytes_in += len(raw)
                return resp.status, _decode(resp.content_type, raw)

    @contextlib.contextmanager
    def _transport_errors(self, method: str, path: str) -> Iterator[None]:
        """Turn timeouts and connection failures into DataLayerError naming the device."""
        try:
            yield
        except TimeoutError as exc:
            raise DataLayerError(
                f"{method} {path}: no answer from {self.base_url} within {self.timeout_s:g} s"
            ) from exc
        except aiohttp.ClientError as exc:
            raise connection_error(self.base_url, exc) from exc

    async def open_stream(
        self, path: str, *, params: dict[str, str] | None = None
    ) -> aiohttp.ClientResponse:
        """Start a ``text/event-stream`` GET; the caller reads and releases the response.

        Only connecting and the response head are bounded by the request
        timeout; the stream itself is watched by its reader (keepalive).
        """
        timeout = aiohttp.ClientTimeout(total=None, sock_connect=self.timeout_s, sock_read=None)
        token = await self.tokens.current()
        for attempt in (1, 2):
            self.traffic.requests += 1
            with self._transport_errors("GET", path):
                async with asyncio.timeout(self.timeout_s):
                    resp = await self._http().get(
                        self.base_url + path,
                        params=params,
                        headers={
                            "Authorization": f"Bearer {token}",
                            "Accept": "text/event-stream",
                        },
                        ssl=self._ssl,
                        timeout=timeout,
                    )
            if resp.status == 200 and resp.content_type == "text/event-stream":
                return resp
            try:
                raw = await resp.read()
            except aiohttp.ClientError:
                raw = b""
            finally:
                resp.release()
            self.traffic.bytes_in += len(raw)
            if resp.status == 401 and attempt == 1:
                token = await self.tokens.renew(stale=token)
                continue
            if resp.status in REFUSED or resp.status == 200:
                raise Unsupported(f"GET {path}: no event stream ({resp.status})")
            raise problem_for_status(resp.status, _decode(resp.content_type, raw), "GET failed")
        raise AssertionError("unreachable")

    # -- nodes ---------------------------------------------------------------

    def node_url_path(self, node: str) -> str:
        """The request path of ``node`` (each segment percent-encoded)."""
        return self.paths.nodes + encode_node_path(node)

    async def read(self, node: str) -> Any:
        """The raw Data body of ``node`` (``GET .../nodes/{path}``)."""
        return await self.request("GET", self.node_url_path(node))

    async def read_number(self, node: str) -> float:
        """Read one numeric node; raises NodeNotFound, BadValue or another DataLayerError."""
        return number_from_data(node, await self.read(node))

    async def read_numbers(self, node: str) -> list[float]:
        """Read one float-array node (``arfloat64`` and kin)."""
        return numbers_from_data(node, await self.read(node))

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
        if self.paths.bulk is None or self.capabilities.bulk is False:
            raise Unsupported("this data layer has no bulk service")
        try:
            body = [{"address": n} for n in nodes]
            entries = await self.request("PUT", self.paths.bulk, params={"type": "read"}, json=body)
        except ProblemError as exc:
            if exc.status in REFUSED:
                self.capabilities.bulk = False
                raise Unsupported(f"bulk read refused: {exc}") from exc
            raise
        self.capabilities.bulk = True
        return _bulk_values(nodes, entries)


def _bulk_values(nodes: list[str], entries: Any) -> BulkRead:
    if not isinstance(entries, list) or len(entries) != len(nodes):
        raise DataLayerError(f"bulk read answered {type(entries).__name__}, not {len(nodes)} items")
    values: dict[str, float | Exception] = {}
    stamps: list[float] = []
    for node, entry in zip(nodes, entries, strict=True):
        if not isinstance(entry, dict):
            values[node] = DataLayerError(f"{node}: bulk answer item is not an object")
            continue
        stamp = parse_filetime(entry.get("timestamp"))
        if stamp is not None:
            stamps.append(stamp)
        result = str(entry.get("result", "DL_OK"))
        if result != "DL_OK" or entry.get("type") == "error":
            values[node] = problem_for_result(node, result, entry.get("value"))
            continue
        try:
            values[node] = number_from_data(node, entry)
        except DataLayerError as exc:
            values[node] = exc
    return BulkRead(max(stamps) if stamps else None, values)


def _decode(content_type: str, raw: bytes) -> Any:
    if not raw:
        return None
    if content_type == "application/json" or content_type.endswith("+json"):
        try:
            return orjson.loads(raw)
        except orjson.JSONDecodeError:
            pass
    return raw.decode("utf-8", "replace")


def connection_error(base_url: str, exc: aiohttp.ClientError) -> DataLayerError:
    """A readable error for a failed connection; TLS trouble says how to fix it."""
    if isinstance(exc, aiohttp.ClientConnectorCertificateError):
        return DataLayerError(
            f"cannot verify the TLS certificate of {base_url} ({exc.certificate_error}); "
            "pass the device's certificate with --ctrlx-ca FILE"
        )
    if isinstance(exc, aiohttp.ClientSSLError):
        return DataLayerError(f"TLS handshake with {base_url} failed: {exc}")
    if isinstance(exc, aiohttp.ClientConnectorError):
        # aiohttp's own text names its internals; the OS error is what people can act on.
        errno = exc.os_error.errno or 0  # negative: a resolver (gai) code, no strerror
        reason = os.strerror(errno) if errno > 0 else exc.os_error.strerror or str(exc.os_error)
        return DataLayerError(f"cannot reach {base_url}: {reason.lower()}")
    return DataLayerError(f"cannot reach {base_url}: {exc or type(exc).__name__}")


__all__ = ["BulkRead", "Capabilities", "Credentials", "DataLayerClient", "Traffic"]
