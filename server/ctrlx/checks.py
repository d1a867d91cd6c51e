"""Start-up checks of the controller's address: one clear line per mistake, not a traceback."""

from __future__ import annotations

from urllib.parse import SplitResult, urlsplit

from ..hosts import is_loopback


def check_base_url(url: str) -> str | None:
    """Raise ValueError (one line) for an unusable controller URL; a warning text, or None.

    Usable: ``http`` or ``https`` with a host, an optional port and path, no
    query or fragment. Plain ``http`` to another machine gives a warning,
    since the password and tokens then travel in clear; loopback does not
    (nothing leaves the machine, as with the embedded mock).
    """
    parts = urlsplit(url.strip())
    shown = _without_userinfo(parts)  # never echo a password someone put in the URL
    if not parts.scheme or not parts.netloc:
        raise ValueError(
            f"controller URL {shown!r} needs a scheme and a host, e.g. https://192.168.1.1"
        )
    scheme = parts.scheme.lower()
    if scheme not in ("http", "https"):
        raise ValueError(f"controller URL {shown!r}: scheme {scheme!r} is not http or https")
    if not parts.hostname:
        raise ValueError(f"controller URL {shown!r} has no host name")
    if parts.username or parts.password:
        raise ValueError(
            f"controller URL {shown!r}: put the user and password in LINKVIEW_CTRLX_USER and "
            "LINKVIEW_CTRLX_PASSWORD, not in the URL (it is shown in logs and health)"
        )
    try:
        parts.port  # noqa: B018 (only parsing it validates it)
    except ValueError:
        raise ValueError(f"controller URL {shown!r} has an invalid port") from None
    if parts.query or parts.fragment:
        raise ValueError(f"controller URL {shown!r} must not have a query or fragment")
    if scheme == "http" and not is_loopback(parts.hostname):
        return (
            f"plain http to {parts.hostname}: credentials travel in clear; "
            "use https (with --ctrlx-ca FILE for the device's own certificate)"
        )
    return None


def _without_userinfo(parts: SplitResult) -> str:
    if "@" not in parts.netloc:
        return parts.geturl()
    return parts._replace(netloc=parts.netloc.rsplit("@", 1)[1]).geturl()
