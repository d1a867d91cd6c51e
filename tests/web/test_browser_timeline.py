"""The timeline in a real browser: pause, seek back, the readouts show then; Live is now again."""

from __future__ import annotations

import math
from collections.abc import Iterator
from pathlib import Path

import numpy as np
import pytest
from mcap.reader import make_reader
from playwright.sync_api import Browser

from tests.conftest import free_port
from tests.web._browser import (
    Watched,
    history_json,
    open_page,
    post_json,
    screenshot,
    server_process,
    watch,
)

TIMEOUT_MS = 30_000
ROBOT = "iiwa7"


@pytest.fixture(scope="module")
def server_url(tmp_path_factory: pytest.TempPathFactory) -> Iterator[str]:
    log = tmp_path_factory.mktemp("server") / "server.log"
    with server_process(free_port(), log, "--history", "60") as url:
        yield url


@pytest.fixture(scope="module")
def viewer(browser: Browser, server_url: str) -> Iterator[Watched]:
    page = browser.new_page(viewport={"width": 720, "height": 480})  # software WebGL: few pixels
    watched = watch(page)
    open_page(page, f"{server_url}/?quality=5", 3 * TIMEOUT_MS)  # software WebGL on busy cores
    yield watched
    page.close()


def test_pause_seek_back_five_seconds_then_live(viewer: Watched, server_url: str) -> None:
    page = viewer.page
    page.wait_for_timeout(7000)  # more than 5 s of history to go back into
    page.get_by_role("button", name="pause on this moment (space)").click()
    page.wait_for_function("() => window.linkview.timeline.mode === 'paused'")
    paused = page.evaluate("window.linkview.timeline")
    target = paused["moment"] - 5.0
    span = paused["span"]
    value = round((target - span["from"]) / (span["to"] - span["from"]) * 1000)
    slider = page.get_by_role("slider", name="Timeline")
    assert page.get_by_text("Timeline", exact=True).is_visible()
    slider.fill(str(value))  # sets the value and fires input, as dragging does
    # The slider spans the history up to the live edge, which moves on while the test
    # types: within a second of the target is "5 s back"; what follows uses the moment.
    page.wait_for_function(
        f"() => Math.abs(window.linkview.timeline.moment - {target}) < 1.0"
        f" && window.linkview.timeline.fetches > 0"
    )
    moment = page.evaluate("window.linkview.timeline.moment")
    # The sample shown: the last one at or before the moment.
    window = history_json(server_url, moment - 0.5, moment)
    (robot,) = [r for r in window["robots"] if r["name"] == ROBOT]
    joints = robot["joints"][-1]
    page.wait_for_function(
        "([name, q]) => { const r = window.linkview.readout(name);"
        " return r && r.joints.every((v, i) => Math.abs(v - q[i]) < 1e-5); }",
        arg=[ROBOT, joints],
        timeout=TIMEOUT_MS,
    )
    shown = page.evaluate(f"window.linkview.readout('{ROBOT}')")
    status, fk = post_json(f"{server_url}/api/robots/{ROBOT}/fk", {"joints": [joints]})
    assert status == 200
    x, y, z = (1000.0 * v for v in fk["tcp"][0][:3])
    # Shown to 0.1 mm, as the live readouts: rounding leaves 0.05 (and float32 a little more).
    assert math.isclose(float(shown["tcp"]["x"]), x, abs_tol=0.051)
    assert math.isclose(float(shown["tcp"]["y"]), y, abs_tol=0.051)
    assert math.isclose(float(shown["tcp"]["z"]), z, abs_tol=0.051)
    state = page.get_by_role("status").filter(has_text="NOT LIVE")
    assert state.is_visible() and "paused at" in state.inner_text()
    assert page.evaluate("document.body.classList.contains('not-live')")
    screenshot(page, "timeline_paused.png")

    # Arrows step one sample; Live returns to the present.
    page.keyboard.press("ArrowRight")
    page.wait_for_function(f"() => window.linkview.timeline.moment > {moment}")
    stepped = page.evaluate("window.linkview.timeline.moment")
    assert stepped - moment < 0.2
    page.get_by_role("button", name="back to the live view").click()
    page.wait_for_function("() => window.linkview.timeline.mode === 'live'")
    page.wait_for_function(
        "([name, q]) => { const r = window.linkview.readout(name);"
        " return r && r.joints.some((v, i) => Math.abs(v - q[i]) > 1e-3); }",
        arg=[ROBOT, joints],
        timeout=TIMEOUT_MS,
    )
    live = page.evaluate("window.linkview.timeline")
    assert live["moment"] is None and live["liveT"] > paused["moment"]
    assert not page.evaluate("document.body.classList.contains('not-live')")
    viewer.assert_clean()


PLAYBACK = """() => new Promise(done => {
  const rows = [];
  function step(t) {
    const tl = window.linkview.timeline;
    rows.push([t, tl.moment, tl.mode]);
    if (t - rows[0][0] < 1500) requestAnimationFrame(step); else done(rows);
  }
  requestAnimationFrame(step);
})"""
"""(time, moment, mode) after each frame for 1.5 s."""


def test_space_plays_and_pauses_at_the_chosen_speed(viewer: Watched) -> None:
    page = viewer.page
    page.locator("body").click(position={"x": 360, "y": 200})
    page.keyboard.press("Space")
    page.wait_for_function("() => window.linkview.timeline.mode === 'paused'")
    paused = page.evaluate("window.linkview.timeline")
    span = paused["span"]
    back = (paused["moment"] - 10.0 - span["from"]) / (span["to"] - span["from"])
    page.get_by_role("slider", name="Timeline").fill(str(round(back * 1000)))
    page.wait_for_function(f"() => window.linkview.timeline.moment < {paused['moment'] - 5}")
    page.get_by_role("button", name="play at 4 times real time").click()
    page.evaluate("document.activeElement.blur()")  # space on a focused button clicks it
    page.keyboard.press("Space")
    page.wait_for_function("() => window.linkview.timeline.mode === 'playing'")
    # The playback rate, measured: the moment shown after each frame against the frames'
    # own clock (requestAnimationFrame's time, which the page's loop gets too). A frame
    # advances the moment by speed x its interval, an interval counted at most 250 ms
    # (static/js/timeline.js), so the rate is exact whatever this machine's frame rate.
    rows = page.evaluate(PLAYBACK)
    playing = [(t, m) for t, m, mode in rows if mode == "playing"]
    assert len(playing) >= 3, rows
    intervals = np.diff([t for t, _ in playing]) / 1000.0
    expected = 4 * float(np.minimum(intervals, 0.25).sum())
    advanced = playing[-1][1] - playing[0][1]
    # Each frame's addition to a unix time rounds by up to half a float64 step there (2.4e-7 s).
    rounding = len(playing) * float(np.spacing(playing[-1][1]))
    assert expected > 0.5 and abs(advanced - expected) <= rounding, (advanced, expected, rounding)
    page.keyboard.press("Space")
    page.wait_for_function("() => window.linkview.timeline.mode === 'paused'")
    page.get_by_role("button", name="back to the live view").click()
    viewer.assert_clean()


def test_save_recording_downloads_the_last_minutes_as_mcap(viewer: Watched, tmp_path: Path) -> None:
    page = viewer.page
    page.get_by_role("spinbutton", name="minutes of history to save").fill("0.1")
    save = page.get_by_role(
        "button", name="save the last minutes as an MCAP file (opens in Foxglove)"
    )
    with page.expect_download(timeout=TIMEOUT_MS) as download:
        save.click()
    path = tmp_path / "saved.mcap"
    download.value.save_as(path)
    assert download.value.suggested_filename.startswith("linkview-")
    with path.open("rb") as f:
        summary = make_reader(f).get_summary()
    assert summary is not None and summary.statistics is not None
    topics = {c.topic for c in summary.channels.values()}
    assert {"/tf", "/scene", f"/{ROBOT}/joints"} <= topics
    # About 6 s of samples (0.1 min) of three robots at 50 Hz, with their transforms.
    assert (
        summary.statistics.channel_message_counts[
            next(i for i, c in summary.channels.items() if c.topic == f"/{ROBOT}/joints")
        ]
        >= 100
    )
    assert page.get_by_role("status").filter(has_text="not saved").count() == 0
    viewer.assert_clean()
