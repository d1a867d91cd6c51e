"""The browser the page tests share: one Chromium per test module."""

from __future__ import annotations

from collections.abc import Iterator

import pytest
from playwright.sync_api import Browser, sync_playwright

from tests.web._browser import CHROMIUM, CHROMIUM_ARGS, chromium


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
