"""Readable errors for failed connections: what people can act on, not aiohttp's internals."""

from __future__ import annotations

import os

import aiohttp

from .problem import DataLayerError


def connection_error(base_url: str, exc: aiohttp.ClientError) -> DataLayerError:
    """A readable error for a failed connection; TLS trouble says how to fix it."""
    if isinstance(exc, aiohttp.ClientConnectorCertificateError):
        return DataLayerError(
            f"cannot verify the TLS certificate of {base_url} ({exc.certificate_error}); "
            "pass the device's certificate with --ctrlx-ca FILE"
        )
    if isinstance(exc, aiohttp.ClientSSLError):
        return DataLayerError(f"TLS handshake with {base_url} failed: {exc}")
    if isinstance(exc, aiohttp.ClientConnectorError):
        # aiohttp's own text names its internals; the OS error is what people can act on.
        errno = exc.os_error.errno or 0  # negative: a resolver (gai) code, no strerror
        reason = os.strerror(errno) if errno > 0 else exc.os_error.strerror or str(exc.os_error)
        return DataLayerError(f"cannot reach {base_url}: {reason.lower()}")
    if isinstance(exc, aiohttp.ServerDisconnectedError):
        return DataLayerError(
            f"cannot reach {base_url}: it closed the connection without an answer"
        )
    if isinstance(exc, aiohttp.ClientPayloadError):
        return cut_short(base_url)
    if isinstance(exc, aiohttp.ClientOSError):
        return os_error(base_url, exc)
    if isinstance(exc, aiohttp.ClientResponseError):
        # aiohttp's text for a malformed answer quotes the device's bytes: name the kind only.
        return DataLayerError(f"{base_url} sent an answer that is not valid HTTP")
    return DataLayerError(f"request to {base_url} failed: {exc or _kind(exc)}")


def cut_short(base_url: str) -> DataLayerError:
    """The error for an answer whose connection closed before its body was complete."""
    return DataLayerError(f"the connection to {base_url} broke in the middle of an answer")


def os_error(base_url: str, exc: OSError) -> DataLayerError:
    """A readable error for a connection that failed at the OS level (reset, unreachable)."""
    return DataLayerError(f"the connection to {base_url} failed: {_os_reason(exc)}")


def _os_reason(exc: OSError) -> str:
    errno = exc.errno or 0
    return (os.strerror(errno) if errno > 0 else exc.strerror or _kind(exc)).lower()


def _kind(exc: BaseException) -> str:
    return type(exc).__name__
