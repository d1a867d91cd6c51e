"""The client against the mock over real loopback sockets: login, reads, streams, faults, TLS."""

from __future__ import annotations

import asyncio
import logging
import ssl
import statistics
from pathlib import Path

import numpy as np
import pytest
from aiohttp import web
from aiohttp.typedefs import Handler

from server.config import Settings
from server.ctrlx import (
    AuthError,
    Credentials,
    DataLayerError,
    NodeNotFound,
    RetryPolicy,
    client_ssl,
    follow,
)
from server.mock_ctrlx import Machine, build_app, make_certificate
from server.mock_ctrlx import serve as serve_mock
from server.runtime import Runtime
from server.runtime.startup import configured_cell, source_defaults
from tests.conftest import free_port, wait_until
from tests.ctrlx.helpers import IIWA, KIN12, client, collect, max_gap, running

PUBLISH_S = 0.05


async def test_wrong_credentials_give_auth_error_with_the_problem_fields() -> None:
    async with running() as mock, client(mock.url, credentials=Credentials("x", "s3cr3t-pw")) as c:
        with pytest.raises(AuthError) as caught:
            await c.read_number(KIN12[0])
    err = caught.value
    assert err.status == 401 and err.title == "Unauthorized"
    assert err.detail == "wrong user name or password"
    assert err.instance == "/identity-manager/api/v2/auth/token"
    assert "s3cr3t-pw" not in str(err) + repr(err)


async def test_unknown_node_is_node_not_found_with_its_address() -> None:
    async with running() as mock, client(mock.url) as c:
        with pytest.raises(NodeNotFound) as caught:
            await c.read_number("motion/axs/nope/state/values/actual/pos")
    assert caught.value.title == "DL_INVALID_ADDRESS"
    assert caught.value.instance == "motion/axs/nope/state/values/actual/pos"


async def test_node_with_special_characters_reads_and_writes() -> None:
    node = "plc/app/Application/sym/PLC_PRG/a^b c%41#?é"
    async with running() as mock, client(mock.url) as c:
        mock.state.nodes.add_variable(node, "double", 1.5)
        assert await c.read_number(node) == 1.5
        await c.write(node, "double", -2.0)
        assert await c.read_number(node) == -2.0
        assert "a^b c%41#?é" in await c.browse("plc/app/Application/sym/PLC_PRG")
        assert (await c.metadata(node))["displayName"] == "a^b c%41#?é"
    assert any("a%5Eb%20c%2541%23%3F%C3%A9" in p for _, p, _ in mock.log)


async def test_arrays_and_the_actual_object() -> None:
    async with running() as mock, client(mock.url) as c:
        assert await c.read_numbers("plc/app/Application/sym/PLC_PRG/arTargets") == [0, 30, -25]
        body = await c.read("motion/axs/iiwa_a1/state/values/actual")
        assert body["value"]["actualPosUnit"] == "deg"


async def test_relogin_after_the_mock_invalidates_all_tokens() -> None:
    async with running() as mock, client(mock.url) as c:
        await c.read_number(KIN12[0])
        mock.state.tokens.revoke_all()
        await c.read_number(KIN12[0])
        assert c.tokens.logins == 2
    assert mock.count("GET", "/automation/", status=401) == 1


async def test_short_tokens_are_renewed_before_they_expire_and_revoked_on_close() -> None:
    # 3 s tokens are renewed 0.6 s early (at 2.4 s, 4.8 s): a margin a loaded machine's event
    # loops keep (with 1 s tokens, 0.2 s early, a CI run under load once sent a request late).
    async with running(token_lifetime_s=3.0) as mock:
        async with client(mock.url) as c:
            await collect(follow(c, KIN12, PUBLISH_S, "poll"), duration_s=5.5, at_least=11)
            token = c.tokens.token
            assert token is not None and c.tokens.logins >= 3
        assert mock.count("PUT", "/automation/", status=401) == 0, "renewed before expiry"
        assert mock.state.tokens.check(token.value) == "the token was revoked"
        assert mock.count("DELETE", "/identity-manager/api/v2/auth/token") == 1


async def test_two_second_tokens_while_a_stream_runs_leave_no_gap() -> None:
    async with running(token_lifetime_s=2.0) as mock, client(mock.url) as c:
        samples = await collect(follow(c, KIN12, PUBLISH_S, keepalive_s=0.5), duration_s=5.0)
        assert c.tokens.logins >= 3, "the stream outlived several tokens"
    assert mock.count("GET", "/automation/api/v2/events/") >= 3
    # Renewed before each token ran out: no request, the streams included, was refused.
    assert mock.count("GET", "/automation/", status=401) == 0
    # In order, and no hole a reconnect would leave (a dead stream is noticed after 1.25 s):
    # the widest step is a few of this very run's publish periods, however busy the machine.
    times = [sample.t_source for sample in samples]
    assert times == sorted(set(times))
    assert max_gap(samples) <= 10 * statistics.median(np.diff(times)), max_gap(samples)
    assert all(isinstance(v, float) for s in samples for v in s.values.values())


async def test_a_stream_the_server_closes_is_reopened() -> None:
    async with running() as mock, client(mock.url) as c:
        samples = follow(c, KIN12, PUBLISH_S, keepalive_s=0.5)
        first = await collect(samples, duration_s=0.3)
        mock.state.faults.drop_streams()
        samples = follow(c, KIN12, PUBLISH_S, keepalive_s=0.5)
        got = []
        async with asyncio.timeout(10):
            async for sample in samples:
                got.append(sample)
                if len(got) == 3:
                    mock.state.faults.drop_streams()
                if len(got) == 20:
                    break
        await samples.aclose()  # type: ignore[attr-defined]
    assert first and len(got) == 20
    assert mock.count("GET", "/automation/api/v2/events/") >= 3


async def test_a_silent_stream_counts_as_dead_and_is_reopened() -> None:
    async with running() as mock, client(mock.url) as c:
        samples = follow(c, KIN12, PUBLISH_S, keepalive_s=0.2, retry=RetryPolicy(give_up_s=5))
        times: list[float] = []
        async with asyncio.timeout(15):
            async for sample in samples:
                times.append(sample.t_source)
                if len(times) == 2:
                    mock.state.faults.stall_streams = True
                    # Unstall once the client gave up on the silent stream and opened another.
                    loop = asyncio.get_running_loop()
                    loop.call_later(1.0, setattr, mock.state.faults, "stall_streams", False)
                if len(times) == 10:
                    break
        await samples.aclose()  # type: ignore[attr-defined]
    assert mock.count("GET", "/automation/api/v2/events/") >= 2
    assert times[2] - times[1] >= 0.5, "the stall happened between these samples"


@pytest.mark.parametrize("mode", ["subscribe", "poll", "get"])
async def test_a_bad_node_spoils_only_its_own_value(mode: str) -> None:
    nodes = [KIN12[0], "motion/axs/nope/state/values/actual/pos", IIWA[0]]
    async with running() as mock, client(mock.url) as c:
        samples = await collect(follow(c, nodes, PUBLISH_S, mode), duration_s=0.3)  # type: ignore[arg-type]
    last = samples[-1].values
    assert isinstance(last[KIN12[0]], float) and isinstance(last[IIWA[0]], float)
    assert isinstance(last[nodes[1]], NodeNotFound)
    assert "DL_INVALID_ADDRESS" in str(last[nodes[1]])


async def test_every_node_bad_is_an_error_of_the_source() -> None:
    async with running() as mock, client(mock.url) as c:
        with pytest.raises(NodeNotFound):
            await collect(follow(c, ["motion/axs/nope/x"], PUBLISH_S), duration_s=1.0)


async def test_subscribe_falls_back_to_bulk_polling_then_to_single_gets() -> None:
    async with running(subscriptions=False) as mock, client(mock.url) as c:
        await collect(follow(c, KIN12, PUBLISH_S), duration_s=0.3, at_least=3)
        assert c.capabilities.subscribe is False and c.capabilities.bulk is True
    assert mock.count("PUT", "/automation/api/v2/bulk") >= 3
    async with running(subscriptions=False, bulk_reads=False) as mock, client(mock.url) as c:
        await collect(follow(c, KIN12, PUBLISH_S), duration_s=0.3, at_least=3)
        assert c.capabilities.bulk is False
    assert mock.count("GET", "/automation/api/v2/nodes/") >= 2 * 3


async def test_short_form_when_created_subscriptions_are_refused() -> None:
    app = build_app()

    @web.middleware
    async def no_post(request: web.Request, handler: Handler) -> web.StreamResponse:
        if request.method == "POST" and request.path == "/automation/api/v2/events":
            return web.json_response({"type": "about:blank", "title": "nope"}, status=405)
        return await handler(request)

    app.middlewares.append(no_post)
    async with running(app) as mock, client(mock.url) as c:
        await collect(follow(c, KIN12, PUBLISH_S), duration_s=0.3, at_least=3)
    assert mock.count("GET", "/automation/api/v2/events") == 1
    assert ("GET", "/automation/api/v2/events", 200) in mock.log


async def test_older_firmware_paths() -> None:
    async with running() as mock, client(mock.url, api="v1") as c:
        await collect(follow(c, KIN12, PUBLISH_S), duration_s=0.3, at_least=2)
    assert mock.count("POST", "/identity-manager/api/v1.0/auth/token") == 1
    assert mock.count("GET", "/automation/api/v1/motion/axs/") >= 2
    assert not any(p.startswith("/automation/api/v2") for _, p, _ in mock.log)


async def test_keepalives_keep_samples_coming_when_nothing_changes() -> None:
    machine = Machine(clock=lambda: 1.7e9)  # a machine at rest
    async with running(build_app(machine, changes_only=True)) as mock, client(mock.url) as c:
        samples = await collect(
            follow(c, KIN12, PUBLISH_S, keepalive_s=0.1), duration_s=0.5, at_least=3
        )
    assert len({tuple(s.values.values()) for s in samples}) == 1


async def test_injected_errors_are_ridden_out() -> None:
    async with running() as mock, client(mock.url) as c:
        mock.state.faults.error_rate = 0.3
        await collect(follow(c, KIN12, PUBLISH_S, "poll"), duration_s=1.0, at_least=5)
    assert mock.count("PUT", "/automation/api/v2/bulk", status=500) >= 1


async def test_polls_missed_during_an_interruption_are_not_counted_as_merged_samples() -> None:
    # A second of failing reads (the device's fault, not our lateness) is ridden out; the
    # periods it lasted are not samples the server "fell behind on" (that reads as overloaded).
    interruption_s = 1.0
    async with running() as mock, client(mock.url) as c:
        samples = follow(c, KIN12, PUBLISH_S, "poll")
        async with asyncio.timeout(20):
            await anext(samples)
            mock.state.faults.error_rate = 1.0
            await asyncio.sleep(interruption_s)
            mock.state.faults.error_rate = 0.0
            after = [await anext(samples) for _ in range(3)]
        await samples.aclose()  # type: ignore[attr-defined]
    missed = interruption_s / PUBLISH_S
    assert max(s.received for s in after) < missed / 2, [s.received for s in after]


async def test_every_request_has_a_timeout() -> None:
    async with running() as mock, client(mock.url, timeout_s=0.2) as c:
        mock.state.faults.latency_s = 1.0
        with pytest.raises(DataLayerError, match="no answer .* within 0.2 s"):
            async with asyncio.timeout(5):
                await c.read_number(KIN12[0])
        mock.state.faults.latency_s = 0.0


async def test_outage_is_reported_and_recovered_by_the_acquisition() -> None:
    async with running() as mock:
        settings = Settings(ctrlx_url=mock.url, keepalive_s=0.2)
        runtime = await Runtime.start(configured_cell(settings), source_defaults(settings))
        try:
            health = runtime.healths()[0]
            await wait_until(lambda: health.state == "connected")
            mock.state.faults.outage = True
            await wait_until(lambda: health.state == "error", timeout_s=20)
            assert "cannot reach" in (health.error or "")
            mock.state.faults.outage = False
            await wait_until(lambda: health.state == "connected", timeout_s=20)
        finally:
            await runtime.stop()


async def test_an_outage_is_logged_once_per_change_of_state_with_a_count(
    caplog: pytest.LogCaptureFixture,
) -> None:
    async with running() as mock:
        settings = Settings(ctrlx_url=mock.url, keepalive_s=0.2)
        runtime = await Runtime.start(configured_cell(settings), source_defaults(settings))
        try:
            (source,) = runtime.sources.values()
            await wait_until(lambda: source.health.state == "connected")
            caplog.clear()
            caplog.set_level(logging.INFO)
            mock.state.faults.outage = True
            # Several attempts (the acquisition tries again within 1.5 s).
            await wait_until(lambda: source.connector.client.failed_starts >= 4, timeout_s=30)
            during = [r.getMessage() for r in caplog.records]
            mock.state.faults.outage = False
            await wait_until(lambda: source.health.state == "connected", timeout_s=20)
            attempts = source.acquisition.failures
        finally:
            await runtime.stop()
    # The outage is news once: the broken stream, the error, the silence; no line per attempt.
    assert len(during) <= 4, during
    assert not [m for m in during if "subscribing" in m or "polling" in m], during
    back = [r.getMessage() for r in caplog.records if "samples again" in r.getMessage()]
    assert back == [f"{mock.url}: samples again, after {attempts} failed attempts"]


async def test_https_with_the_devices_certificate(tmp_path: Path) -> None:
    async with running(tls_dir=tmp_path) as mock:
        assert mock.url.startswith("https://") and mock.cert is not None
        async with client(mock.url, ssl_context=client_ssl(mock.cert.ca_file)) as c:
            assert isinstance(await c.read_number(KIN12[0]), float)
        async with client(mock.url, ssl_context=ssl.create_default_context()) as c:
            with pytest.raises(DataLayerError, match="--ctrlx-ca"):
                await c.read_number(KIN12[0])


async def test_a_certificate_for_another_name_is_called_that(tmp_path: Path) -> None:
    cert = make_certificate(tmp_path, hosts=("plc.example",))  # and 127.0.0.1, not localhost
    port = free_port()
    runner, _ = await serve_mock(build_app(), "127.0.0.1", port, cert.server_context())
    try:
        async with client(f"https://localhost:{port}", ca_file=cert.ca_file) as c:
            with pytest.raises(DataLayerError) as caught:
                await c.read_number(KIN12[0])
    finally:
        await runner.cleanup()
    assert "is not made out to that name or address" in str(caught.value)
    assert "CN=linkview mock ctrlX CORE (SHA-256 " in str(caught.value)


async def test_insecure_works_but_warns(tmp_path: Path, caplog: pytest.LogCaptureFixture) -> None:
    with caplog.at_level(logging.WARNING, logger="server.ctrlx.tls"):
        context = client_ssl(insecure=True)
    assert "verification is OFF" in caplog.text
    async with running(tls_dir=tmp_path) as mock, client(mock.url, ssl_context=context) as c:
        assert isinstance(await c.read_number(KIN12[0]), float)
