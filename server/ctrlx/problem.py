"""RFC 7807 Problem errors from the ctrlX REST API, as typed exceptions."""

from __future__ import annotations

from typing import Any

from ..sources import SourceError


class DataLayerError(SourceError):
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
            raw_status = body.get("status", status)
            return cls(
                status=raw_status if isinstance(raw_status, int) else status,
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


class BadAddress(DataLayerError):
    """A node address we refuse to request (it would leave the nodes API); never retried."""


class Unsupported(DataLayerError):
    """The server lacks a service (subscriptions, bulk): older firmware, or switched off."""


class StreamEnded(DataLayerError):
    """An event stream closed, fell silent past its keepalive, or sent garbage."""


def problem_for_status(status: int, body: Any, fallback_title: str) -> ProblemError:
    """The most specific ProblemError subclass for an HTTP status."""
    kind: type[ProblemError] = {401: AuthError, 404: NodeNotFound}.get(status, ProblemError)
    return kind.from_body(status, body, fallback_title)


RESULT_STATUS = {
    "DL_INVALID_ADDRESS": 404,
    "DL_PERMISSION_DENIED": 403,
    "DL_TYPE_MISMATCH": 400,
    "DL_INVALID_VALUE": 400,
    "DL_INVALID_OPERATION": 400,
    "DL_UNSUPPORTED": 400,
}
"""Data-layer result codes (as in bulk answers) and the HTTP status a single request gets."""


def problem_for_result(node: str, result: str, body: Any) -> ProblemError:
    """The error for one failed entry of a bulk answer (``result`` is e.g. DL_INVALID_ADDRESS)."""
    status = RESULT_STATUS.get(result, 500)
    if isinstance(body, dict) and "title" in body:
        return problem_for_status(status, body, result)
    return problem_for_status(status, {"title": result, "detail": f"node '{node}'"}, result)


def _str_or_none(value: Any) -> str | None:
    return None if value is None else str(value)
