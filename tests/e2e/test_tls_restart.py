"""A TLS controller that restarts: the mock as its own process, linkview trusting its CA file.

A device keeps its certificate across restarts, so the stream must come back by
itself. A device with a new certificate must be named (subject, fingerprint),
and putting that certificate in the CA file must be enough: no restart.
"""

from __future__ import annotations

import shutil
import subprocess
import sys
from collections.abc import AsyncIterator, Iterator
from contextlib import asynccontextmanager, contextmanager
from pathlib import Path

from cryptography import x509
from cryptography.hazmat.primitives import hashes

from server.config import Settings
from server.mock_ctrlx.tls import CERT_NAME
from server.runtime import Runtime
from server.runtime.startup import configured_cell, source_defaults
from server.stream import SourceHealth
from tests.conftest import free_port, wait_until

ROOT = Path(__file__).resolve().parents[2]
BOUND_S = 20.0
"""Generous bound on each state change (the acquisition retries within 1.5 s)."""


class Device:
    """``python -m server.mock_ctrlx --tls --tls-dir DIR`` on one port, started and stopped."""

    def __init__(self, port: int) -> None:
        self.port = port
        self._proc: subprocess.Popen[str] | None = None

    def start(self, tls_dir: Path) -> str:
        """Start it with its certificate in ``tls_dir``; returns the line it prints once up."""
        command = [sys.executable, "-m", "server.mock_ctrlx", "--port", str(self.port)]
        self._proc = subprocess.Popen(
            [*command, "--tls", "--tls-dir", str(tls_dir)],
            cwd=ROOT,
            stdout=subprocess.PIPE,
            stderr=subprocess.DEVNULL,
            text=True,
        )
        assert self._proc.stdout is not None
        line = self._proc.stdout.readline()
        assert "mock ctrlX data layer at https://" in line, line
        return line

    def stop(self) -> None:
        if self._proc is not None:
            self._proc.terminate()
            self._proc.wait(10)
            if self._proc.stdout is not None:
                self._proc.stdout.close()
            self._proc = None


@contextmanager
def device() -> Iterator[Device]:
    """A device on a free port, stopped at the end whatever happens."""
    dev = Device(free_port())
    try:
        yield dev
    finally:
        dev.stop()


@asynccontextmanager
async def following(port: int, ca_file: Path) -> AsyncIterator[SourceHealth]:
    """linkview's runtime following the mock on ``port``, trusting only ``ca_file``."""
    settings = Settings(
        ctrlx_url=f"https://127.0.0.1:{port}", ctrlx_ca=ca_file, keepalive_s=0.2,
        request_timeout_s=1.0,
    )  # fmt: skip
    runtime = await Runtime.start(configured_cell(settings), source_defaults(settings))
    try:
        yield runtime.healths()[0]
    finally:
        await runtime.stop()


def fingerprint(pem_file: Path) -> str:
    """SHA-256 of the certificate as browsers and ``openssl x509 -fingerprint`` show it."""
    cert = x509.load_pem_x509_certificate(pem_file.read_bytes())
    return cert.fingerprint(hashes.SHA256()).hex(":").upper()


async def test_an_outage_of_a_tls_controller_restarted_with_its_certificate(
    tmp_path: Path,
) -> None:
    tls_dir, trusted = tmp_path / "device", tmp_path / "trusted.pem"
    with device() as dev:
        assert "a new certificate" in dev.start(tls_dir)
        shutil.copy(tls_dir / CERT_NAME, trusted)
        async with following(dev.port, trusted) as health:
            await wait_until(lambda: health.state == "connected", BOUND_S)
            dev.stop()
            await wait_until(lambda: health.state == "error", BOUND_S)
            assert "cannot reach" in (health.error or "")
            # Restarted, it finds its certificate and keeps it, as a ctrlX CORE does.
            assert "the certificate kept" in dev.start(tls_dir)
            await wait_until(lambda: health.state == "connected", BOUND_S)
    assert (tls_dir / CERT_NAME).read_bytes() == trusted.read_bytes()


async def test_a_new_device_certificate_is_named_and_picked_up_from_the_ca_file(
    tmp_path: Path,
) -> None:
    trusted = tmp_path / "trusted.pem"
    with device() as dev:
        dev.start(tmp_path / "old")
        shutil.copy(tmp_path / "old" / CERT_NAME, trusted)
        async with following(dev.port, trusted) as health:
            await wait_until(lambda: health.state == "connected", BOUND_S)
            dev.stop()
            dev.start(tmp_path / "new")  # reinstalled: a certificate of its own
            new = tmp_path / "new" / CERT_NAME
            await wait_until(lambda: "TLS certificate" in (health.error or ""), BOUND_S)
            error = health.error or ""
            assert f"no longer matches the CA file {trusted}" in error
            assert "CN=linkview mock ctrlX CORE" in error and fingerprint(new) in error
            assert fingerprint(trusted) not in error
            shutil.copy(new, trusted)  # the operator trusts the new certificate: no restart
            await wait_until(lambda: health.state == "connected", BOUND_S)
