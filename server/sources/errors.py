"""The error every kind of source raises when it cannot be followed right now."""

from __future__ import annotations


class SourceError(Exception):
    """A source that is unusable right now; ``str()`` is meant for people.

    It is shown in /api/health, the log and the page, so it says what failed and
    why (e.g. ``opc.tcp://host:4840: BadUserAccessDenied``). The acquisition
    reports it and follows the source again after a short wait.
    """
