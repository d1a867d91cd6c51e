"""TLS for talking to a device: verified by default, its own certificate trusted on request."""

from __future__ import annotations

import logging
import ssl
from pathlib import Path

log = logging.getLogger(__name__)


def client_ssl(ca_file: str | Path | None = None, insecure: bool = False) -> ssl.SSLContext | bool:
    """What to pass as aiohttp's ``ssl=``.

    * default: verify against the system's CAs (``True``);
    * ``ca_file``: trust exactly the certificates in that PEM file, e.g. the
      self-signed certificate a ctrlX CORE ships with; a file that is missing,
      unreadable or holds no certificate raises ValueError with one clear line;
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
    path = Path(ca_file)
    if not path.exists():
        raise ValueError(f"CA file {path} does not exist")
    if not path.is_file():
        raise ValueError(f"CA file {path} is not a file")
    try:
        pem = path.read_text(encoding="ascii")
    except (OSError, UnicodeDecodeError) as exc:
        reason = exc.strerror if isinstance(exc, OSError) and exc.strerror else "not a PEM file"
        raise ValueError(f"CA file {path} cannot be read: {reason.lower()}") from None
    try:
        return ssl.create_default_context(cadata=pem)
    except ssl.SSLError:
        raise ValueError(f"CA file {path} holds no PEM certificate") from None
