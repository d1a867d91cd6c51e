"""A self-signed certificate for the mock, like the one a ctrlX CORE ships with.

A device keeps its certificate across restarts, and clients trust exactly that
certificate (``--ctrlx-ca``); so does the mock when it is given a folder to keep
it in (``certificate_in``).
"""

from __future__ import annotations

import datetime as dt
import ipaddress
import ssl
from dataclasses import dataclass
from pathlib import Path

from cryptography import x509
from cryptography.hazmat.primitives import hashes, serialization
from cryptography.hazmat.primitives.asymmetric import ec
from cryptography.x509.oid import ExtendedKeyUsageOID, NameOID

CERT_NAME = "mock-ctrlx-cert.pem"
KEY_NAME = "mock-ctrlx-key.pem"
VALID_DAYS = 365
RENEW_WITHIN = dt.timedelta(days=1)
"""A kept certificate this close to its end is replaced rather than reused."""


@dataclass(frozen=True)
class MockCertificate:
    """Where the certificate and key were written; ``ca_file`` is what clients should trust."""

    cert_file: Path
    key_file: Path

    @property
    def ca_file(self) -> Path:
        """The certificate itself: it is self-signed, so it is its own CA."""
        return self.cert_file

    def server_context(self) -> ssl.SSLContext:
        """A server-side TLS context presenting this certificate."""
        context = ssl.create_default_context(ssl.Purpose.CLIENT_AUTH)
        context.load_cert_chain(self.cert_file, self.key_file)
        return context


def make_certificate(directory: Path, hosts: tuple[str, ...] = ("localhost",)) -> MockCertificate:
    """Write a new self-signed certificate for ``hosts``, 127.0.0.1 and ::1 into ``directory``.

    It is valid for a year and marked as a CA, so a client can use the very
    same file as its trust anchor (``--ctrlx-ca``).
    """
    key = ec.generate_private_key(ec.SECP256R1())
    name = x509.Name([x509.NameAttribute(NameOID.COMMON_NAME, "linkview mock ctrlX CORE")])
    now = dt.datetime.now(dt.UTC)
    san = [x509.DNSName(h) for h in hosts] + [
        x509.IPAddress(ipaddress.ip_address("127.0.0.1")),
        x509.IPAddress(ipaddress.ip_address("::1")),
    ]
    public = key.public_key()
    cert = (
        x509.CertificateBuilder()
        .subject_name(name)
        .issuer_name(name)
        .public_key(public)
        .serial_number(x509.random_serial_number())
        .not_valid_before(now - dt.timedelta(minutes=5))
        .not_valid_after(now + dt.timedelta(days=VALID_DAYS))
        .add_extension(x509.SubjectAlternativeName(san), critical=False)
        .add_extension(x509.BasicConstraints(ca=True, path_length=None), critical=True)
        .add_extension(
            x509.KeyUsage(
                digital_signature=True,
                content_commitment=False,
                key_encipherment=False,
                data_encipherment=False,
                key_agreement=False,
                key_cert_sign=True,
                crl_sign=False,
                encipher_only=False,
                decipher_only=False,
            ),
            critical=True,
        )
        .add_extension(x509.ExtendedKeyUsage([ExtendedKeyUsageOID.SERVER_AUTH]), critical=False)
        .add_extension(x509.SubjectKeyIdentifier.from_public_key(public), critical=False)
        .add_extension(x509.AuthorityKeyIdentifier.from_issuer_public_key(public), critical=False)
        .sign(key, hashes.SHA256())
    )
    directory.mkdir(parents=True, exist_ok=True)
    cert_file, key_file = directory / CERT_NAME, directory / KEY_NAME
    cert_file.write_bytes(cert.public_bytes(serialization.Encoding.PEM))
    key_file.write_bytes(
        key.private_bytes(
            serialization.Encoding.PEM,
            serialization.PrivateFormat.PKCS8,
            serialization.NoEncryption(),
        )
    )
    key_file.chmod(0o600)
    return MockCertificate(cert_file, key_file)


def certificate_in(
    directory: Path, hosts: tuple[str, ...] = ("localhost",)
) -> tuple[MockCertificate, bool]:
    """The certificate kept in ``directory``, made there first if needed; True if it is new.

    A kept certificate is reused while its key matches, it covers ``hosts`` and
    it is valid for at least another day, so clients that trust it keep working
    across restarts of the mock.
    """
    kept = MockCertificate(directory / CERT_NAME, directory / KEY_NAME)
    if _usable(kept, hosts):
        return kept, False
    return make_certificate(directory, hosts), True


def _usable(kept: MockCertificate, hosts: tuple[str, ...]) -> bool:
    try:
        cert = x509.load_pem_x509_certificate(kept.cert_file.read_bytes())
        key = serialization.load_pem_private_key(kept.key_file.read_bytes(), password=None)
        names = cert.extensions.get_extension_for_class(x509.SubjectAlternativeName).value
    except (OSError, ValueError, TypeError, x509.ExtensionNotFound):
        return False  # missing, unreadable or not ours: make a new one
    same_key = key.public_key().public_bytes(
        serialization.Encoding.DER, serialization.PublicFormat.SubjectPublicKeyInfo
    ) == cert.public_key().public_bytes(
        serialization.Encoding.DER, serialization.PublicFormat.SubjectPublicKeyInfo
    )
    covered = set(hosts) <= set(names.get_values_for_type(x509.DNSName))
    fresh = cert.not_valid_after_utc - dt.datetime.now(dt.UTC) > RENEW_WITHIN
    return same_key and covered and fresh
