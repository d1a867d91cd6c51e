"""Coarse link meshes made once per content and kept in memory, one conversion at a time."""

from __future__ import annotations

import asyncio
import hashlib
import logging
from collections import OrderedDict
from pathlib import Path

from .decimate import FORMAT, LINK_FACES, TOLERANCE, CoarseError, coarse_glb

log = logging.getLogger(__name__)

CAPACITY = 512
"""Coarse meshes kept (some 5-20 kB each): every link of a large plant, several times over."""


class CoarseMeshes:
    """The coarse GLB of a link mesh file (decimate.coarse_glb), by the file's content.

    Keyed by a hash of the bytes (and the conversion's format and sizes), so a
    changed file is converted again and a copy of a file is not; the least
    recently used are forgotten beyond ``capacity``. A file that cannot be made
    coarse is remembered too, with its reason, and logged once. Conversions run
    in a worker thread, one at a time: the event loop and the other robots' frames
    never wait for them, and many viewers asking at once cost one conversion.
    """

    def __init__(
        self, capacity: int = CAPACITY, tolerance: float = TOLERANCE, link_faces: int = LINK_FACES
    ) -> None:
        self.capacity = capacity
        self.tolerance = tolerance
        self.link_faces = link_faces
        self.conversions = 0
        self._kept: OrderedDict[str, bytes | CoarseError] = OrderedDict()
        self._running: dict[str, asyncio.Future[bytes | CoarseError]] = {}
        self._one_at_a_time = asyncio.Lock()

    def _key(self, data: bytes) -> str:
        digest = hashlib.sha256(data).hexdigest()
        return f"{digest}:{FORMAT}:{self.tolerance}:{self.link_faces}"

    async def get(self, path: Path) -> bytes:
        """The coarse GLB of the GLB at ``path``; raises CoarseError if it has none."""
        data = await asyncio.to_thread(path.read_bytes)
        key = self._key(data)
        found = self._kept.get(key)
        if found is None:
            running = self._running.get(key)
            if running is None:
                running = asyncio.ensure_future(self._convert(key, data, path))
                self._running[key] = running
            found = await asyncio.shield(running)
        self._kept.move_to_end(key)
        if isinstance(found, CoarseError):
            raise found
        return found

    async def _convert(self, key: str, data: bytes, path: Path) -> bytes | CoarseError:
        try:
            async with self._one_at_a_time:
                result: bytes | CoarseError = await asyncio.to_thread(
                    coarse_glb, data, self.tolerance, self.link_faces
                )
        except CoarseError as exc:
            log.warning("coarse mesh of %s: %s; the 2D view draws its full mesh", path, exc)
            result = exc
        finally:
            del self._running[key]
        self.conversions += 1
        self._kept[key] = result
        while len(self._kept) > self.capacity:
            self._kept.popitem(last=False)
        return result
