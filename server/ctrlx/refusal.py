"""A better data path (subscriptions, bulk reads) the device refused, and when to ask again."""

from __future__ import annotations

import logging
import time

from .client import DataLayerClient
from .problem import DataLayerError

log = logging.getLogger(__name__)


class Refusal:
    """A better data path the device refused: when, the caveat it leaves, when to ask again.

    The time of the refusal lives on the client, so the acquisition restarting
    ``follow()`` after an error neither delays the next attempt nor repeats
    the warning.
    """

    def __init__(self, client: DataLayerClient, what: str, instead: str, reprobe_s: float) -> None:
        self._client = client
        self._what = what
        self._instead = instead
        self._reprobe_s = reprobe_s

    @property
    def _at(self) -> float | None:
        return self._client.capabilities.refused_at.get(self._what)

    def due(self) -> bool:
        """True when the path may be used: never refused, or time to try it again."""
        at = self._at
        return at is None or time.monotonic() - at >= self._reprobe_s

    def retry(self) -> None:
        """Forget the client's verdict so the next request asks the device again."""
        if self._at is not None:
            log.debug("%s: trying %s again", self._client.base_url, self._what)
            if self._what == "subscriptions":
                self._client.capabilities.subscribe = None
            else:
                self._client.capabilities.bulk = None

    def refused(self, exc: DataLayerError) -> None:
        """The device refused the path (again)."""
        first = self._at is None
        self._client.capabilities.refused_at[self._what] = time.monotonic()
        text = f"{self._what} refused ({exc}); {self._instead}, asking again every "
        text += f"{self._reprobe_s:g} s"
        self._client.note(self._what, text)
        log.log(logging.WARNING if first else logging.DEBUG, "%s: %s", self._client.base_url, text)

    def worked(self) -> None:
        """The path works (again)."""
        if self._client.capabilities.refused_at.pop(self._what, None) is not None:
            self._client.note(self._what, None)
            log.info("%s: %s work again", self._client.base_url, self._what)
