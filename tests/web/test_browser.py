"""The page in a real browser against the real server: robots, readouts, plots, simulation.

Drives Debian's Chromium (``/usr/bin/chromium``, software WebGL through
SwiftShader) with the playwright package; it never downloads a browser. One
server (``python -m server``, the demo cell with its embedded mock controller)
and one page serve the whole module; screenshots go to pytest's temporary folder.
"""

from __future__ import annotations

import io
import math
import re
import time
from collections.abc import Iterator
from typing import Any
from urllib.parse import urlsplit

import numpy as np
import pytest
from PIL import Image
from playwright.sync_api import Browser, Page

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
READOUTS_PER_S = 10
"""The readout tick (READOUT_INTERVAL_MS, static/js/app.js): plots and cards redraw on it."""
TRAIL_TOL_M = 1e-6
"""The trail keeps float32 (6e-8 m steps at 1 m): a micrometre is far below a wrong point."""
NOT_NETWORK = ("data", "blob", "about")
"""URL schemes that never leave the page."""


@pytest.fixture(scope="module")
def server_url(tmp_path_factory: pytest.TempPathFactory) -> Iterator[str]:
    """``python -m server`` on a free loopback port for the whole module."""
    log = tmp_path_factory.mktemp("server") / "server.log"
    # A short hold of a commanded pose keeps the Move test quick (the default is 30 s).
    with server_process(free_port(), log, env={"LINKVIEW_MOCK_HOLD_S": "3"}) as url:
        yield url


@pytest.fixture(scope="module")
def viewer(browser: Browser, server_url: str) -> Iterator[Watched]:
    """The page at 1280x800, loaded, every robot moving (quality pinned low: tests run faster)."""
    page = browser.new_page(viewport={"width": 1280, "height": 800})
    watched = watch(page)
    open_page(page, f"{server_url}/?quality=5", TIMEOUT_MS)
    yield watched
    page.close()


def _matrices(page: Page, names: list[str]) -> dict[str, list[list[float]]]:
    result: dict[str, list[list[float]]] = page.evaluate(
        "names => Object.fromEntries(names.map(n => [n, window.linkview.linkMatrices(n)]))", names
    )
    return result


def _names(page: Page) -> list[str]:
    names: list[str] = page.evaluate("Object.keys(window.linkview.framesApplied)")
    return names


def _screenshot(page: Page, name: str) -> None:
    screenshot(page, name)


def test_page_shows_moving_robots(viewer: Watched) -> None:
    page = viewer.page
    assert page.evaluate("window.linkview.connected") is True
    names = _names(page)
    first = _matrices(page, names)
    page.wait_for_timeout(500)
    second = _matrices(page, names)
    # Let the camera settle on the robots before the picture is taken.
    page.wait_for_timeout(1000)
    _screenshot(page, "browser.png")

    for name in names:
        links = first[name]
        assert links and all(len(m) == 16 for m in links), f"{name}: bad link matrices {links}"
    still = [name for name in names if first[name] == second[name]]
    assert not still, f"robots that did not move in 0.5 s: {still}"
    viewer.assert_clean()
    assert any(urlsplit(url).path.endswith(".glb") for url in viewer.requests), "no mesh requested"


def test_pills_say_the_server_and_the_controller_are_up(viewer: Watched) -> None:
    page = viewer.page
    page.wait_for_function("() => document.getElementById('banner').hidden", timeout=TIMEOUT_MS)
    assert page.inner_text("#pill-server") == "server: connected"
    assert page.inner_text("#pill-controllers") == "controller: connected"
    assert "demo (mock)" in page.inner_text("#sources")


def _fk(server_url: str, name: str, joints: list[float]) -> dict[str, Any]:
    status, answer = post_json(f"{server_url}/api/robots/{name}/fk", {"joints": [joints]})
    assert status == 200 and answer["ok"] == [True], answer
    return {"tcp": answer["tcp"][0], "rpy": answer["rpy"][0]}


# The TCP fields of a robot's card, and the joints and text the page says it shows there.
READOUT = """name => {
  const card = document.querySelector(`article.robot[data-robot="${name}"]`);
  const dom = Object.fromEntries([...card.querySelectorAll('[data-tcp]')]
    .map(el => [el.dataset.tcp, el.textContent]));
  return { hook: window.linkview.readout(name), dom };
}"""


def _angle_gap(a_deg: float, b_deg: float) -> float:
    return abs((a_deg - b_deg + 180.0) % 360.0 - 180.0)


def test_tcp_readout_matches_fk_for_the_joints_shown(viewer: Watched, server_url: str) -> None:
    page = viewer.page
    for name in _names(page):
        shown = page.evaluate(READOUT, name)
        assert shown["hook"] is not None, name
        # The card shows what the page read, at the same instant.
        assert shown["dom"] == shown["hook"]["tcp"], shown
        expected = _fk(server_url, name, shown["hook"]["joints"])
        text = shown["dom"]
        # Shown to 0.1 mm and 0.1 deg: a correct readout is within half of that.
        for axis, metres in zip("xyz", expected["tcp"][:3], strict=True):
            assert abs(float(text[axis]) - metres * 1000) <= 0.051, (name, axis, text, expected)
        roll, pitch, yaw = (math.degrees(a) for a in expected["rpy"])
        assert abs(float(text["pitch"]) - pitch) <= 0.051, (name, text, expected)
        if abs(pitch) < 89.0:  # at gimbal lock only yaw -/+ roll is defined
            assert _angle_gap(float(text["roll"]), roll) <= 0.051, (name, text, expected)
            assert _angle_gap(float(text["yaw"]), yaw) <= 0.051, (name, text, expected)
    page.wait_for_function("() => window.linkview.robotState('iiwa7').latencyMs !== null")
    state = page.evaluate("window.linkview.robotState('iiwa7')")
    assert 0 <= state["latencyMs"] < 5000, state  # sample to screen, on one machine
    assert "latency" in page.locator("article.robot[data-robot='iiwa7'] .robot-state").inner_text()


def _plot_pixels(page: Page) -> list[str]:
    pixels: list[str] = page.evaluate(
        "[...document.querySelectorAll('#plots canvas')].map(c => c.toDataURL())"
    )
    return pixels


def test_joint_plots_are_drawn_and_move(viewer: Watched) -> None:
    page = viewer.page
    page.select_option("#selected-robot", "iiwa7")
    page.wait_for_function("() => window.linkview.plots.robot === 'iiwa7'")
    assert page.locator("#plots canvas").count() == 7
    assert page.locator("#plots .plot-title").first.inner_text() == "a1 (°)"
    before = page.evaluate("window.linkview.plots.redraws")
    first = _plot_pixels(page)
    page.wait_for_timeout(600)
    after = page.evaluate("window.linkview.plots.redraws")
    second = _plot_pixels(page)
    assert after > before, (before, after)
    moved = [i for i, (a, b) in enumerate(zip(first, second, strict=True)) if a != b]
    assert len(moved) >= 5, f"plots that did not change in 0.6 s: {len(first) - len(moved)}"
    _screenshot(page, "plots.png")


def test_joint_plots_are_tall_aligned_and_fitted_to_their_data(viewer: Watched) -> None:
    page = viewer.page
    page.select_option("#selected-robot", "iiwa7")
    page.wait_for_function("() => window.linkview.plots.robot === 'iiwa7'")
    # A few seconds of motion in the window, then every plot fitted to it.
    page.wait_for_function(
        "() => window.linkview.plots.layout.length === 7"
        " && window.linkview.plots.layout.every(p => p.y[1] - p.y[0] !== 2)",
        timeout=TIMEOUT_MS,
    )
    page.wait_for_timeout(2000)
    layout = page.evaluate("window.linkview.plots.layout")
    assert {p["left"] for p in layout} == {layout[0]["left"]}, layout  # time axes aligned
    narrower = 0
    for plot in layout:
        assert plot["height"] >= 60, plot  # px of drawing per joint
        (lo, hi), (y0, y1), limits = plot["data"], plot["y"], plot["limits"]
        assert y0 <= lo and hi <= y1, plot  # the data in view
        assert y1 - y0 >= 2, plot  # never a flat line
        data_span = max(hi - lo, 2)
        # Fitted to the data (padding and hysteresis aside), not to the limits...
        assert y1 - y0 <= 4 * data_span + 1e-9 or any(y0 <= limit <= y1 for limit in limits), plot
        # ... and a limit far from the data is out of view.
        for limit in limits:
            if min(abs(limit - lo), abs(limit - hi)) > 4 * data_span:
                assert not y0 <= limit <= y1, plot
        narrower += (y1 - y0) < (limits[1] - limits[0]) / 2
    assert narrower >= 3, layout  # the demo moves most joints over far less than their range
    captions = page.locator("#plots .plot-title").all_inner_texts()
    assert all(c.endswith(("(°)", "(mm)")) for c in captions), captions  # units on every y axis
    _screenshot(page, "plots_fitted.png")


def test_velocity_traces_and_one_plot_enlarged(viewer: Watched) -> None:
    page = viewer.page
    page.select_option("#selected-robot", "iiwa7")
    page.wait_for_function("() => window.linkview.plots.layout.length === 7")
    assert all(p["traces"] == 1 for p in page.evaluate("window.linkview.plots.layout"))
    page.check("#plot-velocity")
    # A second (velocity) trace on every plot, from the samples' differences, with its unit.
    page.wait_for_function(
        "() => window.linkview.plots.layout.length === 7"
        " && window.linkview.plots.layout.every(p => p.traces === 2 && p.velocity !== null)",
        timeout=TIMEOUT_MS,
    )
    title = page.locator("#plots .plot-title").first.inner_text()
    assert title == "a1 (°) · velocity (°/s, dashed)", title
    # The demo moves the iiwa's joints at up to 60 °/s: velocities of that order, not 0, not 1e4.
    page.wait_for_function(
        "() => window.linkview.plots.layout.some(p => Math.max(-p.velocity[0], p.velocity[1]) > 5)",
        timeout=TIMEOUT_MS,
    )
    for plot in page.evaluate("window.linkview.plots.layout"):
        assert max(-plot["velocity"][0], plot["velocity"][1]) < 1000, plot
    _screenshot(page, "plots_velocity.png")
    page.uncheck("#plot-velocity")
    page.wait_for_function("() => window.linkview.plots.layout.every(p => p.traces === 1)")

    # Enlarge a4's plot: it alone fills the panel's height; the same button brings all back.
    small = page.evaluate("window.linkview.plots.layout[3].height")
    page.click("button[aria-label='enlarge the plot of a4']")
    page.wait_for_function(
        f"() => window.linkview.plots.layout.length === 1"
        f" && window.linkview.plots.layout[0].height > 3 * {small}",
        timeout=TIMEOUT_MS,
    )
    assert page.evaluate("window.linkview.plots.layout[0].joint") == 3
    assert page.locator("#plots canvas").count() == 1
    _screenshot(page, "plot_enlarged.png")
    page.click("#plots button.plot-size")
    page.wait_for_function(
        "() => window.linkview.plots.layout.length === 7"
        " && window.linkview.plots.layout.every(p => p.height < 100)",
        timeout=TIMEOUT_MS,
    )


def test_hiding_a_robot_removes_it(viewer: Watched) -> None:
    page = viewer.page
    page.uncheck("input[aria-label='show iiwa7']")
    page.wait_for_function("() => !window.linkview.robotState('iiwa7').visible")
    page.wait_for_timeout(200)
    hidden = page.evaluate("window.linkview.renderInfo")
    page.check("input[aria-label='show iiwa7']")
    page.wait_for_function("() => window.linkview.robotState('iiwa7').visible")
    page.wait_for_timeout(200)
    shown = page.evaluate("window.linkview.renderInfo")
    # iiwa7's meshes hold some 60 % of the cell's triangles: not drawn while it is hidden.
    assert hidden["triangles"] < 0.6 * shown["triangles"], (hidden, shown)
    assert hidden["calls"] < shown["calls"], (hidden, shown)
    assert page.evaluate("window.linkview.robotState('kin12').visible") is True


def test_trail_follows_the_tcp_and_can_be_switched_off(viewer: Watched, server_url: str) -> None:
    page = viewer.page
    page.wait_for_function("() => window.linkview.robotState('iiwa7').trailPoints > 10")
    # Every point drawn is where the TCP was at one of the source's samples: the server's
    # /fk of the joints its history kept (base frame), not what the page computed.
    drawn = np.array(page.evaluate("window.linkview.trail('iiwa7')"))
    now = time.time()
    (robot,) = [r for r in history_json(server_url, now - 20.0, now + 1.0)["robots"]
                if r["name"] == "iiwa7"]  # fmt: skip
    status, fk = post_json(f"{server_url}/api/robots/iiwa7/fk", {"joints": robot["joints"]})
    assert status == 200
    path = np.array([tcp[:3] for tcp, ok in zip(fk["tcp"], fk["ok"], strict=True) if ok])
    nearest = np.linalg.norm(drawn[:, None, :] - path[None, :, :], axis=2).min(axis=1)
    assert len(drawn) > 10 and nearest.max() <= TRAIL_TOL_M, nearest.max()
    page.uncheck("input[aria-label='draw the TCP trail of iiwa7']")
    page.wait_for_function("() => window.linkview.robotState('iiwa7').trailPoints === 0")
    page.check("input[aria-label='draw the TCP trail of iiwa7']")
    page.wait_for_function("() => window.linkview.robotState('iiwa7').trailPoints > 2")
    # A shorter trail: at 50 samples/s, 1 s holds at most some 50 points (the next frames
    # trim it, however long they take on a busy machine).
    page.fill("#trail-seconds", "1")
    page.dispatch_event("#trail-seconds", "change")
    page.wait_for_function(
        "() => window.linkview.robotState('positioner').trailPoints <= 52", timeout=TIMEOUT_MS
    )
    page.fill("#trail-seconds", "5")
    page.dispatch_event("#trail-seconds", "change")


def _view_direction(page: Page) -> list[float]:
    camera = page.evaluate("window.linkview.camera")
    d = [p - t for p, t in zip(camera["position"], camera["target"], strict=True)]
    norm = math.hypot(*d)
    return [v / norm for v in d]


def test_view_presets_focus_and_home(viewer: Watched) -> None:
    page = viewer.page
    page.click("button[data-view='top']")
    assert _view_direction(page)[2] > 0.99  # looking down
    page.click("button[data-view='front']")
    assert _view_direction(page)[1] < -0.99  # from -Y
    page.click("button[data-view='side']")
    assert _view_direction(page)[0] > 0.99  # from +X
    page.click("button[aria-label='focus the camera on kin12']")
    target = page.evaluate("window.linkview.camera.target")
    base = page.evaluate("window.linkview.linkMatrices('kin12')[0]")
    assert math.dist(target[:2], base[12:14]) < 0.4, (target, base)  # kin12 is ~0.3 m wide
    page.keyboard.press("Home")
    x, y, z = _view_direction(page)
    assert x > 0.3 and y < -0.5 and z > 0.3, (x, y, z)  # back to the iso view of everything
    # Labels follow the camera on the next rendered frame: wait for it, then check them all.
    shown = "window.linkview.labels.map(l => l.shown)"
    page.wait_for_function(f"() => {shown}.every(Boolean)", timeout=TIMEOUT_MS)
    labels = page.evaluate(shown)
    assert labels == [True, True, True]  # every robot is on screen
    # Each tag (drawn in the view) names its robot, and its foot lies in the view.
    box = page.locator("#viewport canvas").bounding_box()
    assert box is not None
    for label in page.evaluate("window.linkview.labels"):
        assert label["text"] == label["robot"] and label["note"] is None, label
        assert box["x"] <= label["x"] <= box["x"] + box["width"], (label, box)
        assert 0 <= label["y"] <= box["height"], (label, box)


def test_world_axes_and_grid_spacing_are_labelled(viewer: Watched) -> None:
    page = viewer.page
    page.keyboard.press("Home")  # the iso view of everything
    page.wait_for_timeout(500)  # the camera's damping settles
    _assert_orientation_drawn(page)
    _screenshot(page, "orientation.png")


def _type_target(page: Page, values: dict[str, float]) -> None:
    for key, value in values.items():
        page.fill(f"#target-{key}", f"{value:.1f}")


def test_simulation_target_ghosts_move_and_unreachable(viewer: Watched, server_url: str) -> None:
    page = viewer.page
    page.select_option("#selected-robot", "iiwa7")
    page.wait_for_function("() => window.linkview.sim.robot === 'iiwa7'")
    assert page.is_visible("#sim")
    # A pose the arm can take, reached from another configuration than the current one.
    goal = [0.3, 0.5, -0.2, -1.2, 0.4, 0.9, 0.1]
    fk = _fk(server_url, "iiwa7", goal)
    x, y, z = (v * 1000 for v in fk["tcp"][:3])
    roll, pitch, yaw = (math.degrees(a) for a in fk["rpy"])
    _type_target(page, {"x": x, "y": y, "z": z, "roll": roll, "pitch": pitch, "yaw": yaw})
    page.click("#solve")
    page.wait_for_function("() => window.linkview.sim.ghosts > 0", timeout=TIMEOUT_MS)
    sim = page.evaluate("window.linkview.sim")
    assert sim["ghosts"] >= 2 and sim["selected"] >= 0, sim  # the iiwa reaches it several ways
    assert page.locator("#solutions input[type=radio]:checked").count() == 1
    assert "reach the target" in page.inner_text("#sim-status")
    # Each configuration by its name, how far each is from now and whether it is allowed;
    # the raw joint angles only in the tooltip.
    rows = page.locator("#solutions li label")
    names = [rows.nth(i).locator(".configuration").inner_text() for i in range(rows.count())]
    assert len(names) == len(set(names)) == sim["ghosts"], names
    flags = r"shoulder (front|back) · elbow [+−] · wrist (no-flip|flip)"
    assert all(re.fullmatch(flags, name) for name in names), names
    for i in range(rows.count()):
        row = rows.nth(i)
        assert re.fullmatch(r"largest joint move \d+\.\d°", row.locator(".distance").inner_text())
        allowed = row.locator(".inside, .outside").inner_text()
        assert allowed in ("within limits", "outside the limits")
        assert (row.get_attribute("title") or "").count("°") == 7  # the raw joints, in the tooltip
    page.check("#gizmo-on")  # the target can be dragged in the view too
    _screenshot(page, "ghosts.png")
    page.uncheck("#gizmo-on")

    page.click("#move")
    page.wait_for_function(
        "() => document.getElementById('sim-status').textContent.startsWith('Arrived')"
        " && document.getElementById('sim-status').textContent"
        ".includes('Holding the commanded pose (demo cycle resumes in ')",
        timeout=TIMEOUT_MS,
    )  # the mock holds it for the time hello announced (3 s here), and the page says so
    # The TCP of the joints the page shows, by the server's own FK, is on the target typed:
    # the solution is exact (some 1e-8 m), 1 um leaves room for float32 joints on the wire.
    # "Arrived" is said within a tolerance a person can see; the arm settles on the
    # setpoint after it, at the mock's drive lag.
    target = [float(page.input_value(f"#target-{k}")) / 1000 for k in "xyz"]
    deadline = time.monotonic() + TIMEOUT_MS / 1000
    while True:
        shown = page.evaluate("window.linkview.readout('iiwa7')")
        reached = _fk(server_url, "iiwa7", shown["joints"])["tcp"][:3]
        if math.dist(reached, target) <= 1e-6 or time.monotonic() > deadline:
            break
        page.wait_for_timeout(200)
    assert math.dist(reached, target) <= 1e-6, (reached, target)
    assert page.evaluate("window.linkview.sim.ghosts") >= 2  # the preview stays until a new solve
    # The embedded mock goes back to its demo cycle after the hold: the status follows the
    # pose, it does not keep saying "Arrived", and keeps following it.
    page.wait_for_function(
        "() => document.getElementById('sim-status').textContent.startsWith('Demo cycle resumed')",
        timeout=TIMEOUT_MS,
    )
    page.wait_for_function(
        "() => /the TCP is ([0-9]{3,}) mm from the target/.test("
        "document.getElementById('sim-status').textContent)",
        timeout=TIMEOUT_MS,
    )

    _type_target(page, {"x": 5000.0})
    page.click("#solve")
    page.wait_for_function(
        "() => document.getElementById('sim-status').textContent.startsWith('Unreachable')",
        timeout=TIMEOUT_MS,
    )
    assert "out of reach" in page.inner_text("#sim-status")
    assert page.evaluate("window.linkview.sim.ghosts") == 0
    assert page.is_disabled("#move")


def test_jogging_coalesces_moves(viewer: Watched) -> None:
    page = viewer.page
    page.select_option("#selected-robot", "kin12")
    page.wait_for_function("() => window.linkview.sim.robot === 'kin12'")
    before = page.evaluate("window.linkview.sim.jogs")
    # 40 slider steps at once: the first goes out, the newest follows once it is answered,
    # and nothing in between, however slowly the machine answers.
    page.evaluate(
        """() => { const s = document.querySelector("input[aria-label='jog a0']");
        for (let i = 0; i < 40; i++) { s.value = String(-20 + i * 0.5);
          s.dispatchEvent(new Event('input', { bubbles: true })); } }"""
    )
    # Both moves out and the newest one reached (the demo cycle alone may pass -0.5 deg, so
    # the readout by itself proves nothing), then nothing else goes out.
    page.wait_for_function(
        f"""() => window.linkview.sim.jogs - {before} >= 2
          && Math.abs(window.linkview.readout('kin12').joints[0] * 180 / Math.PI - (-0.5)) < 0.6""",
        timeout=TIMEOUT_MS,
    )
    page.wait_for_timeout(500)
    assert page.evaluate("window.linkview.sim.jogs") - before == 2


def test_every_control_says_what_it_does(viewer: Watched) -> None:
    unnamed = viewer.page.evaluate(
        """() => [...document.querySelectorAll('button, input, select')].filter(el => {
             if (el.getAttribute('aria-label')) return false;
             if (el.closest('label')) return false;
             if (el.id && document.querySelector(`label[for="${el.id}"]`)) return false;
             return !(el.tagName === 'BUTTON' && el.textContent.trim());
           }).map(el => el.outerHTML)"""
    )
    assert not unnamed, unnamed


def test_theme_follows_the_color_scheme(viewer: Watched) -> None:
    page = viewer.page
    panel = "getComputedStyle(document.getElementById('hud')).backgroundColor"
    page.emulate_media(color_scheme="light")
    light = page.evaluate(panel)
    page.emulate_media(color_scheme="dark")
    dark = page.evaluate(panel)
    page.emulate_media(color_scheme="light")
    channels = [float(c) for c in dark[dark.index("(") + 1 : -1].split(",")[:3]]
    assert light != dark and max(channels) < 80, (light, dark)


ROBOT_HUES = {"kin12": 215.0, "iiwa7": 25.0, "positioner": 175.0}
"""Hue (deg) of each robot's paint: kin12 blue, iiwa7 orange, positioner teal (assets/)."""
ONLY_THE_VIEW = (
    "body * { visibility: hidden !important } "
    "#viewport, #viewport canvas { visibility: visible !important }"
)
"""Screenshot style: the 3D view alone, without the panels and labels drawn over it."""
MIN_ROBOT_PIXELS = 300


def _view(page: Page, shown: set[str]) -> np.ndarray:
    """The 3D view (RGB, 0-255) with only the robots in ``shown`` visible, once redrawn."""
    for name in ROBOT_HUES:
        page.set_checked(f"input[aria-label='show {name}']", name in shown)
    frames = page.evaluate("Object.values(window.linkview.framesApplied)[0]")
    page.wait_for_function(
        f"() => Object.values(window.linkview.framesApplied)[0] > {frames + 2}", timeout=TIMEOUT_MS
    )
    png = page.locator("#viewport canvas").screenshot(style=ONLY_THE_VIEW)
    return np.asarray(Image.open(io.BytesIO(png)).convert("RGB"), dtype=np.float64)


def _painted(rgb: np.ndarray, hue_deg: float) -> np.ndarray:
    """Pixels of ``hue_deg`` (+/- 15 deg), saturated and bright enough to make the colour out."""
    hsv = np.asarray(Image.fromarray(rgb.astype(np.uint8)).convert("HSV"), dtype=np.float64)
    hue, saturation, value = hsv[..., 0] * 360.0 / 255.0, hsv[..., 1] / 255.0, hsv[..., 2] / 255.0
    near = np.abs((hue - hue_deg + 180.0) % 360.0 - 180.0) <= 15.0
    return near & (saturation > 0.35) & (value > 0.35)


def test_quality_can_be_pinned_and_stays_legible(viewer: Watched) -> None:
    page = viewer.page
    page.select_option("#quality", "4")
    page.wait_for_function("() => window.linkview.quality.level === 4")
    page.wait_for_timeout(300)
    parts_drawn = page.evaluate("window.linkview.renderInfo.calls")
    page.select_option("#quality", "5")
    page.wait_for_function("() => window.linkview.quality.level === 5")
    # The lowest level draws each link as one mesh: the demo cell's 45 parts are 15 links.
    page.wait_for_function(f"() => window.linkview.renderInfo.calls <= {parts_drawn} - 25")
    settings = page.evaluate("window.linkview.quality.settings")
    assert settings == {
        "shadows": False,
        "antialias": False,
        "pixelRatio": 1,
        "environment": False,
        "simpleMaterials": True,
    }
    page.wait_for_timeout(300)
    _screenshot(page, "quality-lowest.png")
    # Legible: alone in the view, each robot stands out from the empty floor, and in its
    # own paint (simple materials keep the colour, no environment light leaves it lit).
    try:
        empty = _view(page, set())
        for name, hue in ROBOT_HUES.items():
            alone = _view(page, {name})
            stands_out = np.abs(alone - empty).max(axis=-1) > 40
            painted = _painted(alone, hue) & stands_out
            assert stands_out.sum() >= MIN_ROBOT_PIXELS, (name, int(stands_out.sum()))
            assert painted.sum() >= MIN_ROBOT_PIXELS / 3, (name, int(painted.sum()))
    finally:
        for name in ROBOT_HUES:
            page.check(f"input[aria-label='show {name}']")
    # Antialiasing is fixed per WebGL context: turning it on makes a new renderer
    # (in a smaller window: software antialiasing at 1280x800 is slow, not interesting).
    page.set_viewport_size({"width": 900, "height": 500})
    try:
        before = page.evaluate("Object.values(window.linkview.framesApplied)[0]")
        page.select_option("#quality", "1")
        page.wait_for_function("() => window.linkview.quality.settings.antialias")
        page.wait_for_function(
            f"() => Object.values(window.linkview.framesApplied)[0] > {before + 2}",
            timeout=TIMEOUT_MS,
        )
        assert page.locator("#viewport canvas").count() == 1
        page.select_option("#quality", "5")
        page.wait_for_function("() => window.linkview.quality.level === 5")
    finally:
        page.set_viewport_size({"width": 1280, "height": 800})


def test_software_webgl_starts_at_the_lowest_level(browser: Browser, server_url: str) -> None:
    """SwiftShader is a software rasteriser: 'auto' starts where it can keep up, not at 'full'."""
    page = browser.new_page(viewport={"width": 800, "height": 600})
    try:
        open_page(page, f"{server_url}/", TIMEOUT_MS)  # auto
        quality = page.evaluate("window.linkview.quality")
        assert quality["mode"] == "auto"
        assert quality["level"] == 5, quality
        assert quality["settings"]["simpleMaterials"] and not quality["settings"]["shadows"]
    finally:
        page.close()


def test_readouts_change_ten_times_a_second_not_every_frame(viewer: Watched) -> None:
    """Plots and cards are redrawn on one readout tick (10/s), so most frames repaint no DOM."""
    page = viewer.page
    page.select_option("#selected-robot", "iiwa7")
    page.wait_for_function("() => window.linkview.plots.robot === 'iiwa7'")
    counted: dict[str, float] = page.evaluate(
        """() => new Promise(done => {
          const plots = window.linkview.plots.redraws; let frames = 0;
          const start = performance.now();
          function tick() {
            frames++;
            if (performance.now() - start < 2000) requestAnimationFrame(tick);
            else done({ frames, redraws: window.linkview.plots.redraws - plots,
                        seconds: (performance.now() - start) / 1000 });
          }
          requestAnimationFrame(tick);
        })"""
    )
    # Live (redrawn at all in 2 s), and never more than the readout tick allows, however many
    # frames this machine draws (a slower one draws and redraws less: no floor on a rate).
    assert counted["redraws"] >= 1, counted
    assert counted["redraws"] <= READOUTS_PER_S * counted["seconds"] + 1, counted


def test_narrow_screen_collapses_the_panels(viewer: Watched) -> None:
    page = viewer.page
    page.set_viewport_size({"width": 760, "height": 800})
    try:
        for panel in ("#hud", "#inspector"):
            page.wait_for_function(
                f"() => document.querySelector('{panel}').classList.contains('collapsed')"
            )
            box = page.locator(panel).bounding_box()
            assert box is not None and box["height"] < 80 and box["width"] < 380, (panel, box)
        page.click("#hud .panel-toggle")
        assert "collapsed" not in (page.get_attribute("#hud", "class") or "")
        assert page.get_attribute("#hud .panel-toggle", "aria-expanded") == "true"
        _screenshot(page, "narrow.png")
    finally:
        page.set_viewport_size({"width": 1280, "height": 800})
    page.wait_for_function("() => !document.querySelector('#hud').classList.contains('collapsed')")


def test_no_console_error_and_no_request_leaving_the_server(
    browser: Browser, server_url: str
) -> None:
    # A page of its own: what the other tests did to theirs must not decide this one.
    page = browser.new_page(viewport={"width": 1280, "height": 800})
    page.set_default_navigation_timeout(TIMEOUT_MS)
    watched = watch(page)
    try:
        open_page(page, f"{server_url}/?quality=5", TIMEOUT_MS)
        page.select_option("#selected-robot", "iiwa7")  # plots and the simulation panel
        page.wait_for_function("() => window.linkview.plots.robot === 'iiwa7'")
        redraws = page.evaluate("window.linkview.plots.redraws")
        frames = page.evaluate("Object.values(window.linkview.framesApplied)[0]")
        page.wait_for_function(
            f"""() => window.linkview.plots.redraws > {redraws} + 5
              && Object.values(window.linkview.framesApplied)[0] > {frames} + 50""",
            timeout=TIMEOUT_MS,
        )
        watched.assert_clean()
    finally:
        page.close()
    origin = urlsplit(server_url)
    assert any(urlsplit(url).path.endswith(".glb") for url in watched.requests)
    assert any(urlsplit(url).scheme == "ws" for url in watched.requests)
    foreign = [
        url
        for url in watched.requests
        if urlsplit(url).scheme not in NOT_NETWORK
        and (urlsplit(url).hostname, urlsplit(url).port) != (origin.hostname, origin.port)
    ]
    assert not foreign, f"requests outside {server_url}: {foreign}"


MERGE_TWO_PARTS = """async () => {
  const THREE = await import('three');
  const { mergedLinkGeometry } = await import('/static/js/merged_links.js');
  const link = new THREE.Group();
  const box = new THREE.Mesh(new THREE.BoxGeometry(0.2, 0.1, 0.1));  // indexed
  const ball = new THREE.Mesh(new THREE.SphereGeometry(0.05, 12, 8).toNonIndexed());
  ball.position.set(0.3, 0, 0);
  link.add(box, ball);
  const parts = [[box, box.geometry, new THREE.Color(1, 0, 0)],
                 [ball, ball.geometry, new THREE.Color(0, 0, 1)]];
  const merged = mergedLinkGeometry(link, parts);
  merged.computeBoundingBox();
  const corners = box.geometry.index.count + ball.geometry.attributes.position.count;
  return { indexed: merged.index !== null, triangles: merged.index.count / 3,
           vertices: merged.attributes.position.count, corners,
           min: merged.boundingBox.min.toArray(), max: merged.boundingBox.max.toArray() };
}"""


def test_a_merged_link_shares_its_vertices_and_keeps_its_shape(viewer: Watched) -> None:
    """The lowest level's one mesh per link is indexed: a vertex is shaded once, not per corner."""
    got = viewer.page.evaluate(MERGE_TWO_PARTS)
    assert got["indexed"] and got["triangles"] * 3 == got["corners"], got
    assert got["vertices"] < got["corners"] / 2, got
    assert np.allclose(got["min"], [-0.1, -0.05, -0.05], atol=1e-6), got
    assert np.allclose(got["max"], [0.35, 0.05, 0.05], atol=1e-6), got


VERTEX_LIT_BESIDE_LAMBERT = """async () => {
  const THREE = await import('three');
  const { vertexLitMaterial } = await import('/static/js/vertex_lit.js');
  const renderer = new THREE.WebGLRenderer({ antialias: false });
  renderer.setSize(64, 32, false);
  renderer.toneMapping = THREE.NeutralToneMapping;  // as the stage's (scene.js)
  const scene = new THREE.Scene();
  scene.add(new THREE.HemisphereLight(0xf4f6ff, 0x8a8f99, 1.5));
  const sun = new THREE.DirectionalLight(0xffffff, 1.9);
  sun.position.set(2.5, -1.5, 4.0);
  scene.add(sun);
  const camera = new THREE.OrthographicCamera(-2, 2, 1, -1, 0.1, 10);
  camera.position.set(0, 0, 5);
  // A flat square (one normal): lit at its corners or at each pixel, the same colour.
  const square = (x, material) => {
    const geometry = new THREE.PlaneGeometry(1.6, 1.6);
    const colour = new THREE.Color(0xf07a1a);  // a robot's orange, linear as vertex colours are
    geometry.setAttribute('color', new THREE.BufferAttribute(
      new Float32Array(Array(4).fill([colour.r, colour.g, colour.b]).flat()), 3));
    const mesh = new THREE.Mesh(geometry, material);
    mesh.position.x = x;
    mesh.rotation.x = -0.5;  // turned to the sun a little
    scene.add(mesh);
  };
  square(-1, vertexLitMaterial());
  square(1, new THREE.MeshLambertMaterial({ vertexColors: true }));
  renderer.render(scene, camera);
  const gl = renderer.getContext();
  const pixel = (x) => {
    const p = new Uint8Array(4);
    gl.readPixels(x, 16, 1, 1, gl.RGBA, gl.UNSIGNED_BYTE, p);
    return [...p.slice(0, 3)];
  };
  const result = { vertexLit: pixel(16), lambert: pixel(48) };
  renderer.dispose();
  return result;
}"""


def test_vertex_lit_links_match_three_lambert_colours(viewer: Watched) -> None:
    """The lowest level lights, tone maps and encodes sRGB per vertex; the colour stays three's."""
    got = viewer.page.evaluate(VERTEX_LIT_BESIDE_LAMBERT)
    assert max(got["lambert"]) > 60, got  # lit, not black
    assert np.abs(np.subtract(got["vertexLit"], got["lambert"])).max() <= 3, got


VIEW_BOXES = """() => {
  const box = (s) => { const r = document.querySelector(s).getBoundingClientRect();
                       return { left: r.left, right: r.right, top: r.top, bottom: r.bottom }; };
  return { canvas: box('#viewport canvas'), bar: box('#timeline'), hud: box('#hud'),
           inspector: box('#inspector'), height: innerHeight };
}"""


def _assert_orientation_drawn(page: Page) -> None:
    """The world axes' letters and the grid's label are drawn where the page says they are."""
    labels = page.evaluate("window.linkview.orientation")
    assert [label["text"] for label in labels] == ["X", "Y", "Z", "grid 250 mm"], labels
    assert all(label["inView"] for label in labels), labels
    # Each label's own colour around its place on screen (the letters in the axes' red,
    # green and blue; the grid's spacing in dark grey on the light floor).
    shot = Image.open(io.BytesIO(page.screenshot())).convert("RGB")
    colours = {
        "X": (224, 65, 47),
        "Y": (47, 158, 68),
        "Z": (47, 111, 214),
        "grid 250 mm": (74, 82, 96),
    }
    for label in labels:
        x, y = round(label["x"]), round(label["y"])
        box = np.asarray(shot.crop((x - 20, y - 14, x + 20, y + 14)), dtype=np.float64)
        near = np.abs(box - colours[label["text"]]).max(axis=-1) < 40
        assert near.sum() >= 15, (label, int(near.sum()))


def test_the_canvas_spans_only_what_the_panels_and_the_bar_leave_free(viewer: Watched) -> None:
    """Software WebGL draws every canvas pixel each frame: none hidden under a panel or the bar."""
    page = viewer.page
    at = page.evaluate(VIEW_BOXES)
    canvas, bar = at["canvas"], at["bar"]
    assert canvas["left"] >= at["hud"]["right"] and canvas["right"] <= at["inspector"]["left"], at
    # At 1280 px the centred bar spans the part between the panels: the canvas ends above it.
    assert bar["left"] <= canvas["left"] and bar["right"] >= canvas["right"], at
    assert abs(canvas["bottom"] - bar["top"]) <= 1, at
    page.keyboard.press("Home")
    page.wait_for_timeout(500)  # the camera's damping settles
    _assert_orientation_drawn(page)
    # Wider, the bar leaves the view's lower corners free: the canvas goes down to the bottom,
    # and what is drawn on it still lies where the page computes it.
    page.set_viewport_size({"width": 1700, "height": 800})
    try:
        page.wait_for_function(
            "() => document.querySelector('#viewport canvas').getBoundingClientRect().bottom"
            " === innerHeight"
        )
        page.keyboard.press("Home")
        page.wait_for_timeout(500)
        _assert_orientation_drawn(page)
    finally:
        page.set_viewport_size({"width": 1280, "height": 800})
    page.wait_for_function(
        """() => Math.abs(document.querySelector('#viewport canvas').getBoundingClientRect().bottom
                 - document.querySelector('#timeline').getBoundingClientRect().top) <= 1"""
    )
