"""A published robot with more than 60 movable joints: it loads, streams every sample, and its
page lists, filters and plots all of its joints.

PAL Robotics' TIAGo++ (``tests/urdf/corpus.py``, from example-robot-data): a
dual-arm mobile manipulator of 101 movable joints and 130 links, on an
embedded mock publishing at 50 Hz.
"""

from __future__ import annotations

import json
import time
import urllib.error
import urllib.request
from pathlib import Path

from playwright.sync_api import Browser

from server.cell import load_cell
from server.urdf import load_urdf
from tests.conftest import free_port
from tests.urdf.corpus import CORPUS
from tests.web._browser import open_page, server_process, watch
from tests.web.test_browser_corpus import robot_entry

TIMEOUT_MS = 180_000  # software rendering on shared cores: loading is slow
NAME = "tiago_dual"


def health(url: str) -> dict[str, object]:
    """/api/health once it says ok (503 while the source is not live yet)."""
    deadline = time.monotonic() + 120
    while True:
        try:
            with urllib.request.urlopen(f"{url}/api/health", timeout=10) as response:
                body: dict[str, object] = json.load(response)
                return body
        except urllib.error.HTTPError:
            assert time.monotonic() < deadline, "never healthy"
            time.sleep(0.5)


def counts(body: dict[str, object]) -> tuple[int, int]:
    """Samples the source received, and frames the robot got from them."""
    (source,) = body["sources"]  # type: ignore[misc]
    frames = source["robots"][NAME]["frames"]
    return int(body["samples"]["received"]), int(frames)  # type: ignore[index]


def test_a_robot_of_101_joints_streams_and_its_page_shows_and_plots_them(
    browser: Browser, tmp_path: Path
) -> None:
    robot = next(r for r in CORPUS if r.name == NAME)
    names = load_urdf(robot.path).joint_names
    assert len(names) > 60
    cell = tmp_path / "cell.toml"
    cell.write_text('[[source]]\nname = "mock"\n\n' + robot_entry(NAME, robot.path, 0.0))
    cache = tmp_path / "cache"
    load_cell(cell, env={}, cache_dir=cache)  # converts the meshes before the clock runs
    env = {"LINKVIEW_CACHE_DIR": str(cache)}
    with server_process(free_port(), tmp_path / "server.log", "--cell", str(cell), env=env) as url:
        # Every sample of the source becomes a frame of the robot (the mock sends 50 a second).
        before = counts(health(url))
        time.sleep(3)
        after = counts(health(url))
        samples, frames = after[0] - before[0], after[1] - before[1]
        assert samples > 0 and frames >= 0.95 * samples, (samples, frames)

        page = browser.new_page(viewport={"width": 1280, "height": 900})
        watched = watch(page)
        open_page(page, f"{url}/?quality=4", TIMEOUT_MS)
        card = page.locator(f"article.robot[data-robot='{NAME}']")
        folded = card.locator("details.joint-list")
        assert folded.locator("summary").inner_text() == f"{len(names)} joints"
        assert not card.locator(".joint").first.is_visible()  # folded until asked for
        folded.locator("summary").click()
        assert card.locator(".joint").count() == len(names)
        assert card.locator(".joint .name").all_inner_texts() == list(names)
        page.wait_for_function(
            "n => [...document.querySelectorAll(`article.robot[data-robot='${n}'] .joint .value`)]"
            ".every(v => v.textContent !== '—')",
            arg=NAME,
            timeout=TIMEOUT_MS,
        )
        card.get_by_label(f"filter the joints of {NAME}").fill("arm_left")
        wanted = [n for n in names if "arm_left" in n.lower()]
        assert 0 < len(wanted) < len(names)
        assert card.locator(".joint:visible .name").all_inner_texts() == wanted

        page.select_option("#selected-robot", NAME)
        page.wait_for_function(f"() => window.linkview.plots.robot === '{NAME}'")
        assert page.locator("#plots canvas").count() == len(names)
        titles = page.locator("#plots .plot-title").all_inner_texts()
        assert [t.rsplit(" (", 1)[0] for t in titles] == list(names)
        page.wait_for_function(
            f"() => window.linkview.plots.layout.length === {len(names)}"
            " && window.linkview.plots.layout.every(p => Number.isFinite(p.data[0]))",
            timeout=TIMEOUT_MS,
        )
        page.get_by_label("plot only the joints whose names hold this").fill("arm_left")
        titles = page.locator("#plots .plot-title").all_inner_texts()
        assert [t.rsplit(" (", 1)[0] for t in titles] == wanted
        watched.assert_clean()
        page.close()
