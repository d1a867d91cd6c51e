"""Certificates of an OPC UA source: linkview's own (kept beside the cell) and the server's.

A signed or encrypted session (``Basic256Sha256``, ``Sign`` or ``SignAndEncrypt``)
needs an application instance certificate on each side. linkview makes its own
once (asyncua's self-signed helper: RSA 2048, a year, the application URI
``CLIENT_URI`` and this host's name) and keeps it, with its key (mode 0600),
where the cell says; the server's administrator trusts that certificate once.

The server's certificate is trusted only from a file the cell names
(``server_certificate``): one that is not in it is refused with its thumbprint,
and saved beside linkview's own so that trusting it is one line in the cell.
"""

from __future__ import annotations

import hashlib
import os
import socket
from dataclasses import dataclass
from pathlib import Path

from asyncua.crypto import cert_gen
from cryptography import x509
from cryptography.hazmat.primitives.serialization import Encoding
from cryptography.x509.oid import ExtendedKeyUsageOID, NameOID

CLIENT_URI = "urn:linkview:opcua-client"
"""linkview's application URI, in its certificate and in every session it creates."""
CLIENT_CERTIFICATE = "linkview-opcua-client.der"
"""linkview's certificate's default file name, beside the cell; its key beside it (``key_file``)."""


@dataclass(frozen=True)
class ClientIdentity:
    """linkview's certificate and private key files (created when missing or expired)."""

    certificate: Path
    key: Path


def key_file(certificate: Path) -> Path:
    """Where the private key of ``certificate`` is kept: ``<name>.key.pem`` beside it."""
    return certificate.with_name(certificate.stem + ".key.pem")


async def client_identity(certificate: Path) -> ClientIdentity:
    """linkview's certificate at ``certificate``, made once (and again when expired).

    Raises OSError when the folder cannot be written.
    """
    key = key_file(certificate)
    certificate.parent.mkdir(parents=True, exist_ok=True)
    had_key = key.is_file()
    await cert_gen.setup_self_signed_certificate(
        key,
        certificate,
        CLIENT_URI,
        socket.gethostname(),
        [ExtendedKeyUsageOID.CLIENT_AUTH],
        {"commonName": "linkview"},
    )
    if not had_key:
        os.chmod(key, 0o600)  # the key is a secret: readable by its owner only
    return ClientIdentity(certificate, key)


def load_certificates(path: Path) -> list[x509.Certificate]:
    """The certificates in a PEM (one or more) or DER file; ValueError saying why not."""
    try:
        data = path.read_bytes()
    except OSError as exc:
        raise ValueError(f"cannot read {path}: {exc.strerror or exc}") from None
    try:
        if b"-----BEGIN CERTIFICATE-----" in data:
            return x509.load_pem_x509_certificates(data)
        return [x509.load_der_x509_certificate(data)]
    except ValueError:
        raise ValueError(f"{path} holds no certificate (PEM or DER)") from None


def first_certificate(chain: bytes) -> bytes:
    """The first certificate of a DER chain (OPC UA sends a server's chain as one ByteString)."""
    if len(chain) < 2 or chain[0] != 0x30:
        return chain
    size = chain[1]
    if size < 0x80:
        return chain[: 2 + size]
    count = size & 0x7F  # DER long form: the length in the next ``count`` bytes
    return chain[: 2 + count + int.from_bytes(chain[2 : 2 + count], "big")]


def thumbprint(der: bytes) -> str:
    """The certificate's SHA-1 thumbprint as OPC UA tools show it (``AB:12:...``)."""
    return ":".join(f"{b:02X}" for b in hashlib.sha1(der).digest())  # noqa: S324 (OPC UA's)


def subject(der: bytes) -> str:
    """The certificate's common name (or whole subject), for people."""
    certificate = x509.load_der_x509_certificate(der)
    names = certificate.subject.get_attributes_for_oid(NameOID.COMMON_NAME)
    return str(names[0].value) if names else certificate.subject.rfc4514_string()


def is_trusted(der: bytes, trusted: list[x509.Certificate]) -> bool:
    """Whether the server's certificate ``der`` is one of ``trusted``."""
    return any(c.public_bytes(Encoding.DER) == der for c in trusted)


def refusal(der: bytes, saved: Path | None, source: str) -> str:
    """Why the server's certificate was refused, and the line of the cell that trusts it."""
    what = f"the server's certificate {subject(der)!r} (SHA-1 thumbprint {thumbprint(der)})"
    if saved is None:
        return (
            f"{what} is not trusted: save it and name it in source {source!r}'s server_certificate"
        )
    return (
        f"{what} is not trusted; it is saved as {saved}: if it is your server's, add "
        f'server_certificate = "{saved.name}" to source {source!r}'
    )


def save_refused(der: bytes, folder: Path, source: str) -> Path | None:
    """Keep a refused server certificate as ``<source>-server.der`` in ``folder`` (None: cannot)."""
    path = folder / f"{source}-server.der"
    try:
        folder.mkdir(parents=True, exist_ok=True)
        path.write_bytes(der)
    except OSError:
        return None
    return path
