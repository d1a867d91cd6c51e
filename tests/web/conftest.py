"""The browser the page tests share: one Chromium per test module."""

from __future__ import annotations

from collections.abc import Iterator
from pathlib import Path

import pytest
from playwright.sync_api import Browser

from tests.web import _browser
from tests.web._browser import chromium


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
