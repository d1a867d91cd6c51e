"""The whole server against a hostile or broken device (tests/ctrlx/fake_device.py).

Every case runs linkview (uvicorn, acquisition, client) against the fake on
real loopback sockets and reads ``GET /api/health``. Each checks that the
fault ends in a clear error or warning, that the server streams again once the
device behaves (within a generous 10 s; on a quiet machine it takes under 2 s,
``bench/device_recovery.py``), that our RSS grew by less than 20 MB while the
fault ran, and that no password or token reached the log or the health report.
"""

from __future__ import annotations

import asyncio
import ctypes
import gc
import logging
import sys
import time
import traceback
from collections.abc import AsyncIterator, Callable
from contextlib import asynccontextmanager
from pathlib import Path
from typing import Any

import aiohttp
import orjson
import pytest
from pydantic import SecretStr

from server.config import Settings
from server.ctrlx import Credentials, DataLayerClient, DataLayerError
from tests.conftest import running_server
from tests.ctrlx.fake_device import Behaviour, FakeDevice, LoginAnswer, serving

Health = dict[str, Any]
log = logging.getLogger(__name__)

FAULT_S = 1.0
"""How long a fault runs on after it shows, before RSS is read again and the device heals."""
LONG_FAULT_S = 2.5
"""The same for faults that would make an unbounded reader hoard memory."""
SHOW_S = 15.0
"""Bound on the wait for the fault to show in /api/health."""
RECOVER_S = 10.0
"""Bound on the wait for streaming again after the device behaves (the figure: the bench)."""
RSS_LIMIT = 20 * 1024 * 1024
STATUS_S = 5.0
"""Bound on the wait for a status change that follows recovery (status comes every 1 s)."""


_LIBC = ctypes.CDLL("libc.so.6")


def rss() -> int:
    """This process's resident set size in bytes, after handing freed memory back.

    Without the collection and ``malloc_trim``, memory freed but kept by the
    allocator (more of it the more tests ran before in this process) reads
    as growth: the same case grew 5 MB alone and up to 21 MB after the others.
    """
    gc.collect()
    _LIBC.malloc_trim(0)
    for line in Path("/proc/self/status").read_text().splitlines():
        if line.startswith("VmRSS:"):
            return int(line.split()[1]) * 1024
    raise AssertionError("no VmRSS in /proc/self/status")


class Linkview:
    """A running server's health report, every text of it kept for the secret scan."""

    def __init__(self, base: str, http: aiohttp.ClientSession) -> None:
        self.base = base
        self._http = http
        self.texts: list[str] = []

    async def health(self) -> Health:
        async with self._http.get(self.base + "/api/health") as resp:
            assert resp.status in (200, 503)  # 503: degraded, which the faults are about
            text = await resp.text()
        self.texts.append(text)
        result: Health = orjson.loads(text)["sources"][0]
        return result

    async def until(self, predicate: Callable[[Health], bool], timeout_s: float) -> Health:
        """The first health report that satisfies ``predicate`` (fails after ``timeout_s``)."""
        last: Health = {}
        try:
            async with asyncio.timeout(timeout_s):
                while not predicate(last := await self.health()):
                    await asyncio.sleep(0.05)
        except TimeoutError:
            raise AssertionError(f"not within {timeout_s} s; last health: {last}") from None
        return last


@asynccontextmanager
async def linkview(device: FakeDevice, **settings: Any) -> AsyncIterator[Linkview]:
    """linkview following ``device``: 0.2 s keepalive, 1 s request timeout."""
    async with serving(device) as url:
        options: dict[str, Any] = {"keepalive_s": 0.2, "request_timeout_s": 1.0, **settings}
        config = Settings(
            ctrlx_url=url,
            ctrlx_user=device.user,
            ctrlx_password=SecretStr(device.password),
            **options,
        )
        async with running_server(config) as base, aiohttp.ClientSession() as http:
            yield Linkview(base, http)


def streaming(h: Health) -> bool:
    """Connected, every robot has frames and is fine."""
    robots = h.get("robots", {})
    return (
        h.get("state") == "connected"
        and len(robots) == 3
        and all(r["ok"] and r["frames"] > 0 for r in robots.values())
    )


def failed_with(*fragments: str) -> Callable[[Health], bool]:
    """The source is in error, and its error says all of ``fragments``."""
    return lambda h: h.get("state") == "error" and all(f in (h["error"] or "") for f in fragments)


def assert_no_secret(
    device: FakeDevice, caplog: pytest.LogCaptureFixture, texts: list[str]
) -> None:
    records = [f"{r.name} {r.getMessage()} {r.exc_text or ''}" for r in caplog.records]
    corpus = "\n".join([caplog.text, *records, *texts])
    assert device.issued, "the fake issued no token: the scan would prove nothing"
    for secret in device.secrets():
        assert secret not in corpus
    assert "eyJ" not in corpus  # the start of any JWT


async def fault_case(
    device: FakeDevice,
    caplog: pytest.LogCaptureFixture,
    fault: Behaviour,
    shows: Callable[[Health], bool],
    *,
    mid_run: bool = False,
    recovered: Callable[[Health], bool] = streaming,
    then: Callable[[Health], bool] | None = None,
    then_s: float = STATUS_S,
    fault_s: float = FAULT_S,
    peak: asyncio.Barrier | None = None,
    **settings: Any,
) -> Health:
    """Run linkview against ``device`` with ``fault`` (from the start, or once streaming).

    ``then`` must hold within ``then_s`` after recovery: a warning's end shows
    only with the next status, which comes once a second while streaming.
    RSS is read once the fault shows (server start-up is not the fault's doing)
    and again ``fault_s`` later, before the device heals. With ``peak``, RSS is
    left to the caller, who reads it at the first two of three barrier waits,
    so that every case sharing ``peak`` has its fault running meanwhile.
    Returns the health report that showed the fault.
    """
    caplog.set_level(logging.DEBUG)
    if not mid_run:
        device.behaviour = fault
    grown = 0
    try:
        async with linkview(device, **settings) as lv:
            if mid_run:
                await lv.until(streaming, timeout_s=10.0)
                device.behaviour = fault
            shown = await lv.until(shows, timeout_s=SHOW_S)
            before = rss()
            if peak is not None:
                await peak.wait()
            await asyncio.sleep(fault_s)
            if peak is None:
                grown = rss() - before
            else:
                await peak.wait()
                await peak.wait()
            device.heal()
            healed = time.monotonic()
            await lv.until(recovered, timeout_s=RECOVER_S)
            took = time.monotonic() - healed
            log.info("RSS grew %.1f MB; recovered in %.2f s", grown / 2**20, took)
            if then is not None:
                await lv.until(then, timeout_s=then_s)
    except BaseException:
        if peak is not None:
            await peak.abort()  # do not leave the other cases waiting
        raise
    assert grown < RSS_LIMIT, f"RSS grew {grown / 2**20:.1f} MB during the fault"
    assert_no_secret(device, caplog, lv.texts)
    return shown


@pytest.fixture
def device() -> FakeDevice:
    return FakeDevice()


SKEW_FRAMES = 100
"""Frames of every robot watched under a skewed clock (2 s at 50 Hz), health read throughout."""


@pytest.mark.parametrize("offset_s", [-7200.0, 7200.0], ids=["behind", "ahead"])
async def test_controller_clock_skew_streams_on_without_a_gap_or_another_login(
    offset_s: float, device: FakeDevice, caplog: pytest.LogCaptureFixture
) -> None:
    caplog.set_level(logging.DEBUG)
    # One-hour tokens stamped on the device's clock, two hours off ours: behind, they arrive
    # already expired by our clock (a renewal planned from exp storms the device); ahead,
    # they are issued in our future.
    device.behaviour = Behaviour(clock_offset_s=offset_s)
    async with linkview(device) as lv:
        first = await lv.until(streaming, timeout_s=SHOW_S)
        start = {name: robot["frames"] for name, robot in first["robots"].items()}
        reports = [first]

        def watched(h: Health) -> bool:
            reports.append(h)
            return all(r["frames"] >= start[n] + SKEW_FRAMES for n, r in h["robots"].items())

        await lv.until(watched, timeout_s=SHOW_S)
    # No gap: every health report said streaming, and the device's one event stream stayed
    # open. One login however long the run took: the token lives an hour on our clock.
    assert all(streaming(h) for h in reports), [h for h in reports if not streaming(h)]
    assert device.counts.stream_opens == 1
    assert device.counts.login_attempts == device.counts.logins == 1
    assert device.counts.rejected == 0
    warned = [r for r in caplog.records if "clock skew" in r.getMessage()]
    if offset_s < 0:
        assert "about 2.0 h behind" in first["warning"]
        assert len(warned) == 1
    else:  # a clock ahead leaves the token's lifetime as it is: nothing to warn about
        assert first["warning"] is None and warned == []
    assert_no_secret(device, caplog, lv.texts)


def assert_spaced_logins(device: FakeDevice) -> None:
    """Logins after failures come at least a second apart (LoginBackoff's first gap), so
    their number follows the fault's duration, never a storm (a slower machine only
    spaces them more)."""
    times = device.counts.login_times
    assert len(times) >= 2, "the fault must have caused a second login: nothing was checked"
    gaps = [b - a for a, b in zip(times, times[1:], strict=False)]
    assert min(gaps) >= 1.0 - LOGIN_SLACK_S, gaps


LOGIN_SLACK_S = 0.25
"""The device sees a login request a little after the client sent it, and on a loaded machine
one arrives later than the next (0.93 s apart once, with a busy loop beside): a storm is
logins milliseconds apart."""


async def test_tokens_that_expire_before_issue_are_rejected_without_a_login_storm(
    device: FakeDevice, caplog: pytest.LogCaptureFixture
) -> None:
    fault = Behaviour(exp=1000.0)  # exp in 1970: the device rejects its own tokens
    shown = await fault_case(device, caplog, fault, failed_with("401", "expired"))
    assert "expire before they are issued" in shown["warning"]
    assert_spaced_logins(device)


async def test_login_answering_500(device: FakeDevice, caplog: pytest.LogCaptureFixture) -> None:
    await fault_case(
        device, caplog, Behaviour(login="500"), failed_with("500", "identity manager not ready")
    )
    assert_spaced_logins(device)


async def test_html_pages_instead_of_json(
    device: FakeDevice, caplog: pytest.LogCaptureFixture
) -> None:
    shown = await fault_case(device, caplog, Behaviour(html=True), failed_with("text/html"))
    assert "router setup" not in shown["error"], "bodies are summarised, never quoted"
    assert "ctrlX CORE?" in shown["error"]


async def test_connection_reset_mid_stream(
    device: FakeDevice, caplog: pytest.LogCaptureFixture
) -> None:
    await fault_case(device, caplog, Behaviour(events="reset"), failed_with("event stream"))


async def test_a_stall_without_a_byte(device: FakeDevice, caplog: pytest.LogCaptureFixture) -> None:
    # Mid-run: the open stream falls silent, and every new request hangs for 10 s.
    shown = await fault_case(
        device, caplog, Behaviour(stall=True), lambda h: h.get("state") == "error", mid_run=True
    )
    assert "within 1 s" in shown["error"] or "silent" in shown["error"]


UNBOUNDED: list[tuple[Behaviour, Callable[[Health], bool], dict[str, Any]]] = [
    (Behaviour(events="endless_line"), failed_with("line longer than 64 KiB"), {}),
    (Behaviour(events="endless_data"), failed_with("larger than 1 MiB"), {}),
    (Behaviour(events="junk"), failed_with("no valid event"), {}),
    (Behaviour(bulk="endless"), failed_with("larger than 4 MiB"), {"ctrlx_mode": "poll"}),
]
"""An SSE line without end, data lines without the blank line, bytes but no valid event,
a response body without end; each is cut, reported and reopened."""


async def test_endless_answers_are_cut_and_memory_stays_flat(
    caplog: pytest.LogCaptureFixture,
) -> None:
    # All four at once, each against its own device and server: their RSS growth together
    # must stay under the limit, measured while every fault is running.
    peak = asyncio.Barrier(len(UNBOUNDED) + 1)
    cases = asyncio.gather(
        *(
            fault_case(FakeDevice(), caplog, fault, shows, fault_s=LONG_FAULT_S, peak=peak, **opts)
            for fault, shows, opts in UNBOUNDED
        )
    )
    try:
        async with asyncio.timeout(SHOW_S + LONG_FAULT_S + 5.0):
            await peak.wait()  # every fault shows
            before = rss()
            await peak.wait()  # every fault ran LONG_FAULT_S more
            grown = rss() - before
            await peak.wait()
    except asyncio.BrokenBarrierError:
        await cases  # raises what broke it
        raise
    await cases
    log.info("RSS grew %.1f MB with all four running", grown / 2**20)
    assert grown < RSS_LIMIT, f"RSS grew {grown / 2**20:.1f} MB during the faults"


@pytest.mark.parametrize("mode", ["subscribe", "poll", "get"])
async def test_a_nan_literal_spoils_only_the_robot_that_reads_it(
    mode: str, device: FakeDevice, caplog: pytest.LogCaptureFixture
) -> None:
    def only_positioner(h: Health) -> bool:
        robots = h.get("robots", {})
        return (
            h.get("state") == "connected"
            and robots.get("positioner", {}).get("ok") is False
            and "not finite" in (robots["positioner"]["error"] or "")
            and all(robots.get(r, {}).get("ok") for r in ("kin12", "iiwa7"))
        )

    shown = await fault_case(device, caplog, Behaviour(nan="NaN"), only_positioner, ctrlx_mode=mode)
    assert "pos_turn" in shown["robots"]["positioner"]["error"]


async def test_refused_subscriptions_are_tried_again(
    device: FakeDevice, caplog: pytest.LogCaptureFixture, monkeypatch: pytest.MonkeyPatch
) -> None:
    monkeypatch.setattr(sys.modules["server.ctrlx.follow"], "REPROBE_S", 1.0)
    shown = await fault_case(
        device,
        caplog,
        Behaviour(events="refuse"),
        lambda h: streaming(h) and "subscriptions refused" in (h["warning"] or ""),
        recovered=lambda h: streaming(h) and device.counts.stream_opens > 0,
        then=lambda h: streaming(h) and h["warning"] is None,
    )
    assert "asking again every 1 s" in shown["warning"]


async def test_refused_bulk_reads_are_tried_again(
    device: FakeDevice, caplog: pytest.LogCaptureFixture, monkeypatch: pytest.MonkeyPatch
) -> None:
    monkeypatch.setattr(sys.modules["server.ctrlx.follow"], "REPROBE_S", 1.0)
    await fault_case(
        device,
        caplog,
        Behaviour(bulk="refuse"),
        lambda h: streaming(h) and "bulk reads refused" in (h["warning"] or ""),
        recovered=lambda h: streaming(h) and device.counts.bulk_reads > 0,
        then=lambda h: streaming(h) and h["warning"] is None,
        ctrlx_mode="poll",
    )


SHAPES: list[tuple[Behaviour, tuple[str, ...]]] = [
    (Behaviour(login="text_token"), ("text/plain", "access_token")),
    (Behaviour(login="echo_password"), ("application/json", "access_token")),
    (Behaviour(login="html"), ("text/html",)),
    (Behaviour(login="problem_token"), ("500", "could not store token ***")),
    (Behaviour(login="problem_password"), ("401", "password '***'")),
    (Behaviour(login="unsendable"), ("cannot be sent as a header",)),
    (Behaviour(data_problem_token=True), ("403", "token *** lacks a scope")),
]


async def test_no_secret_whatever_the_login_answers(
    device: FakeDevice, caplog: pytest.LogCaptureFixture
) -> None:
    caplog.set_level(logging.DEBUG)
    before = rss()
    texts: list[str] = []  # every health report of every server below
    for fault, fragments in SHAPES:  # a fresh server each: it must log in and meet the answer
        device.behaviour = fault
        async with linkview(device) as lv:
            await lv.until(failed_with(*fragments), timeout_s=SHOW_S)
            await asyncio.sleep(0.3)  # a retry or two more
        texts += lv.texts
    grown = rss() - before
    async with linkview(device) as lv:
        device.heal()
        await lv.until(streaming, timeout_s=RECOVER_S)
    texts += lv.texts
    assert grown < RSS_LIMIT
    assert len(texts) > len(lv.texts), "the hostile logins' reports are scanned too"
    assert_no_secret(device, caplog, texts)


@pytest.mark.parametrize("answer", [f.login for f, _ in SHAPES if f.login != "ok"])
async def test_no_secret_in_exception_texts(answer: LoginAnswer) -> None:
    device = FakeDevice()
    device.behaviour.login = answer
    async with serving(device) as url:
        async with DataLayerClient(url, Credentials(device.user, device.password)) as client:
            with pytest.raises(DataLayerError) as caught:
                await client.read_number("motion/axs/kin12_a0/state/values/actual/pos")
    exc = caught.value
    text = "".join(traceback.format_exception(exc)) + repr(exc) + repr(vars(exc))
    assert "login" in text or "/auth/token" in text
    for secret in device.secrets():
        assert secret not in text
    assert "eyJ" not in text
