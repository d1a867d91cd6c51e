"""One object per running event loop, for what every task of a process shares (batches, writes)."""

from __future__ import annotations

import asyncio
import weakref
from collections.abc import Callable
from typing import Generic, TypeVar

T = TypeVar("T")


class PerLoop(Generic[T]):
    """``make()`` once per event loop, dropped with the loop.

    The loop is held weakly, so what ``make`` returns must not refer to it (a
    value that keeps its weak key alive would keep every finished loop, one per
    test): ask ``asyncio.get_running_loop()`` when needed instead.
    """

    def __init__(self, make: Callable[[], T]) -> None:
        self._make = make
        self._made: weakref.WeakKeyDictionary[asyncio.AbstractEventLoop, T] = (
            weakref.WeakKeyDictionary()
        )

    def get(self) -> T:
        """The running loop's object (made now if it has none)."""
        loop = asyncio.get_running_loop()
        found = self._made.get(loop)
        if found is None:
            found = self._made[loop] = self._make()
        return found
