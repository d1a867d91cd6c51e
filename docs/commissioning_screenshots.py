"""Photograph each step of docs/commissioning.md: a discovered cell brought up on the page.

Runs the standalone mock, ``discover``, and the server with ``--allow-edits``
in a temporary folder, then drives Debian's Chromium through the steps of
``tests/web/_bring_up.py`` (the same steps ``tests/web/test_browser_bring_up.py``
checks) and saves one PNG per step into ``docs/commissioning/``.

    python docs/commissioning_screenshots.py [--out DIR]
"""

from __future__ import annotations

import argparse
import sys
import tempfile
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))

from tests.conftest import free_port  # noqa: E402
from tests.web._bring_up import ENV, bring_up, discover  # noqa: E402
from tests.web._browser import chromium, mock_process, open_page, server_process  # noqa: E402

TIMEOUT_MS = 180_000
SHOWN = {
    "describe": ".commission .describe",
    "place": ".commission .place",
    "calibrate": ".commission .calibrate .fit-result",
    "check": 'article.robot[data-robot="pos"] details.mapping',
    "saved": ".commission .cell-edits",
}
"""What of the panels each step is about: scrolled into sight."""


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--out", type=Path, default=ROOT / "docs" / "commissioning")
    args = parser.parse_args()
    args.out.mkdir(parents=True, exist_ok=True)
    with tempfile.TemporaryDirectory(prefix="linkview-commissioning-") as tmp:
        folder = Path(tmp) / "cell"
        folder.mkdir()
        cell = folder / "cell.toml"
        # 20 samples a second are plenty to show: a shared machine then keeps up.
        env = {**ENV, "LINKVIEW_POLL_INTERVAL_S": "0.05"}
        env["LINKVIEW_CACHE_DIR"] = str(Path(tmp) / "cache")
        log = Path(tmp) / "server.log"
        with (
            mock_process(free_port(), Path(tmp) / "mock.log", "--hold-s", "3600") as mock_url,
            chromium() as browser,
        ):
            discover(mock_url, cell)
            flags = ("--cell", str(cell), "--allow-edits", "--allow-commands")
            with server_process(free_port(), log, *flags, env=env) as url:
                page = browser.new_page(viewport={"width": 1400, "height": 900})
                page.set_default_timeout(TIMEOUT_MS)
                open_page(page, f"{url}/?quality=2", TIMEOUT_MS)

                def shoot(name: str) -> None:
                    page.click("#fit-all")
                    shown = SHOWN.get(name.split("-")[0])
                    if shown is not None:
                        page.locator(shown).first.scroll_into_view_if_needed()
                    page.wait_for_timeout(1000)  # the camera there, a few frames drawn
                    page.screenshot(path=str(args.out / f"{name}.png"))
                    print(f"{args.out / name}.png")

                bring_up(page, url, shoot)


if __name__ == "__main__":
    main()
