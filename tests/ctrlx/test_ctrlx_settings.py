"""The client's settings reach Settings from flags and LINKVIEW_* variables."""

from __future__ import annotations

from pathlib import Path

import pytest

from server.__main__ import parse_settings
from server.mock_ctrlx import make_certificate
from tests.test_cli import run_server


def test_flags(tmp_path: Path) -> None:
    ca = make_certificate(tmp_path).ca_file  # the CA file must exist and hold PEM
    settings = parse_settings(
        ["--mode", "poll", "--api", "v1", "--ctrlx-ca", str(ca), "--insecure"]
    )
    assert settings.ctrlx_mode == "poll" and settings.ctrlx_api == "v1"
    assert settings.ctrlx_ca == ca and settings.insecure is True


def test_defaults_and_environment(monkeypatch: pytest.MonkeyPatch, tmp_path: Path) -> None:
    ca = make_certificate(tmp_path).ca_file
    defaults = parse_settings([])
    assert defaults.ctrlx_mode == "subscribe" and defaults.ctrlx_api == "v2"
    assert defaults.insecure is False and defaults.ctrlx_ca is None
    monkeypatch.setenv("LINKVIEW_CTRLX_MODE", "get")
    monkeypatch.setenv("LINKVIEW_CTRLX_API", "v1")
    monkeypatch.setenv("LINKVIEW_CTRLX_CA", str(ca))
    monkeypatch.setenv("LINKVIEW_INSECURE", "true")
    settings = parse_settings([])
    assert settings.ctrlx_mode == "get" and settings.ctrlx_api == "v1"
    assert settings.ctrlx_ca == ca and settings.insecure is True
    assert "boschrexroth" not in repr(settings.ctrlx_password)


def test_an_empty_ca_file_is_refused_like_one_without_a_certificate(tmp_path: Path) -> None:
    empty = tmp_path / "device.pem"
    empty.write_bytes(b"")
    result = run_server("--ctrlx-ca", str(empty))
    assert result.returncode == 2 and "Traceback" not in result.stderr
    assert f"CA file {empty} is empty" in result.stderr
