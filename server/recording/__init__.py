"""Recordings in MCAP with Foxglove's well-known schemas: continuous, on request, and replay."""

from .connector import ReplayConnector
from .continuous import Recorder
from .encode import encode_batch
from .export import history_rows, write_export
from .replay import SourceReplay, load_source, replay_cell
from .writer import McapFile

__all__ = [
    "McapFile",
    "Recorder",
    "ReplayConnector",
    "SourceReplay",
    "encode_batch",
    "history_rows",
    "load_source",
    "replay_cell",
    "write_export",
]
