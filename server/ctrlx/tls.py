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
      self-signed certificate a ctrlX CORE ships with;
    * ``insecure``: no verification at all, logged as a warning because
      anyone on the network path can then read the password.
    """
    if insecure:
        log.warning(
            "TLS certificate verification is OFF (--insecure): the controller's identity is "
            "not checked; prefer --ctrlx-ca FILE with the device's certificate"
        )
        return False
    if ca_file is not None:
        path = Path(ca_file)
        if not path.is_file():
            raise FileNotFoundError(f"CA file {path} does not exist")
        return ssl.create_default_context(cafile=str(path))
    return True
