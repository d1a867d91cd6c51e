"""One MCAP file of a cell: Foxglove's well-known schemas, zstd chunks, indexed, the cell attached.

Written with foxglove-sdk's MCAP writer: chunks of CHUNK_BYTES (uncompressed),
each compressed and indexed when full, so a reader can seek and a crash loses
at most the chunk being filled.
"""

from __future__ import annotations

import os
import time
from pathlib import Path

import foxglove
from foxglove.mcap import MCAPCompression, MCAPWriteOptions

from ..cell import Cell
from .encode import Encoded
from .messages import (
    LOG_TOPIC,
    SCENE_TOPIC,
    SCHEMAS,
    TF_TOPIC,
    RobotFrames,
    base_transforms,
    joints_schema,
    joints_topic,
    log_message,
    nanoseconds,
    scene_update,
)

CHUNK_BYTES = 1 << 20
PROFILE = ""
METADATA_NAME = "linkview"


class McapFile:
    """An open recording of ``cell``; ``write`` encoded messages, then ``close``."""

    def __init__(self, path: Path, cell: Cell, t0: float | None = None) -> None:
        t0 = time.time() if t0 is None else t0
        self.path = path
        self.cell = cell
        self.opened = time.monotonic()
        self.frames = {r.name: RobotFrames(r) for r in cell.robots}
        self.messages = 0
        self._context = foxglove.Context()
        options = MCAPWriteOptions(
            compression=MCAPCompression.Zstd,
            chunk_size=CHUNK_BYTES,
            compression_threads=0,  # the machine is shared: no compression threads of its own
            profile=PROFILE,
        )
        path.parent.mkdir(parents=True, exist_ok=True)
        self._writer = foxglove.open_mcap(path, context=self._context, writer_options=options)
        self._channels: dict[str, foxglove.Channel] = {}
        for topic, schema in SCHEMAS.items():
            self._channels[topic] = foxglove.Channel(
                topic, schema=schema, message_encoding="protobuf", context=self._context
            )
        for robot in cell.robots:
            topic = joints_topic(robot.name)
            self._channels[topic] = foxglove.Channel(
                topic, schema=joints_schema(robot), message_encoding="json", context=self._context
            )
        self._attach_cell(t0)
        robots = list(cell.robots)
        self.write([(SCENE_TOPIC, nanoseconds(t0), scene_update(robots, t0))])
        self.write([(TF_TOPIC, nanoseconds(t0), base_transforms(robots, t0))])
        where = "the demo cell" if cell.path is None else str(cell.path)
        note = log_message(t0, "info", "linkview", f"recording of {where}")
        self.write([(LOG_TOPIC, nanoseconds(t0), note)])

    def _attach_cell(self, t0: float) -> None:
        path = self.cell.path
        metadata = {"cell": "" if path is None else str(path.resolve())}
        self._writer.write_metadata(METADATA_NAME, metadata)
        if path is None:
            return
        self._writer.attach(
            log_time=nanoseconds(t0),
            create_time=int(path.stat().st_mtime_ns),
            name=path.name,
            media_type="application/toml",
            data=path.read_bytes(),
        )

    def write(self, messages: list[Encoded]) -> None:
        """Log each ``(topic, log time ns, bytes)`` (topics of robots not in the cell: left out)."""
        for topic, log_time, data in messages:
            channel = self._channels.get(topic)
            if channel is not None:
                channel.log(data, log_time=log_time)
                self.messages += 1

    @property
    def size(self) -> int:
        """Bytes on disk so far (whole chunks)."""
        try:
            return os.path.getsize(self.path)
        except OSError:
            return 0

    def close(self) -> None:
        """Write the last chunk and the summary (the index)."""
        self._writer.close()
        for channel in self._channels.values():
            channel.close()
