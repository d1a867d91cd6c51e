"""Attacks that found nothing when the server was probed, kept as regression tests.

Path traversal on /static and /meshes (encoded, doubled, NUL bytes, a symlink
in static/), malformed WebSocket frames, JSON nested 100 000 deep, XXE and
"billion laughs" in a URDF, and a controller that redirects the login.
"""

from __future__ import annotations

import asyncio
import json
import shutil
import struct
from pathlib import Path

import pytest
from aiohttp import web
from websockets.exceptions import ConnectionClosed
from websockets.sync.client import connect as connect_sync

import server.web.app
from server.config import Settings
from server.ctrlx import Credentials, DataLayerClient, DataLayerError
from server.paths import STATIC_DIR
from server.urdf import UrdfError, load_urdf
from tests.conftest import running_server
from tests.web.test_hostile_page import request

SECRET = Path("/etc/hostname").read_text().strip()


@pytest.mark.parametrize(
    "path",
    [
        "/static/../server/config.py",
        "/static/%2e%2e/server/config.py",
        "/static/..%2fserver%2fconfig.py",
        "/static/%252e%252e/server/config.py",
        "/static/....//....//etc/hostname",
        "/static/js/main.js%00.png",
        "/static/%2fetc%2fhostname",
        "/meshes/kin12/..%2f..%2f..%2fetc%2fhostname",
        "/meshes/kin12/-1.glb",
        "/meshes/kin12/99999999999999999999.glb",
        "/meshes/..%2fkin12/0.glb",
    ],
)
async def test_no_path_leaves_the_served_folders(path: str) -> None:
    async with running_server(Settings()) as base:
        status, _, body = await request(base, "GET", path, {})
    assert status in (400, 404, 422), (path, status)
    assert "linkview_" not in body and SECRET not in body


async def test_a_symlink_in_static_is_not_followed_out(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    # The app's static folder, copied to a temporary one (tests never write into the
    # checkout), with a symlink out of it beside a real file.
    static = tmp_path / "static"
    shutil.copytree(STATIC_DIR, static)
    (static / "_held_up_test_link").symlink_to("/etc/hostname")
    monkeypatch.setattr(server.web.app, "STATIC_DIR", static)
    async with running_server(Settings()) as base:
        status, _, body = await request(base, "GET", "/static/_held_up_test_link", {})
        served, _, _ = await request(base, "GET", "/static/js/main.js", {})
    assert served == 200, "the copy is the folder served"
    assert status == 404 and SECRET not in body


@pytest.mark.parametrize(
    ("frame", "code"),
    [
        (struct.pack("!BB", 0x81, 2) + b"hi", 1002),  # a client frame without a mask
        (struct.pack("!BB", 0x81, 0x82) + b"\0\0\0\0" + b"\xff\xfe", 1007),  # not UTF-8
        (struct.pack("!BB", 0x8B, 0x80) + b"\0\0\0\0", 1002),  # an unknown opcode
    ],
)
async def test_malformed_websocket_frames_close_that_viewer(frame: bytes, code: int) -> None:
    async with running_server(Settings()) as base:

        def attack() -> int | None:
            with connect_sync(base.replace("http", "ws") + "/ws") as ws:
                ws.recv(timeout=10)  # hello
                ws.socket.sendall(frame)
                try:
                    while True:
                        ws.recv(timeout=10)
                except ConnectionClosed as exc:
                    return None if exc.rcvd is None else exc.rcvd.code

        assert await asyncio.to_thread(attack) == code
        status, _, _ = await request(base, "GET", "/api/robots", {})
        assert status == 200  # the server carries on


async def test_json_nested_100_000_deep_is_a_422() -> None:
    body = "[" * 100_000 + "]" * 100_000
    async with running_server(Settings()) as base:
        headers = {"Content-Type": "application/json"}
        status, _, _ = await request(base, "POST", "/api/robots/kin12/fk", headers, body)
        assert status == 422
        fk = json.dumps({"joints": [[0.1, -0.1]]})
        assert (await request(base, "POST", "/api/robots/kin12/fk", headers, fk))[0] == 200


def test_xxe_and_billion_laughs_in_a_urdf_are_refused(tmp_path: Path) -> None:
    xxe = tmp_path / "xxe.urdf"
    xxe.write_text(
        '<?xml version="1.0"?>\n<!DOCTYPE robot [<!ENTITY s SYSTEM "file:///etc/hostname">]>\n'
        '<robot name="x"><link name="&s;"/></robot>\n'
    )
    with pytest.raises(UrdfError, match="Entity 's' not defined"):
        load_urdf(xxe)
    entities = ['<!ENTITY a "' + "a" * 50 + '">']
    for name, inner in zip("bcdefghi", "abcdefgh", strict=True):
        entities.append(f'<!ENTITY {name} "{f"&{inner};" * 10}">')
    laughs = tmp_path / "laughs.urdf"
    laughs.write_text(
        f'<?xml version="1.0"?>\n<!DOCTYPE robot [{"".join(entities)}]>\n'
        '<robot name="x"><link name="&i;"/></robot>\n'
    )
    with pytest.raises(UrdfError, match="amplification"):
        load_urdf(laughs)


async def test_a_controller_redirecting_the_login_is_not_followed() -> None:
    elsewhere: list[str] = []

    async def record(request: web.Request) -> web.Response:
        elsewhere.append(f"{request.method} {request.path} {request.headers.get('Authorization')}")
        return web.json_response({"access_token": "stolen", "token_type": "Bearer"})

    async def redirect(request: web.Request) -> web.Response:
        raise web.HTTPTemporaryRedirect(f"{other_url}{request.path}")

    other, device = web.Application(), web.Application()
    other.router.add_route("*", "/{tail:.*}", record)
    device.router.add_route("*", "/{tail:.*}", redirect)
    runners = [web.AppRunner(other), web.AppRunner(device)]
    urls = []
    for runner in runners:
        await runner.setup()
        site = web.TCPSite(runner, "127.0.0.1", 0)
        await site.start()
        urls.append(f"http://127.0.0.1:{site._server.sockets[0].getsockname()[1]}")  # type: ignore[union-attr]
    other_url, device_url = urls
    try:
        async with DataLayerClient(device_url, Credentials("user", "secret-pass")) as client:
            with pytest.raises(DataLayerError) as caught:
                await client.read("framework/metrics/system/cpu-utilisation-percent")
    finally:
        for runner in runners:
            await runner.cleanup()
    assert elsewhere == [], "the client followed the redirect"
    assert "secret-pass" not in str(caught.value)
