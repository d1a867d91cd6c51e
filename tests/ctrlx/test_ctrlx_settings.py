"""The client's settings reach Settings from flags and LINKVIEW_* variables."""

from __future__ import annotations

from pathlib import Path

import pytest

from server.__main__ import parse_settings


def test_flags() -> None:
    settings = parse_settings(
        ["--mode", "poll", "--api", "v1", "--ctrlx-ca", "dev.pem", "--insecure"]
    )
    assert settings.ctrlx_mode == "poll" and settings.ctrlx_api == "v1"
    assert settings.ctrlx_ca == Path("dev.pem") and settings.insecure is True


def test_defaults_and_environment(monkeypatch: pytest.MonkeyPatch) -> None:
    defaults = parse_settings([])
    assert defaults.ctrlx_mode == "subscribe" and defaults.ctrlx_api == "v2"
    assert defaults.insecure is False and defaults.ctrlx_ca is None
    monkeypatch.setenv("LINKVIEW_CTRLX_MODE", "get")
    monkeypatch.setenv("LINKVIEW_CTRLX_API", "v1")
    monkeypatch.setenv("LINKVIEW_CTRLX_CA", "/tmp/ca.pem")
    monkeypatch.setenv("LINKVIEW_INSECURE", "true")
    settings = parse_settings([])
    assert settings.ctrlx_mode == "get" and settings.ctrlx_api == "v1"
    assert settings.ctrlx_ca == Path("/tmp/ca.pem") and settings.insecure is True
    assert "boschrexroth" not in repr(settings.ctrlx_password)
