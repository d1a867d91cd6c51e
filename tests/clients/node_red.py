"""A client that calls the ctrlX API exactly as Bosch Rexroth's Node-RED nodes do.

``node-red-contrib-ctrlx-automation`` could not be installed here (the npm
registry answers 404 for it), so its requests are imitated, from reading its
``lib/CtrlxCore.js``, ``lib/CtrlxDatalayerV2.js``, ``lib/CtrlxDatalayerSubscription.js``,
``lib/CtrlxProblemError.js`` and ``ctrlx-config-subscription.js``:

* raw HTTPS requests (Node's ``https.request``; self-signed certificates
  accepted), paths built with JavaScript's ``encodeURI``, the library's
  headers (``Accept``, ``Connection: keep-alive``, ``Content-Length``) and no
  body at all for empty-argument writes and creates;
* success only on the statuses it checks: 201 login, 204 logout, 200 read
  and write, 200/201 create, 200/204 delete, 200/201/204 subscription;
* subscriptions created with ``POST /automation/api/v2/events/`` (trailing
  slash) with an id ``node-red-<uuid>`` and the node's settings as Node-RED
  keeps them (strings), then streamed from ``/automation/api/v2/events/<id>``
  with an EventSource's headers, never deleted (the device lets them expire);
* ``update`` events dispatched by ``data.node``, ``error`` events turned into
  a problem and dispatched by its ``instance`` to the one node it names; an
  error naming no subscribed node goes to every node and resets the
  subscription.
"""

from __future__ import annotations

import base64
import http.client
import json
import ssl
import time
import uuid
from collections.abc import Callable
from dataclasses import dataclass, field
from typing import Any
from urllib.parse import quote

ENCODE_URI_SAFE = ";,/?:@&=+$-_.!~*'()#"
"""What JavaScript's ``encodeURI`` leaves as it is (besides letters and digits)."""
FILETIME_EPOCH_MS = 11644473600000


def encode_uri(text: str) -> str:
    """JavaScript's ``encodeURI``."""
    return quote(text, safe=ENCODE_URI_SAFE)


def filetime_to_ms(timestamp: int) -> int:
    """``convertTimestamp2Javascript``: FILETIME to milliseconds since 1970."""
    return round(timestamp / 10000) - FILETIME_EPOCH_MS


@dataclass
class CtrlxProblemError(Exception):
    """The library's error: the Problem's fields, or only the status for an empty body."""

    status: int | None
    title: str | None = None
    type: str | None = None
    detail: str | None = None
    instance: str | None = None
    main_diagnosis_code: str | None = None
    detailed_diagnosis_code: str | None = None
    dynamic_description: str | None = None
    severity: str | None = None

    @classmethod
    def from_http_response(cls, status: int | None, data: str | bytes | None) -> CtrlxProblemError:
        """``CtrlxProblemError.fromHttpResponse``."""
        if not data:
            return cls(status, title=f"[{status}]", type="about:blank")
        try:
            problem = json.loads(data)
        except ValueError:
            return cls(status, title=f"[{status}]", type="about:blank")
        return cls(
            status=problem.get("status"),
            title=problem.get("title"),
            type=problem.get("type"),
            detail=problem.get("detail"),
            instance=problem.get("instance"),
            main_diagnosis_code=problem.get("mainDiagnosisCode"),
            detailed_diagnosis_code=problem.get("detailedDiagnosisCode"),
            dynamic_description=problem.get("dynamicDescription"),
            severity=problem.get("severity"),
        )


class CtrlxCore:
    """``CtrlxCore``: login, read/write/create/delete and subscriptions over raw HTTPS."""

    def __init__(self, host: str, port: int, username: str, password: str) -> None:
        self.host, self.port = host, port
        self._username, self._password = username, password
        self._authorization: str | None = None
        self.token_expire_time = 0.0
        self._context = ssl._create_unverified_context()  # rejectUnauthorized: false

    def _request(
        self, method: str, path: str, headers: dict[str, str], body: bytes | None = None
    ) -> tuple[int, bytes]:
        conn = http.client.HTTPSConnection(self.host, self.port, context=self._context, timeout=5)
        try:
            conn.request(method, path, body=body, headers=headers)
            resp = conn.getresponse()
            return resp.status, resp.read()
        finally:
            conn.close()

    def _json(self, data: Any) -> tuple[dict[str, str], bytes]:
        body = json.dumps(data).encode()
        return {"Content-Type": "application/json", "Content-Length": str(len(body))}, body

    def log_in(self) -> dict[str, Any]:
        """``logIn``: POST the credentials; the token's lifetime comes from its iat and exp."""
        extra, body = self._json({"name": self._username, "password": self._password})
        headers = {"Connection": "keep-alive", **extra}
        status, raw = self._request("POST", "/identity-manager/api/v2/auth/token", headers, body)
        if status != 201:
            raise CtrlxProblemError.from_http_response(status, raw)
        data: dict[str, Any] = json.loads(raw)
        if not data.get("access_token") or not data.get("token_type"):
            raise ValueError("Did not receive expected data as authentication response")
        self._authorization = f"{data['token_type']} {data['access_token']}"
        payload = data["access_token"].split(".")[1]
        decoded = json.loads(base64.urlsafe_b64decode(payload + "=" * (-len(payload) % 4)))
        data["token_decoded"] = decoded
        self.token_expire_time = time.time() + decoded["exp"] - decoded["iat"] - 30
        return data

    def log_out(self) -> None:
        """``logOut``: DELETE the token; 204 expected."""
        assert self._authorization is not None
        headers = {"Authorization": self._authorization, "Connection": "close"}
        status, _ = self._request("DELETE", "/identity-manager/api/v2/auth/token", headers)
        self._authorization = None
        if status != 204:
            raise CtrlxProblemError.from_http_response(status, None)

    def _headers(self) -> dict[str, str]:
        assert self._authorization is not None, "Not authenticated. Please login first."
        return {
            "Accept": "application/json",
            "Authorization": self._authorization,
            "Connection": "keep-alive",
        }

    def datalayer_read(self, path: str, data: Any = None, kind: str = "data") -> Any:
        """``datalayerRead`` (``kind``: 'data', 'metadata' or 'browse')."""
        if kind in ("browse", "metadata"):
            url = encode_uri(f"/automation/api/v2/nodes/{path}?type={kind}")
        elif data is not None:
            url = encode_uri(f"/automation/api/v2/nodes/{path}?data=")
            url += quote(json.dumps(data), safe="-_.!~*'()")  # encodeURIComponent
        else:
            url = encode_uri(f"/automation/api/v2/nodes/{path}")
        status, raw = self._request("GET", url, self._headers())
        if status != 200:
            raise CtrlxProblemError.from_http_response(status, raw)
        return json.loads(raw)

    def _change(self, method: str, path: str, data: Any, ok: tuple[int, ...]) -> Any:
        headers, body = self._headers(), None
        if data:  # "writes with empty arguments (no data)" send no body and no Content-Type
            extra, body = self._json(data)
            headers.update(extra)
        status, raw = self._request(method, encode_uri(f"/automation/api/v2/nodes/{path}"),
                                    headers, body)  # fmt: skip
        if status not in ok:
            raise CtrlxProblemError.from_http_response(status, raw)
        return json.loads(raw) if raw else None

    def datalayer_write(self, path: str, data: Any = None) -> Any:
        """``datalayerWrite``: PUT, 200 expected."""
        return self._change("PUT", path, data, (200,))

    def datalayer_create(self, path: str, data: Any = None) -> Any:
        """``datalayerCreate``: POST, 200 or 201 expected."""
        return self._change("POST", path, data, (200, 201))

    def datalayer_delete(self, path: str) -> None:
        """``datalayerDelete``: DELETE, 200 or 204 expected."""
        self._change("DELETE", path, None, (200, 204))

    def create_subscription(self, paths: list[str], options: dict[str, str]) -> str:
        """``_createSubscription``: POST to ``/events/``; returns the stream's path."""
        sub_id = f"node-red-{uuid.uuid4()}"
        rules: list[dict[str, Any]] = []
        if options.get("samplingIntervalUs"):
            rules.append(
                {"rule_type": "Sampling",
                 "rule": {"samplingInterval": options["samplingIntervalUs"]}}
            )  # fmt: skip
        if options.get("queueBehaviour") and options.get("queueSize"):
            rule = {"behaviour": options["queueBehaviour"], "queueSize": options["queueSize"]}
            rules.append({"rule_type": "Queueing", "rule": rule})
        properties: dict[str, Any] = {"id": sub_id}
        for key, name in (
            ("keepaliveIntervalMs", "keepaliveInterval"),
            ("publishIntervalMs", "publishInterval"),
            ("errorIntervalMs", "errorInterval"),
        ):
            if options.get(key):
                properties[name] = options[key]
        if rules:
            properties["rules"] = rules
        extra, body = self._json({"properties": properties, "nodes": paths})
        status, raw = self._request(
            "POST", encode_uri("/automation/api/v2/events/"), {**self._headers(), **extra}, body
        )
        if status not in (200, 201, 204):
            raise CtrlxProblemError.from_http_response(status, raw)
        return f"/automation/api/v2/events/{sub_id}"

    def open_event_source(self, path: str) -> EventSource:
        """What ``new EventSource(url, {headers: {Authorization}})`` sends."""
        assert self._authorization is not None
        conn = http.client.HTTPSConnection(self.host, self.port, context=self._context, timeout=5)
        headers = {
            "Authorization": self._authorization,
            "Accept": "text/event-stream",
            "Cache-Control": "no-cache",
        }
        conn.request("GET", path, headers=headers)
        resp = conn.getresponse()
        if resp.status != 200:
            raw = resp.read()
            conn.close()
            raise CtrlxProblemError.from_http_response(resp.status, raw)
        return EventSource(conn, resp)


@dataclass
class EventSource:
    """A minimal EventSource: yields (event, data) per event until closed."""

    conn: http.client.HTTPSConnection
    resp: http.client.HTTPResponse

    def next_event(self) -> tuple[str, str]:
        """The next event's type and data (blocks; the socket timeout bounds it)."""
        event, data = "message", []
        while True:
            line = self.resp.readline().decode().rstrip("\r\n")
            if not line:
                if data:
                    return event, "\n".join(data)
                continue
            name, _, value = line.partition(":")
            value = value[1:] if value.startswith(" ") else value
            if name == "event":
                event = value
            elif name == "data":
                data.append(value)

    def close(self) -> None:
        """Drop the connection, as ``es.close()`` does."""
        self.conn.close()


@dataclass
class ConfigSubscription:
    """``ctrlx-config-subscription``: one subscription shared by registered Node-RED nodes."""

    users: dict[str, tuple[str, Callable[[Exception | None, Any], None]]] = field(
        default_factory=dict
    )
    resets: int = 0

    def register(self, node_id: str, path: str, callback: Callable[..., None]) -> None:
        """``register``: a Data Layer Subscribe node and the path it wants."""
        self.users[node_id] = (path, callback)

    def paths(self) -> list[str]:
        """Every registered path (the subscription's node list)."""
        return [path for path, _ in self.users.values() if path]

    def on_update(self, data: str) -> None:
        """The ``update`` handler: to the nodes whose path is ``data.node``."""
        payload = json.loads(data)
        for path, callback in self.users.values():
            if path == payload["node"]:
                callback(None, payload)

    def on_error(self, data: str) -> None:
        """The ``error`` handler: one node's problem by ``instance``, else everyone's."""
        err = CtrlxProblemError.from_http_response(None, data)
        single = False
        if err.instance:
            for path, callback in self.users.values():
                if path == err.instance:
                    callback(err, None)
                    single = True
        if not single:
            for _, callback in self.users.values():
                callback(err, None)
            self.resets += 1  # "To recover from the error state, let's reset the subscription."
