"""RFC 7807 Problem errors from the ctrlX REST API, as typed exceptions."""

from __future__ import annotations

from typing import Any


class DataLayerError(Exception):
    """Anything that stops us from reading the data layer; ``str()`` is meant for people."""


class ProblemError(DataLayerError):
    """An HTTP error answered with a Problem body (title, status, detail, instance)."""

    def __init__(
        self,
        status: int,
        title: str,
        detail: str | None = None,
        instance: str | None = None,
        type_: str = "about:blank",
    ) -> None:
        self.status = status
        self.title = title
        self.detail = detail
        self.instance = instance
        self.type = type_
        super().__init__(self.message())

    def message(self) -> str:
        """One readable line, e.g. ``404 DL_INVALID_ADDRESS: ... (motion/axs/x)``."""
        text = f"{self.status} {self.title}"
        if self.detail:
            text += f": {self.detail}"
        if self.instance:
            text += f" ({self.instance})"
        return text

    @classmethod
    def from_body(cls, status: int, body: Any, fallback_title: str) -> ProblemError:
        """Build from a decoded response body, tolerating bodies that are not Problems."""
        if isinstance(body, dict):
            return cls(
                status=int(body.get("status", status)),
                title=str(body.get("title") or fallback_title),
                detail=_str_or_none(body.get("detail")),
                instance=_str_or_none(body.get("instance")),
                type_=str(body.get("type", "about:blank")),
            )
        return cls(status=status, title=fallback_title, detail=_str_or_none(body))


class AuthError(ProblemError):
    """401: wrong credentials, or a token the server no longer accepts."""


class NodeNotFound(ProblemError):
    """404: the node address does not exist in the data layer."""


class BadValue(DataLayerError):
    """A node answered with a value we cannot use (not a number, wrong type)."""


def problem_for_status(status: int, body: Any, fallback_title: str) -> ProblemError:
    """The most specific ProblemError subclass for an HTTP status."""
    kind: type[ProblemError] = {401: AuthError, 404: NodeNotFound}.get(status, ProblemError)
    return kind.from_body(status, body, fallback_title)


def _str_or_none(value: Any) -> str | None:
    return None if value is None else str(value)
