"""Who may watch: Origin check, viewer token, viewer cap; and what /metrics and /api/health say."""

from __future__ import annotations

import asyncio
import json
from typing import Any

import aiohttp
import pytest
from pydantic import SecretStr
from websockets.asyncio.client import connect
from websockets.exceptions import InvalidStatus

from server.config import Settings
from tests.conftest import running_mock, running_server

TOKEN = "s3cret-viewer-token"


async def get(url: str, **kwargs: Any) -> tuple[int, str, aiohttp.ClientResponse]:
    async with aiohttp.ClientSession() as http, http.get(url, **kwargs) as resp:
        return resp.status, await resp.text(), resp


async def ws_status(url: str, **kwargs: Any) -> int:
    """101 if the WebSocket opens and says hello, else the HTTP status it was refused with."""
    try:
        async with connect(url, open_timeout=5, **kwargs) as ws, asyncio.timeout(5):
            assert json.loads(await ws.recv())["type"] == "hello"
            return 101
    except InvalidStatus as exc:
        return exc.response.status_code


async def test_a_foreign_origin_cannot_open_the_stream_with_or_without_token() -> None:
    settings = Settings(allow_origin=["https://hmi.plant.example:8443"])
    async with running_server(settings) as base:
        ws = base.replace("http", "ws") + "/ws"
        assert await ws_status(ws, origin=base) == 101  # the page's own origin
        assert await ws_status(ws) == 101  # no Origin: not a browser
        assert await ws_status(ws, origin="https://hmi.plant.example:8443") == 101
        assert await ws_status(ws, origin="https://evil.example") == 403
        assert await ws_status(ws, origin="http://127.0.0.1:1") == 403  # another port
    async with running_server(
        settings.model_copy(update={"viewer_token": SecretStr(TOKEN)})
    ) as base:
        ws = base.replace("http", "ws") + "/ws"
        auth = {"Authorization": f"Bearer {TOKEN}"}
        assert await ws_status(ws, origin="https://evil.example", additional_headers=auth) == 403
        assert await ws_status(ws, origin=base, additional_headers=auth) == 101


async def test_the_viewer_token_guards_page_api_and_stream() -> None:
    async with running_server(Settings(viewer_token=SecretStr(TOKEN))) as base:
        ws = base.replace("http", "ws") + "/ws"
        for path in ("/", "/api/health", "/api/robots", "/metrics", "/static/js/main.js"):
            status, _, _ = await get(base + path)
            assert status == 401, path
            status, _, _ = await get(base + path, headers={"Authorization": "Bearer nope"})
            assert status == 401, path
        assert await ws_status(ws) == 401
        assert await ws_status(ws + "?token=nope") == 401

        status, page, resp = await get(f"{base}/?token={TOKEN}")
        assert status == 200 and "linkview" in page
        cookie = resp.headers["Set-Cookie"]
        assert f"linkview_token={TOKEN}" in cookie
        assert "HttpOnly" in cookie and "SameSite=Strict" in cookie
        jar = {"Cookie": f"linkview_token={TOKEN}"}
        assert (await get(base + "/api/robots", headers=jar))[0] == 200
        assert await ws_status(ws, origin=base, additional_headers=jar) == 101
        bearer = {"Authorization": f"Bearer {TOKEN}"}
        assert (await get(base + "/api/health", headers=bearer))[0] in (200, 503)


async def test_viewers_beyond_the_cap_get_503() -> None:
    async with running_server(Settings(max_viewers=2)) as base:
        ws = base.replace("http", "ws") + "/ws"
        async with connect(ws) as first, connect(ws) as second:
            await first.recv()
            await second.recv()
            assert await ws_status(ws) == 503
        async with asyncio.timeout(5):  # the slots free up when viewers leave
            while await ws_status(ws) != 101:
                await asyncio.sleep(0.05)


async def test_metrics_count_frames_viewers_and_logins() -> None:
    async with running_server(Settings()) as base:
        async with connect(base.replace("http", "ws") + "/ws", subprotocols=["linkview.2"]) as ws:
            async with asyncio.timeout(10):
                while not isinstance(await ws.recv(), bytes):
                    pass
            _, text, _ = await get(base + "/metrics")
    values = {
        line.rsplit(" ", 1)[0]: float(line.rsplit(" ", 1)[1])
        for line in text.splitlines()
        if line and not line.startswith("#")
    }
    assert values['linkview_frames_published_total{robot="kin12"}'] > 0
    assert values['linkview_viewers{protocol="2"}'] == 1
    assert values['linkview_datalayer_logins_total{source="demo"}'] == 1
    assert values["linkview_sample_to_send_seconds_count"] >= 1
    batches = values["linkview_sample_batches_total"]
    assert 1 <= batches <= values["linkview_samples_computed_total"]
    assert values['linkview_kinematics_seconds_count{source="demo"}'] > 0
    assert 0 <= values['linkview_sample_age_seconds{source="demo"}'] < 5


async def test_health_turns_stale_then_503_when_samples_stop() -> None:
    async with (
        running_mock() as (app, url),
        running_server(Settings(ctrlx_url=url, keepalive_s=30.0)) as base,
    ):
        async with asyncio.timeout(10):
            while (await get(base + "/api/health"))[0] != 200:
                await asyncio.sleep(0.05)
        from server.mock_ctrlx import STATE_KEY

        app[STATE_KEY].faults.stall_streams = True  # the stream stays open but says nothing
        async with asyncio.timeout(10):
            while True:
                status, text, _ = await get(base + "/api/health")
                health = json.loads(text)
                if health["sources"][0]["state"] == "stale":
                    break
                await asyncio.sleep(0.02)
        source = health["sources"][0]
        assert health["status"] == "degraded" and status == 503  # no source is live
        assert source["last_sample_age_s"] >= 0.25
        assert "no sample for" in source["error"]
        app[STATE_KEY].faults.stall_streams = False
        async with asyncio.timeout(10):
            while (await get(base + "/api/health"))[0] != 200:
                await asyncio.sleep(0.05)


@pytest.mark.parametrize("body", [{"joints": [["0.1", 0.2]]}, {"joints": [[True, 0.2]]}])
async def test_strings_and_booleans_where_numbers_belong_are_422(body: Any) -> None:
    async with running_server(Settings()) as base, aiohttp.ClientSession() as http:
        async with http.post(base + "/api/robots/kin12/fk", json=body) as resp:
            assert resp.status == 422, await resp.text()
        ik = {"tcp": ["0.1", 0, 0, 0, 0, 0, 1]}
        async with http.post(base + "/api/robots/kin12/ik", json=ik) as resp:
            assert resp.status == 422


async def test_metrics_show_how_late_the_event_loop_runs() -> None:
    async def lag_count() -> float:
        status, text, _ = await get(base + "/metrics")
        assert status == 200
        (count,) = [
            float(line.rsplit(" ", 1)[1])
            for line in text.splitlines()
            if line.startswith("linkview_event_loop_lag_seconds_count")
        ]
        return count

    # The probe keeps measuring: its count grows from one scrape to the next, however
    # long a wake-up takes on this machine (each is waited for, within a bound).
    async with running_server(Settings()) as base:
        counts = [await lag_count()]
        async with asyncio.timeout(10):
            while len(counts) < 4:  # three ticks after the first scrape
                count = await lag_count()
                if count > counts[-1]:
                    counts.append(count)
                await asyncio.sleep(0.05)
        status, text, _ = await get(base + "/metrics")
    assert counts == sorted(set(counts)), counts
    assert "linkview_event_loop_lag_newest_seconds " in text
    # One demo source wakes the loop far less than a flood: measured, and not paced.
    values = dict(line.rsplit(" ", 1) for line in text.splitlines() if line[:1] != "#")
    assert float(values["linkview_event_loop_paced"]) == 0.0
    assert float(values["linkview_event_loop_wakeups_per_second"]) > 0.0
    assert 0.0 < float(values["linkview_event_loop_busy_ratio"]) < 1.0
