"""A web page on another site, or one reached through DNS rebinding, gets nothing.

Over real sockets, with the headers a browser sends: a cross-site page may send
a form or ``text/plain`` POST without asking first, and a rebinding page names
its own domain in ``Host`` (and a matching ``Origin``).
"""

from __future__ import annotations

import asyncio
import base64
import hashlib
import json
from html.parser import HTMLParser
from pathlib import Path

import pytest
from pydantic import SecretStr

from server.config import Settings
from tests.commissioning.cells import SOURCE, STILL
from tests.conftest import running_server

ROOT = Path(__file__).resolve().parents[2]
MOVE = json.dumps({"joints": [0.1, -0.1]})


async def request(
    base: str, method: str, path: str, headers: dict[str, str], body: str = ""
) -> tuple[int, dict[str, str], str]:
    """One raw HTTP/1.1 request with exactly these headers; status, headers, body."""
    port = int(base.rsplit(":", 1)[1])
    reader, writer = await asyncio.open_connection("127.0.0.1", port)
    head = {"Host": f"127.0.0.1:{port}", "Connection": "close", **headers}
    if body:
        head["Content-Length"] = str(len(body.encode()))
    lines = "".join(f"{k}: {v}\r\n" for k, v in head.items())
    writer.write(f"{method} {path} HTTP/1.1\r\n{lines}\r\n{body}".encode())
    async with asyncio.timeout(10):
        head_bytes = await reader.readuntil(b"\r\n\r\n")
        switching = head_bytes.startswith(b"HTTP/1.1 101")
        answer = head_bytes + (b"" if switching else await reader.read())  # a socket stays open
    writer.close()
    top, _, rest = answer.decode("latin-1").partition("\r\n\r\n")
    status = int(top.split(" ", 2)[1])
    fields = dict(line.split(": ", 1) for line in top.split("\r\n")[1:])
    return status, {k.lower(): v for k, v in fields.items()}, rest


async def test_cross_site_posts_are_refused_and_the_pages_own_json_moves() -> None:
    async with running_server(Settings()) as base:
        path = "/api/robots/kin12/move"
        evil = {"Origin": "https://evil.example"}
        # What a foreign page's <form> or fetch(..., {mode: "no-cors"}) sends:
        for kind in ("text/plain", "application/x-www-form-urlencoded", "multipart/form-data"):
            status, _, text = await request(
                base, "POST", path, {**evil, "Content-Type": kind}, MOVE
            )
            assert status == 403 and "--allow-origin" in text, (kind, status, text)
        # A sandboxed frame or a file: page says "null".
        null = {"Origin": "null", "Content-Type": "application/json"}
        assert (await request(base, "POST", path, null, MOVE))[0] == 403
        # The page's own origin, but not JSON: refused too (no "simple request" gets through).
        own = {"Origin": base}
        status, _, text = await request(
            base, "POST", path, {**own, "Content-Type": "text/plain"}, MOVE
        )
        assert status == 415 and "application/json" in text
        # Not a browser (no Origin), not JSON: a script's mistake, told so.
        assert (await request(base, "POST", path, {"Content-Type": "text/plain"}, MOVE))[0] == 415
        # The page's own request moves the robot; so does a script's.
        json_type = {"Content-Type": "application/json; charset=utf-8"}
        assert (await request(base, "POST", path, {**own, **json_type}, MOVE))[0] == 202
        assert (await request(base, "POST", path, json_type, MOVE))[0] == 202
        fk = json.dumps({"joints": [[0.1, -0.1]]})
        status, _, _ = await request(
            base, "POST", "/api/robots/kin12/fk", {**evil, **json_type}, fk
        )
        assert status == 403  # every POST, not only move


async def test_an_allowed_origin_may_post() -> None:
    async with running_server(Settings(allow_origin=["https://hmi.plant.example"])) as base:
        headers = {"Origin": "https://hmi.plant.example", "Content-Type": "application/json"}
        assert (await request(base, "POST", "/api/robots/kin12/move", headers, MOVE))[0] == 202


UPGRADE = {
    "Upgrade": "websocket",
    "Connection": "Upgrade",
    "Sec-WebSocket-Key": "dGhlIHNhbXBsZSBub25jZQ==",
    "Sec-WebSocket-Version": "13",
}


@pytest.mark.parametrize("path", ["/", "/api/robots", "/api/health", "/static/js/main.js"])
async def test_a_rebinding_host_is_refused_on_a_loopback_bind(path: str) -> None:
    async with running_server(Settings()) as base:
        evil = {"Host": "evil.example:8000", "Origin": "http://evil.example:8000"}
        status, _, text = await request(base, "GET", path, evil)
        assert status == 403 and "--allow-host evil.example" in text, (status, text)
        for host in ("localhost:8000", "127.0.0.1", "[::1]:8000", "LOCALHOST."):
            status, _, _ = await request(base, "GET", path, {"Host": host})
            assert status != 403, host  # /api/health may say 503 before the first sample


async def test_a_rebinding_host_cannot_open_the_stream() -> None:
    async with running_server(Settings()) as base:
        evil = {"Host": "evil.example", "Origin": "http://evil.example"}
        assert (await request(base, "GET", "/ws", {**UPGRADE, **evil}))[0] == 403
        own = {"Origin": base}
        assert (await request(base, "GET", "/ws", {**UPGRADE, **own}))[0] == 101


async def test_allowed_hosts_and_a_bind_beyond_loopback() -> None:
    async with running_server(Settings(allow_host=["plant-pc.example", ".cell.example"])) as base:
        for host in ("plant-pc.example:8000", "a.cell.example", "cell.example"):
            assert (await request(base, "GET", "/api/robots", {"Host": host}))[0] == 200, host
        # A lookalike: ".cell.example" is the domain and its subdomains, not a name ending so.
        for host in ("other.example", "10.0.0.5", "evilcell.example", "cell.example.evil.example",
                     "plant-pc.example.evil.example", "xplant-pc.example"):  # fmt: skip
            assert (await request(base, "GET", "/api/robots", {"Host": host}))[0] == 403, host
    # Bound to every interface: this machine's addresses are typed as they are.
    async with running_server(Settings(host="0.0.0.0")) as base:
        for host in ("192.168.1.20:8000", "[fe80::1]:8000", "127.0.0.1"):
            assert (await request(base, "GET", "/api/robots", {"Host": host}))[0] == 200, host
        assert (await request(base, "GET", "/api/robots", {"Host": "evil.example"}))[0] == 403


class InlineScripts(HTMLParser):
    """The text of each ``<script>`` without ``src``, as a browser hashes it for the CSP."""

    def __init__(self) -> None:
        super().__init__(convert_charrefs=False)
        self.bodies: list[str] = []
        self._open: list[str] | None = None

    def handle_starttag(self, tag: str, attrs: list[tuple[str, str | None]]) -> None:
        if tag == "script" and "src" not in dict(attrs):
            self._open = []

    def handle_data(self, data: str) -> None:
        if self._open is not None:
            self._open.append(data)

    def handle_endtag(self, tag: str) -> None:
        if tag == "script" and self._open is not None:
            self.bodies.append("".join(self._open))
            self._open = None


def expected_policy() -> str:
    """The page's policy, written out; the hashes are of index.html's inline scripts
    (the import map), read with the standard library's HTML parser (CSP Level 3: sha256 of
    the script's UTF-8 text, base64)."""
    parser = InlineScripts()
    parser.feed((ROOT / "static" / "index.html").read_text(encoding="utf-8"))
    assert len(parser.bodies) == 1, "index.html has one inline script: its import map"
    digests = [base64.b64encode(hashlib.sha256(b.encode()).digest()) for b in parser.bodies]
    hashes = " ".join(f"'sha256-{digest.decode()}'" for digest in digests)
    return (
        "default-src 'self'; "
        f"script-src 'self' 'wasm-unsafe-eval' {hashes}; "
        "style-src 'self'; "
        "img-src 'self' data: blob:; "
        "connect-src 'self' blob: data:; "
        "worker-src 'self' blob:; "
        "object-src 'none'; "
        "base-uri 'none'; "
        "form-action 'self'; "
        "frame-ancestors 'none'"
    )


async def test_every_response_carries_the_security_headers() -> None:
    policy = expected_policy()
    async with running_server(Settings(viewer_token=SecretStr("t0ken"))) as base:
        auth = {"Authorization": "Bearer t0ken"}
        cases = [
            ("/", auth, 200),
            ("/static/js/main.js", auth, 200),
            ("/api/health", auth, 200),
            ("/api/nothing", auth, 404),
            ("/api/robots", {}, 401),  # refusals too
            ("/api/robots", {"Host": "evil.example"}, 403),
        ]
        for path, headers, expected in cases:
            status, fields, _ = await request(base, "GET", path, headers)
            assert status == expected, path
            assert fields["referrer-policy"] == "no-referrer", path
            assert fields["x-content-type-options"] == "nosniff", path
            assert fields["content-security-policy"] == policy, path


async def test_the_cookie_is_secure_only_behind_tls() -> None:
    async with running_server(Settings(viewer_token=SecretStr("t0ken"))) as base:
        _, plain, _ = await request(base, "GET", "/?token=t0ken", {})
        # A TLS proxy on this machine (uvicorn trusts loopback's X-Forwarded-Proto).
        _, behind_tls, _ = await request(
            base, "GET", "/?token=t0ken", {"X-Forwarded-Proto": "https"}
        )
    assert "HttpOnly" in plain["set-cookie"] and "Secure" not in plain["set-cookie"]
    assert behind_tls["set-cookie"].endswith("; Secure"), behind_tls["set-cookie"]


EDITABLE = "# a cell a cross-site page must not be able to change\n" + SOURCE + STILL
EDITS = [
    ("/api/cell/changes",
     json.dumps({"changes": [{"op": "joint", "robot": "still", "joint": "a0", "scale": -1.0}]})),
    ("/api/cell/save", json.dumps({"version": "0" * 64})),
    ("/api/cell/discard", "{}"),
    ("/api/cell/undo", "{}"),
]  # fmt: skip


async def test_a_cross_site_page_cannot_change_the_cell(tmp_path: Path) -> None:
    cell = tmp_path / "cell.toml"
    cell.write_text(EDITABLE)
    settings = Settings(cell=cell, allow_edits=True, viewer_token=SecretStr("t0ken"))
    auth = {"Authorization": "Bearer t0ken"}
    async with running_server(settings) as base:
        for path, body in EDITS:
            evil = {**auth, "Origin": "https://evil.example"}
            for kind in ("application/json", "text/plain", "application/x-www-form-urlencoded"):
                status, _, text = await request(
                    base, "POST", path, {**evil, "Content-Type": kind}, body
                )
                assert status == 403 and "--allow-origin" in text, (path, kind, status, text)
            # The page's own origin, but a "simple" request: refused before any route.
            own = {**auth, "Origin": base, "Content-Type": "text/plain"}
            assert (await request(base, "POST", path, own, body))[0] == 415
            # Without the token, nobody gets in; a rebinding page names its own host.
            json_type = {"Content-Type": "application/json"}
            assert (await request(base, "POST", path, json_type, body))[0] == 401
            rebinding = {
                **auth,
                **json_type,
                "Host": "evil.example",
                "Origin": "http://evil.example",
            }
            assert (await request(base, "POST", path, rebinding, body))[0] == 403
        for path in ("/api/cell", "/api/descriptions?robot=still"):
            assert (await request(base, "GET", path, {}))[0] == 401
        # The page's own JSON request with the token changes it (unsaved until saved).
        own = {**auth, "Origin": base, "Content-Type": "application/json"}
        status, _, text = await request(base, "POST", EDITS[0][0], own, EDITS[0][1])
        assert status == 200, text
    assert cell.read_text() == EDITABLE
