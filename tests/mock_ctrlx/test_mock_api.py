"""The mock's own behaviour: expiring tokens, browse, commands, streams, faults, TLS, CLI."""

from __future__ import annotations

import asyncio
import json
import ssl
import subprocess
import sys
import time
from pathlib import Path

import aiohttp
import jwt
import pytest

from server.ctrlx import SseParser, unix_from_filetime
from server.mock_ctrlx import auth
from server.mock_ctrlx.auth import TokenIssuer
from tests.conftest import free_port
from tests.ctrlx.helpers import KIN12, Mock, client, running

DL = "/automation/api/v2"


async def token_of(http: aiohttp.ClientSession, mock: Mock, version: str = "v2") -> str:
    credentials = {"name": "boschrexroth", "password": "boschrexroth"}
    async with http.post(f"{mock.url}/identity-manager/api/{version}/auth/token",
                         json=credentials) as resp:  # fmt: skip
        assert resp.status == 201
        return str((await resp.json())["access_token"])


async def test_tokens_really_expire() -> None:
    async with running(token_lifetime_s=0.3) as mock, aiohttp.ClientSession() as http:
        headers = {"Authorization": f"Bearer {await token_of(http, mock)}"}
        async with http.get(f"{mock.url}{DL}/nodes/{KIN12[0]}", headers=headers) as resp:
            assert resp.status == 200
        await asyncio.sleep(0.4)
        async with http.get(f"{mock.url}{DL}/nodes/{KIN12[0]}", headers=headers) as resp:
            assert resp.status == 401
            assert (await resp.json())["detail"] == "the token has expired"


async def test_browse_metadata_and_commands() -> None:
    async with running() as mock, client(mock.url) as c:
        # "datalayer" holds the data layer's own nodes, as on a device.
        assert await c.browse("") == ["datalayer", "framework", "motion", "plc"]
        assert await c.browse("motion/grp") == ["iiwa", "kin12", "pos"]
        assert "pos-abs" in await c.browse("motion/axs/kin12_a0/cmd")
        meta = await c.metadata("motion/axs/kin12_a0/cmd/pos-abs")
        assert meta["nodeClass"] == "Method" and meta["operations"]["write"] is True
        await c.write("motion/grp/kin12/cmd/pos-abs", "object", {"axsPos": [12.0, -7.0]})
        await c.write("motion/axs/pos_turn/cmd/pos-abs", "object", {"axsPos": 90.0})
        async with asyncio.timeout(10):
            while abs(await c.read_number(KIN12[0]) - 12.0) > 1e-9:
                await asyncio.sleep(0.05)
        assert await c.read_number(KIN12[1]) == pytest.approx(-7.0)
        with pytest.raises(Exception, match="400 DL_INVALID_VALUE"):
            await c.write("motion/grp/kin12/cmd/pos-abs", "object", {"axsPos": [90.0, 0.0]})
        with pytest.raises(Exception, match="400 DL_INVALID_OPERATION"):
            await c.write(KIN12[0], "double", 1.0)


async def test_stream_stamps_filetime_and_ends_with_its_token() -> None:
    async with running(token_lifetime_s=0.5) as mock, aiohttp.ClientSession() as http:
        headers = {"Authorization": f"Bearer {await token_of(http, mock)}"}
        params = {"nodes": ",".join(KIN12), "publishIntervalMs": "20"}
        events = []
        async with (
            asyncio.timeout(5),
            http.get(f"{mock.url}{DL}/events", params=params, headers=headers) as resp,
        ):
            parser = SseParser()
            async for chunk in resp.content.iter_any():
                events += parser.feed(chunk)
        assert mock.state.open_streams == 0
    updates = [json.loads(e.data) for e in events if e.event == "update"]
    assert {u["node"] for u in updates} == set(KIN12)
    assert 10 <= len(updates) <= 2 * 0.5 / 0.02 + 4
    assert abs(unix_from_filetime(updates[-1]["timestamp"]) - time.time()) < 2.0


async def test_admin_endpoint_switches_faults() -> None:
    async with running() as mock, aiohttp.ClientSession() as http:
        async with http.put(f"{mock.url}/mock/faults", json={"outage": True}) as resp:
            assert (await resp.json())["outage"] is True
        with pytest.raises(aiohttp.ClientError):
            await token_of(http, mock)
        async with http.put(f"{mock.url}/mock/faults", json={"outage": False}):
            pass
        assert await token_of(http, mock)
        async with http.post(f"{mock.url}/mock/tokens/revoke-all") as resp:
            assert resp.status == 204
        async with http.get(f"{mock.url}/mock/stats") as resp:
            stats = await resp.json()
        assert stats["requests"] == 2 and stats["bytes_out"] > 100  # the logins


async def test_tls_certificate_verifies_with_its_ca_file(tmp_path: Path) -> None:
    async with running(tls_dir=tmp_path) as mock, aiohttp.ClientSession() as http:
        assert mock.cert is not None
        context = ssl.create_default_context(cafile=str(mock.cert.ca_file))
        async with http.get(f"{mock.url}/mock/faults", ssl=context) as resp:
            assert resp.status == 200
        with pytest.raises(aiohttp.ClientConnectorCertificateError):
            await http.get(f"{mock.url}/mock/faults", ssl=ssl.create_default_context())


def test_command_line_serves_https_and_names_its_ca_file(tmp_path: Path) -> None:
    port = free_port()
    cmd = [sys.executable, "-m", "server.mock_ctrlx", "--port", str(port), "--tls",
           "--tls-dir", str(tmp_path), "--token-lifetime", "5"]  # fmt: skip
    with subprocess.Popen(cmd, stdout=subprocess.PIPE, text=True) as proc:
        try:
            assert proc.stdout is not None
            line = proc.stdout.readline()
        finally:
            proc.terminate()
            proc.wait(10)
    assert f"https://127.0.0.1:{port}" in line
    assert str(tmp_path / "mock-ctrlx-cert.pem") in line


async def test_axes_at_their_own_nodes_are_served_everywhere() -> None:
    from server.ctrlx import follow
    from server.mock_ctrlx import AxisGroup, Machine, SimAxis, build_app

    lift = "robots/r1/lift"
    axes = (SimAxis("j1", "rad", 1.0, 4.0, node=lift), SimAxis("j2", "mm", 200.0, 900.0))
    machine = Machine(groups=[AxisGroup("r1", axes, ((0.0, 0.0), (1.5, 300.0)))])
    nodes = [lift, "motion/axs/j2/state/values/actual/pos"]
    async with running(build_app(machine=machine)) as mock, client(mock.url) as c:
        assert await c.browse("") == ["datalayer", "framework", "motion", "plc", "robots"]
        assert (await c.metadata(lift))["unit"] == "rad"
        assert isinstance(await c.read_number(lift), float)
        read = await c.bulk_read(nodes)
        assert all(isinstance(read.values[n], float) for n in nodes)
        async with asyncio.timeout(10):
            samples = follow(c, nodes, 0.02)
            sample = await anext(samples)
            await samples.aclose()
        assert set(sample.values) == set(nodes)
        assert all(isinstance(v, float) for v in sample.values.values())
        await c.write("motion/grp/r1/cmd/pos-abs", "object", {"axsPos": [0.25, 40.0]})
        async with asyncio.timeout(10):
            while await c.read_number(lift) != 0.25:
                await asyncio.sleep(0.05)
        assert await c.read_number(nodes[1]) == pytest.approx(40.0)
    assert mock.count("POST", "/automation/api/v2/events") == 1


def test_a_token_checked_before_is_still_refused_once_revoked_or_its_key_is_gone(
    monkeypatch: pytest.MonkeyPatch,
) -> None:
    now = [1000.0]
    issuer = TokenIssuer({"u": "p"}, lifetime_s=10.0, clock=lambda: now[0])
    first, second = issuer.issue("u", "p"), issuer.issue("u", "p")
    assert first is not None and second is not None
    assert issuer.check(first) is None and issuer.check(second) is None  # remembered now
    forged = jwt.encode({"exp": 2000.0}, b"another key" * 3, algorithm="HS256")
    assert issuer.check(forged) == "the token is not valid"
    issuer.revoke(first)
    assert issuer.check(first) == "the token was revoked"
    now[0] = 1010.0
    assert issuer.check(second) == "the token has expired"
    now[0] = 1005.0
    issuer.revoke_all()
    assert issuer.check(second) == "the token is not valid"
    # Only tokens it signed are remembered, and the expired ones go once there are many.
    monkeypatch.setattr(auth, "MAX_REMEMBERED", 3)
    tokens = [issuer.issue("u", "p") for _ in range(3)]
    assert all(t is not None and issuer.check(t) is None for t in tokens)
    now[0] = 1020.0
    fresh = issuer.issue("u", "p")
    assert fresh is not None and issuer.check(fresh) is None
    assert len(issuer._expiry) == 1
