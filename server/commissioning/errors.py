"""The one error of commissioning: what was refused, with the HTTP status that says why."""

from __future__ import annotations


class CommissioningError(ValueError):
    """An edit, sample or description refused: 403 not allowed, 404 unknown, 409 not now,
    422 does not fit; the message says what to do."""

    def __init__(self, status: int, reason: str) -> None:
        super().__init__(reason)
        self.status = status
