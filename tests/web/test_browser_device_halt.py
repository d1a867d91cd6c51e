"""A controller that holds its robots still (a UR's protective or emergency stop, over RTDE):
each of its robots' cards and the banner say so, until it lets go; robots of other
controllers are not marked."""

from __future__ import annotations

import asyncio
import threading
from collections.abc import Iterator
from contextlib import contextmanager
from pathlib import Path

from playwright.sync_api import Browser, Page

from server.mock_ctrlx import Machine
from server.mock_rtde import RtdeMock, demo_groups
from tests.conftest import free_port
from tests.e2e.test_rtde_mqtt_cells import UR5E_DH
from tests.web._browser import open_page, server_process, watch

TIMEOUT_MS = 30_000


class MockThread:
    """The RTDE mock on its own event loop in a thread (the test's browser calls block)."""

    def __init__(self) -> None:
        self.loop = asyncio.new_event_loop()
        self.mock = RtdeMock(Machine(demo_groups()))
        self.thread = threading.Thread(target=self.loop.run_forever, daemon=True)

    def call(self, method: str, *args: object) -> None:
        """``mock.method(*args)`` on the mock's loop, waited for."""

        async def run() -> None:
            getattr(self.mock, method)(*args)

        asyncio.run_coroutine_threadsafe(run(), self.loop).result(10)


@contextmanager
def rtde_mock() -> Iterator[MockThread]:
    mock = MockThread()
    mock.thread.start()
    asyncio.run_coroutine_threadsafe(mock.mock.start("127.0.0.1", free_port()), mock.loop).result(
        10
    )
    try:
        yield mock
    finally:
        asyncio.run_coroutine_threadsafe(mock.mock.close(), mock.loop).result(10)
        mock.loop.call_soon_threadsafe(mock.loop.stop)
        mock.thread.join(10)
        mock.loop.close()


def cell(folder: Path, url: str) -> Path:
    """The UR5e on the RTDE mock, and a Type 12 on the embedded ctrlX mock beside it."""
    path = folder / "cell.toml"
    path.write_text(
        f'[[source]]\nname = "ur"\ntype = "rtde"\nurl = "{url}"\n\n'
        '[[source]]\nname = "ctrlx"\n\n'
        f'[[robot]]\nname = "ur5e"\nsource = "ur"\n{UR5E_DH}\n\n'
        '[[robot]]\nname = "kin12"\nsource = "ctrlx"\n'
        'kinematics = { type = "type12", limits = [[-40.0, 40.0], [-40.0, 40.0]] }\n'
        'joints = [{ node = "motion/axs/Axis_1/state/values/actual/pos", unit = "deg" },'
        ' { node = "motion/axs/Axis_2/state/values/actual/pos", unit = "deg" }]\n'
    )
    return path


def halted(page: Page) -> dict[str, str | None]:
    """Each card's halt line (by robot), None where it is hidden."""
    found: dict[str, str | None] = page.evaluate(
        "() => Object.fromEntries([...document.querySelectorAll('.robot-halted')].map("
        "(el) => [el.closest('.robot').dataset.robot, el.hidden ? null : el.textContent]))"
    )
    return found


def test_a_protective_stop_shows_on_its_robots_cards_until_released(
    browser: Browser, tmp_path: Path
) -> None:
    page = browser.new_page(viewport={"width": 1280, "height": 800})
    watched = watch(page)
    with (
        rtde_mock() as ur,
        server_process(
            free_port(), tmp_path / "server.log", "--cell", str(cell(tmp_path, ur.mock.url))
        ) as url,
    ):
        open_page(page, f"{url}/?quality=5", TIMEOUT_MS)
        assert halted(page) == {"ur5e": None, "kin12": None}

        ur.call("protective_stop")
        page.wait_for_function(
            "() => !document.querySelector('[data-robot=\"ur5e\"] .robot-halted').hidden",
            timeout=TIMEOUT_MS,
        )
        assert halted(page) == {"ur5e": "held by its controller: protective stop", "kin12": None}
        page.wait_for_function(
            "() => document.getElementById('banner').textContent"
            ".includes('Controller ur holds its robots: protective stop')",
            timeout=TIMEOUT_MS,
        )
        page.screenshot(path=str(tmp_path / "protective_stop.png"))

        ur.call("protective_stop", False)
        page.wait_for_function(
            "() => [...document.querySelectorAll('.robot-halted')].every((el) => el.hidden)"
            " && document.getElementById('banner').hidden",
            timeout=TIMEOUT_MS,
        )
        ur.call("emergency_stop")
        page.wait_for_function(
            "() => document.querySelector('[data-robot=\"ur5e\"] .robot-halted').textContent"
            ".endsWith('robot emergency stop')",
            timeout=TIMEOUT_MS,
        )
    watched.assert_clean(expected="WebSocket connection to")
    page.close()
