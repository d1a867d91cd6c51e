"""The client's guards one by one: login spacing, bounds, lenient JSON, masking, start-up checks."""

from __future__ import annotations

import asyncio
import math
import ssl
import time
from pathlib import Path

import pytest
from aiohttp import web

from server.ctrlx import (
    BadValue,
    Credentials,
    DataLayerClient,
    DataLayerError,
    LoginBackoff,
    SseParser,
    StreamEnded,
    TokenManager,
    check_base_url,
    client_ssl,
    follow,
)
from server.ctrlx.bodies import MAX_BODY_BYTES, NOT_JSON, BodyTooLarge, decode, loads
from server.ctrlx.problem import ProblemError
from server.ctrlx.redact import Redactor
from server.ctrlx.sse import SseEvent
from server.ctrlx.updates import InvalidEvent, Update, decode_event
from server.ctrlx.values import bulk_values
from server.mock_ctrlx import make_certificate
from tests.ctrlx.fake_device import NODES, Behaviour, FakeDevice, serving

# -- login spacing -------------------------------------------------------------


def test_login_gaps_grow_from_one_second_to_a_cap() -> None:
    backoff = LoginBackoff()
    assert [backoff.gap(n) for n in range(5)] == [0.0, 1.0, 1.25, 1.5, 1.5]


async def test_failed_logins_are_spaced_by_the_backoff() -> None:
    now = [100.0]
    calls: list[float] = []

    async def sleep(seconds: float) -> None:  # time passes only while the manager waits
        now[0] += seconds

    async def fetch() -> str:
        calls.append(now[0])
        if len(calls) <= 4:
            raise DataLayerError("500 login failed")
        return "opaque-token"

    backoff = LoginBackoff(first_s=0.1, factor=2.0, max_s=0.15)
    tokens = TokenManager(fetch, mono=lambda: now[0], sleep=sleep, backoff=backoff)
    for _ in range(4):
        with pytest.raises(DataLayerError):
            await tokens.current()
    assert await tokens.current() == "opaque-token"
    gaps = [b - a for a, b in zip(calls, calls[1:], strict=False)]
    # Growing by 2 from 0.1 s, capped at 0.15 s: uncapped it would be 0.1, 0.2, 0.4, 0.8.
    assert gaps == pytest.approx([0.1, 0.15, 0.15, 0.15])


async def test_rejected_tokens_are_spaced_and_an_accepted_one_ends_the_spacing() -> None:
    calls: list[float] = []

    async def fetch() -> str:
        calls.append(time.monotonic())
        return f"token-{len(calls)}"

    tokens = TokenManager(fetch, backoff=LoginBackoff(first_s=0.2, max_s=0.2))
    first = await tokens.current()
    second = await tokens.renew(first, rejected=True)  # the device refused it at once
    assert calls[1] - calls[0] >= 0.2
    tokens.accepted()
    # A planned renewal right after acceptance waits for nothing (5 s would fail the bound).
    slow = TokenManager(fetch, backoff=LoginBackoff(first_s=5.0, max_s=5.0))
    stale = await slow.current()
    slow.accepted()
    async with asyncio.timeout(1.0):
        assert await slow.renew(stale) != stale
    assert second == "token-2"


async def test_callers_queued_behind_a_failed_login_share_its_error() -> None:
    calls = 0

    async def fetch() -> str:
        nonlocal calls
        calls += 1
        await asyncio.sleep(0.05)
        raise DataLayerError("login failed")

    tokens = TokenManager(fetch)
    results = await asyncio.gather(*(tokens.current() for _ in range(10)), return_exceptions=True)
    assert all(isinstance(r, DataLayerError) for r in results)
    assert calls == 1, "eleven GETs of one sample must not mean eleven logins"


# -- bounded event streams -------------------------------------------------------


def test_sse_lines_and_events_are_bounded() -> None:
    parser = SseParser(max_line=16, max_event=64)
    assert parser.feed(b"data: 0123456789\n\n")[0].data == "0123456789"  # 16 bytes: fine
    with pytest.raises(StreamEnded, match="line longer than"):
        for _ in range(10):
            parser.feed(b"xxxxx")  # no line end ever
    assert not parser.pending, "what was held is let go, not kept alive by the traceback"
    parser = SseParser(max_line=16, max_event=64)
    with pytest.raises(StreamEnded, match="event larger than"):
        for _ in range(10):
            parser.feed(b"data: 012345678\n")  # no blank line ever


# -- lenient JSON and per-node errors ----------------------------------------------


def test_json_with_nan_and_infinity_literals_is_read() -> None:
    assert loads(b'{"a": 1.5}') == {"a": 1.5}
    nan, inf, ninf = loads(b"[NaN, Infinity, -Infinity]")
    assert math.isnan(nan) and inf == math.inf and ninf == -math.inf
    with pytest.raises(ValueError):
        loads(b"{broken")


def test_bodies_decode_by_what_they_hold() -> None:
    assert decode("text/plain", b'{"access_token": "t"}') == {"access_token": "t"}
    assert decode("text/html", b"<html>hi</html>") is NOT_JSON
    assert decode("application/json", b"{truncated") is NOT_JSON
    assert decode("text/plain", b"eyJhbGciOi.x.y") is NOT_JSON
    assert decode("application/json", b"  ") is None


@pytest.mark.parametrize("literal", [b"NaN", b"Infinity", b"-Infinity", b'"nan"', b'"abc"'])
def test_a_non_finite_value_in_a_bulk_answer_spoils_only_its_node(literal: bytes) -> None:
    body = (
        b'[{"address":"a","type":"double","value":1.5},{"address":"b","type":"double","value":%s}]'
    )
    read = bulk_values(["a", "b"], loads(body % literal))
    assert read.values["a"] == 1.5
    assert isinstance(read.values["b"], BadValue) and "b: value" in str(read.values["b"])


def test_a_nan_in_an_event_spoils_only_its_node_and_junk_is_an_invalid_event() -> None:
    nan = SseEvent("update", None, '{"node":"n","type":"double","value":NaN}')
    update = decode_event(nan, "/automation/api/v2/nodes/")
    assert isinstance(update, Update) and isinstance(update.value, BadValue)
    assert "not finite" in str(update.value)
    with pytest.raises(InvalidEvent, match="malformed JSON"):
        decode_event(SseEvent("update", None, "{nope"), "/automation/api/v2/nodes/")
    with pytest.raises(InvalidEvent, match="without a node"):
        decode_event(SseEvent("update", None, '{"value": 1}'), "/automation/api/v2/nodes/")


# -- masking -------------------------------------------------------------------------


def test_secrets_jwts_and_bearer_values_are_masked() -> None:
    redact = Redactor("correct-horse-battery")
    redact.add("opaque-token-1234")
    text = (
        "pw correct-horse-battery, tok opaque-token-1234, jwt eyJhbGciOi.eyJzdWIi.sig, "
        "header Authorization: Bearer abc.def"
    )
    masked = redact.text(text)
    for leak in ("correct-horse", "opaque-token", "eyJ", "abc.def"):
        assert leak not in masked
    assert masked.count("***") == 4
    # A short password is left alone: masking "wrong" would garble and reveal it.
    assert Redactor("wrong").text("wrong user name or password") == "wrong user name or password"


def test_problem_errors_are_masked_field_by_field() -> None:
    redact = Redactor("correct-horse-battery")
    err = redact.error(ProblemError(401, "Unauthorized", "bad password correct-horse-battery"))
    assert err.detail == "bad password ***"
    assert str(err) == "401 Unauthorized: bad password ***"


# -- start-up checks -------------------------------------------------------------------


@pytest.mark.parametrize(
    ("url", "says"),
    [
        ("192.168.1.1", "needs a scheme and a host"),
        ("https://", "needs a scheme and a host"),
        ("ftp://192.168.1.1", "scheme 'ftp' is not http or https"),
        ("https://ctrlx:99999", "invalid port"),
        ("https://ctrlx/?a=b", "query or fragment"),
        ("https://me:pw@ctrlx", "not in the URL"),
    ],
)
def test_unusable_urls_raise_one_clear_line(url: str, says: str) -> None:
    with pytest.raises(ValueError, match=says) as caught:
        check_base_url(url)
    assert "\n" not in str(caught.value) and ":pw@" not in str(caught.value)


def test_plain_http_warns_unless_it_stays_on_this_machine() -> None:
    assert "credentials travel in clear" in (check_base_url("http://192.168.1.1") or "")
    for url in ("https://192.168.1.1", "http://127.0.0.1:8000", "http://localhost", "http://[::1]"):
        assert check_base_url(url) is None


def test_ca_files_that_cannot_work_raise_clear_value_errors(tmp_path: Path) -> None:
    junk, empty, blank = tmp_path / "junk.pem", tmp_path / "empty.pem", tmp_path / "blank.pem"
    junk.write_text("not a certificate\n")
    empty.write_bytes(b"")  # cadata="" would trust the system's CAs instead
    blank.write_text("\n  \n")
    for path, says in ((tmp_path / "none.pem", "does not exist"), (tmp_path, "is not a file"),
                       (junk, "holds no PEM certificate"), (empty, "is empty"),
                       (blank, "is empty")):  # fmt: skip
        with pytest.raises(ValueError, match=says):
            client_ssl(path)


def test_a_ca_file_trusts_exactly_its_certificate(tmp_path: Path) -> None:
    context = client_ssl(make_certificate(tmp_path).ca_file)
    assert isinstance(context, ssl.SSLContext)
    assert context.verify_mode == ssl.CERT_REQUIRED and context.check_hostname
    (trusted,) = context.get_ca_certs()  # the device's certificate, no system CA besides
    assert trusted["subject"] == ((("commonName", "linkview mock ctrlX CORE"),),)


# -- bounded bodies and re-probing, over real sockets -------------------------------------------


async def test_a_body_announced_larger_than_the_cap_is_not_read() -> None:
    async def huge(request: web.Request) -> web.Response:
        return web.Response(body=b" " * (MAX_BODY_BYTES + 1), content_type="application/json")

    device = FakeDevice()
    app = device.app()
    app.router.add_get("/automation/api/v2/nodes/huge", huge)
    runner = web.AppRunner(app, access_log=None)
    await runner.setup()
    site = web.TCPSite(runner, "127.0.0.1", 0)
    await site.start()
    url = f"http://127.0.0.1:{runner.addresses[0][1]}"
    try:
        async with DataLayerClient(url, Credentials(device.user, device.password)) as client:
            with pytest.raises(BodyTooLarge, match="over 4 MiB"):
                await client.read("huge")
            assert client.traffic.bytes_in < 1024 * 1024
    finally:
        await runner.cleanup()


async def test_follow_tries_refused_subscriptions_again_after_reprobe_s() -> None:
    device = FakeDevice()
    device.behaviour = Behaviour(events="refuse")
    async with serving(device) as url:
        async with DataLayerClient(url, Credentials(device.user, device.password)) as client:
            samples = follow(client, NODES, 0.02, reprobe_s=0.3)
            async with asyncio.timeout(10):
                async for sample in samples:  # noqa: B007 (the last one is checked)
                    if "subscriptions refused" in (client.warning or ""):
                        device.heal()
                    if device.counts.stream_opens and client.warning is None:
                        break
            await samples.aclose()
    assert device.counts.stream_opens >= 1, "back on the event stream"
    assert all(isinstance(v, float) for v in sample.values.values())


async def test_a_refusal_is_remembered_when_follow_restarts() -> None:
    # The acquisition restarts follow() after every error: that must not re-ask every time.
    device = FakeDevice()
    device.behaviour = Behaviour(bulk="refuse")
    async with serving(device) as url:
        async with DataLayerClient(url, Credentials(device.user, device.password)) as client:
            for _ in range(3):
                samples = follow(client, NODES, 0.02, "poll", reprobe_s=60.0)
                sample = await anext(samples)
                assert all(isinstance(v, float) for v in sample.values.values())
                await samples.aclose()
            assert "bulk reads refused" in (client.warning or "")
    assert device.counts.refusals == 1
    assert device.counts.node_reads >= 3 * len(NODES)
