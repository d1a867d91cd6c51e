"""The browser the page tests share: one Chromium per test module."""

from __future__ import annotations

from collections.abc import Iterator
from pathlib import Path

import pytest
from playwright.sync_api import Browser, sync_playwright

from tests.web import _browser
from tests.web._browser import CHROMIUM, CHROMIUM_ARGS, chromium


@pytest.fixture(scope="session", autouse=True)
def screenshots(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """The folder the page tests' screenshots go to (pytest's temporary ones)."""
    folder = tmp_path_factory.mktemp("screenshots")
    _browser.SCREENSHOTS = folder
    return folder


@pytest.fixture(scope="module")
def browser() -> Iterator[Browser]:
    """Debian's Chromium, headless, with software WebGL."""
    with chromium() as launched:
        yield launched


@pytest.fixture(scope="module")
def no_webgl_browser() -> Iterator[Browser]:
    """Debian's Chromium with WebGL switched off, as a policy or a remote desktop does."""
    with sync_playwright() as pw:
        browser = pw.chromium.launch(
            executable_path=str(CHROMIUM),
            headless=True,
            args=[*CHROMIUM_ARGS, "--disable-webgl", "--disable-3d-apis"],
        )
        try:
            yield browser
        finally:
            browser.close()
