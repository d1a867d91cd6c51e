"""TLS for talking to a device: verified by default, its own certificate trusted on request."""

from __future__ import annotations

import asyncio
import logging
import ssl
from dataclasses import dataclass
from pathlib import Path

from cryptography import x509
from cryptography.hazmat.primitives import hashes
from yarl import URL

log = logging.getLogger(__name__)


def client_ssl(ca_file: str | Path | None = None, insecure: bool = False) -> ssl.SSLContext | bool:
    """What to pass as aiohttp's ``ssl=``.

    * default: verify against the system's CAs (``True``);
    * ``ca_file``: trust exactly the certificates in that PEM file, e.g. the
      self-signed certificate a ctrlX CORE ships with; a file that is missing,
      unreadable, empty or holds no certificate raises ValueError with one
      clear line;
    * ``insecure``: no verification at all, logged as a warning because
      anyone on the network path can then read the password.
    """
    if insecure:
        log.warning(
            "TLS certificate verification is OFF (--insecure): the controller's identity is "
            "not checked; prefer --ctrlx-ca FILE with the device's certificate"
        )
        return False
    if ca_file is None:
        return True
    return ca_context(Path(ca_file))


def ca_context(path: Path) -> ssl.SSLContext:
    """A client context trusting exactly the certificates in the PEM file ``path``.

    Raises ValueError (one line) for a file that cannot serve: an empty one
    must not fall back to the system's CAs, as ``cadata=""`` would.
    """
    if not path.exists():
        raise ValueError(f"CA file {path} does not exist")
    if not path.is_file():
        raise ValueError(f"CA file {path} is not a file")
    try:
        pem = path.read_text(encoding="ascii")
    except (OSError, UnicodeDecodeError) as exc:
        reason = exc.strerror if isinstance(exc, OSError) and exc.strerror else "not a PEM file"
        raise ValueError(f"CA file {path} cannot be read: {reason.lower()}") from None
    if not pem.strip():
        raise ValueError(f"CA file {path} is empty: it holds no PEM certificate")
    try:
        context = ssl.create_default_context(cadata=pem)
    except ssl.SSLError:
        raise ValueError(f"CA file {path} holds no PEM certificate") from None
    if not context.get_ca_certs():
        raise ValueError(f"CA file {path} holds no PEM certificate")
    return context


@dataclass(frozen=True)
class PeerCertificate:
    """Who a device says it is: what people compare with the certificate they hold."""

    subject: str
    """RFC 4514, e.g. ``CN=ctrlX CORE``."""
    sha256: str
    """Fingerprint of the DER certificate, colon-separated hex (as browsers show it)."""

    def __str__(self) -> str:
        return f"{self.subject} (SHA-256 {self.sha256})"


def describe_certificate(der: bytes) -> PeerCertificate:
    """Subject and fingerprint of a DER certificate."""
    cert = x509.load_der_x509_certificate(der)
    digest = cert.fingerprint(hashes.SHA256()).hex(":").upper()
    return PeerCertificate(cert.subject.rfc4514_string() or "(no subject)", digest)


async def peer_certificate(base_url: str, timeout_s: float) -> PeerCertificate | None:
    """The certificate the device at ``base_url`` presents, fetched WITHOUT verifying it.

    Only for naming it in an error after verification failed; nothing is sent
    over this connection. None if it cannot be fetched.
    """
    url = URL(base_url)
    if url.host is None:
        return None
    unverified = ssl.create_default_context()
    unverified.check_hostname = False
    unverified.verify_mode = ssl.CERT_NONE
    try:
        async with asyncio.timeout(timeout_s):
            _, writer = await asyncio.open_connection(
                url.host, url.port or 443, ssl=unverified, server_hostname=url.host
            )
    except (OSError, TimeoutError, ssl.SSLError):
        return None
    try:
        tls = writer.get_extra_info("ssl_object")
        der = tls.getpeercert(binary_form=True) if tls is not None else None
        return describe_certificate(der) if der else None
    except ValueError:
        return None
    finally:
        writer.close()
        try:
            async with asyncio.timeout(timeout_s):
                await writer.wait_closed()
        except (OSError, TimeoutError, ssl.SSLError):
            pass  # we only wanted its certificate
