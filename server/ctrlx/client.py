"""Async client for the ctrlX identity manager and data layer REST APIs (aiohttp)."""

from __future__ import annotations

import asyncio
import logging
import ssl
from dataclasses import dataclass
from typing import Any

import aiohttp

from .paths import encode_node_path
from .problem import AuthError, DataLayerError, problem_for_status
from .values import number_from_data

log = logging.getLogger(__name__)

TOKEN_PATH = "/identity-manager/api/v2/auth/token"
NODES_PATH = "/automation/api/v2/nodes/"


@dataclass(frozen=True)
class Credentials:
    """User name and password; the password never appears in ``repr`` or logs."""

    user: str
    password: str

    def __repr__(self) -> str:
        return f"Credentials(user={self.user!r}, password=***)"


class DataLayerClient:
    """One logged-in session with a ctrlX device (or the mock).

    Logs in lazily, sends ``Authorization: Bearer``, and logs in once more when
    a request answers 401 (an expired or revoked token).
    """

    def __init__(
        self,
        base_url: str,
        credentials: Credentials,
        *,
        ssl_context: ssl.SSLContext | bool = True,
        timeout_s: float = 5.0,
    ) -> None:
        self.base_url = base_url.rstrip("/")
        self._credentials = credentials
        self._ssl = ssl_context
        self._timeout = aiohttp.ClientTimeout(total=timeout_s)
        self._session: aiohttp.ClientSession | None = None
        self._token: str | None = None
        self._login_lock = asyncio.Lock()
        self.requests = 0
        """Requests sent so far (for traffic accounting in tests and benchmarks)."""

    async def __aenter__(self) -> DataLayerClient:
        return self

    async def __aexit__(self, *exc: object) -> None:
        await self.close()

    def _http(self) -> aiohttp.ClientSession:
        if self._session is None or self._session.closed:
            self._session = aiohttp.ClientSession(timeout=self._timeout)
        return self._session

    async def close(self) -> None:
        """Close the HTTP session."""
        if self._session is not None:
            await self._session.close()
        self._session = None
        self._token = None

    async def login(self) -> None:
        """Fetch a new bearer token; raises AuthError on wrong credentials."""
        body = {"name": self._credentials.user, "password": self._credentials.password}
        status, data = await self._send("POST", TOKEN_PATH, json=body, auth=False)
        if status != 201 or not isinstance(data, dict) or "access_token" not in data:
            raise problem_for_status(status, data, "login failed")
        self._token = str(data["access_token"])
        log.info("logged in to %s as %s", self.base_url, self._credentials.user)

    async def _ensure_token(self, stale: str | None = None) -> str:
        async with self._login_lock:
            # Several readers may see the same 401; only the first logs in again.
            if self._token is None or self._token == stale:
                await self.login()
            assert self._token is not None
            return self._token

    async def request(self, method: str, path: str, **kwargs: Any) -> Any:
        """Send an authenticated request; returns the decoded JSON body or raises ProblemError."""
        token = await self._ensure_token()
        status, data = await self._send(method, path, token=token, **kwargs)
        if status == 401:
            token = await self._ensure_token(stale=token)
            status, data = await self._send(method, path, token=token, **kwargs)
        if status >= 400:
            raise problem_for_status(status, data, f"{method} {path} failed")
        return data

    async def _send(
        self, method: str, path: str, *, token: str | None = None, auth: bool = True, **kwargs: Any
    ) -> tuple[int, Any]:
        headers = {"Authorization": f"Bearer {token}"} if auth and token else {}
        self.requests += 1
        try:
            async with self._http().request(
                method, self.base_url + path, headers=headers, ssl=self._ssl, **kwargs
            ) as resp:
                data: Any = None
                if resp.content_type == "application/json" or resp.content_type.endswith("+json"):
                    data = await resp.json(content_type=None)
                else:
                    data = (await resp.text()) or None
                return resp.status, data
        except TimeoutError as exc:
            raise DataLayerError(f"{method} {path}: no answer from {self.base_url}") from exc
        except aiohttp.ClientError as exc:
            raise DataLayerError(f"cannot reach {self.base_url}: {exc}") from exc

    async def read_number(self, node: str) -> float:
        """Read one numeric node (``GET /automation/api/v2/nodes/{path}``)."""
        return number_from_data(
            node, await self.request("GET", NODES_PATH + encode_node_path(node))
        )


__all__ = ["AuthError", "Credentials", "DataLayerClient"]
