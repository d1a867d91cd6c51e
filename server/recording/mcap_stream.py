"""An MCAP file read front to back with every size bounded, whatever its records claim.

Replay reads files it did not write: a recording from another machine, one
cut short by a crash, or one made to hurt. ``mcap``'s readers trust the
sizes a file states (a chunk claiming 2^62 bytes is allocated, a small zstd
chunk may decompress to gigabytes) and its seeking reader needs the summary
a crashed recorder never wrote. So records are read in file order with
``mcap``'s ``StreamReader``, over a file object that refuses any read past
the end of the file or over MAX_RECORD_BYTES, and chunks are decompressed
here, at most MAX_CHUNK_BYTES each, rather than by the library.

The end of the file may be cut anywhere (``kill -9`` during ``--record``):
whatever runs past the end, or cannot be decompressed, ends the reading
(``Stream.cut`` says where and why), and what came before counts. A record
over the limits refuses the file (``TooLarge``, naming the number).
"""

from __future__ import annotations

import io
import struct
from collections.abc import Iterator
from pathlib import Path
from typing import BinaryIO

import lz4.frame
import zstandard
from mcap.data_stream import ReadDataStream
from mcap.exceptions import EndOfFile, McapError
from mcap.opcode import Opcode
from mcap.records import Channel, Chunk, McapRecord, Message, Metadata
from mcap.stream_reader import StreamReader

MAX_RECORD_BYTES = 64 << 20
"""One record as stored (our chunks are about 1 MiB compressed; the cell file is attached)."""
MAX_CHUNK_BYTES = 64 << 20
"""One chunk decompressed (our writer's are 1 MiB: ``writer.CHUNK_BYTES``)."""
RECORD = struct.Struct("<BQ")
"""A record's opcode and length."""
MESSAGE_HEAD = struct.Struct("<HIQQ")
"""Channel id, sequence, log time, publish time: a message record's bytes before its data."""
SKIPPED = frozenset({Opcode.MESSAGE_INDEX, Opcode.CHUNK_INDEX, Opcode.STATISTICS})
"""Index records: a stream reader has no use for them, and parsing them costs."""


class TooLarge(ValueError):
    """A record or chunk over the limits: the file is refused."""


class _Cut(Exception):
    """The file ends (or stops making sense) inside a record."""


class _Bounded:
    """A file as ``StreamReader`` reads it: no read past its end or over MAX_RECORD_BYTES."""

    def __init__(self, file: BinaryIO, size: int) -> None:
        self._file = file
        self.left = size

    def read(self, size: int = -1) -> bytes:
        if size < 0 or size > self.left:
            raise _Cut(f"a record runs past the end: {size} more bytes claimed, {self.left} left")
        if size > MAX_RECORD_BYTES:
            raise TooLarge(f"a record of {size} bytes, over the limit of {MAX_RECORD_BYTES}")
        data = self._file.read(size)
        self.left -= len(data)
        return data


class _Records(StreamReader):
    """mcap's stream reader, skipping the index records unparsed."""

    def _read_record(self, opcode: int, length: int) -> McapRecord | None:
        if opcode in SKIPPED:
            self._stream.read(length)
            return None
        record: McapRecord | None = super()._read_record(opcode, length)
        return record


class Stream:
    """The channels and messages of an MCAP file, in file order, chunks opened one at a time."""

    def __init__(self, path: Path, open_chunks: bool = True) -> None:
        self.path = path
        self.open_chunks = open_chunks
        """False: chunks are skipped unopened (the records outside them are enough)."""
        self.cut: str | None = None
        """Why reading stopped before the end of the file (a crash cut it), None if it did not."""
        self.chunks = 0
        """Chunks read whole."""

    def records(self) -> Iterator[McapRecord]:
        """Every channel, message and metadata record; TooLarge, OSError or McapError if the
        file cannot be read at all (a wrong magic)."""
        with self.path.open("rb") as file:
            source = _Bounded(file, self.path.stat().st_size)
            # No limit of its own: a record that claims to run past the end is a cut (foxglove-sdk
            # writes a chunk's length once it is done: 2^64 - 1 until then), one over
            # MAX_RECORD_BYTES within the file is refused; ``_Bounded`` tells which.
            reader = _Records(
                source,  # type: ignore[arg-type]  # it only calls read()
                emit_chunks=True,
                record_size_limit=None,
            )
            records = reader.records
            first = True
            while True:
                try:
                    record = next(records)
                except StopIteration:
                    return
                except TooLarge:
                    raise
                except (_Cut, EndOfFile, struct.error, ValueError, McapError) as exc:
                    if first:  # not even the magic and header: not an MCAP file
                        raise McapError(f"not an MCAP file: {_reason(exc)}") from None
                    self.cut = f"the file ends inside a record ({_reason(exc)})"
                    return
                first = False
                if isinstance(record, Chunk) and self.open_chunks:
                    try:
                        yield from _chunk_records(record)
                    except _Cut as exc:
                        self.cut = f"chunk {self.chunks + 1}: {exc}"
                        return
                    self.chunks += 1
                elif isinstance(record, Channel | Message | Metadata):
                    yield record


def _reason(exc: BaseException) -> str:
    return str(exc) or type(exc).__name__


def _chunk_records(chunk: Chunk) -> Iterator[Channel | Message]:
    """The channels and messages of one chunk (mcap's ``breakup_chunk``, with bounds).

    Message records are taken apart with one struct read each rather than
    through ``Message.read``'s five stream reads: a million of them is most of
    what a long replay costs to load.
    """
    data = _decompress(chunk)
    at, end = 0, len(data)
    while at < end:
        if end - at < RECORD.size:
            raise _Cut("a record's header runs past its chunk")
        opcode, length = RECORD.unpack_from(data, at)
        at += RECORD.size
        if length > end - at:
            raise _Cut(f"a record of {length} bytes runs past its chunk")
        if opcode == Opcode.MESSAGE and length >= MESSAGE_HEAD.size:
            channel, sequence, log_time, publish_time = MESSAGE_HEAD.unpack_from(data, at)
            body = data[at + MESSAGE_HEAD.size : at + length]
            yield Message(
                channel_id=channel,
                log_time=log_time,
                data=body,
                publish_time=publish_time,
                sequence=sequence,
            )
        elif opcode == Opcode.CHANNEL:
            try:
                yield Channel.read(ReadDataStream(io.BytesIO(data[at : at + length])))
            except (EndOfFile, struct.error, UnicodeDecodeError) as exc:
                raise _Cut(f"a garbled channel record: {_reason(exc)}") from None
        at += length


def _decompress(chunk: Chunk) -> bytes:
    """A chunk's records: at most MAX_CHUNK_BYTES, whatever the chunk claims or holds."""
    size = chunk.uncompressed_size
    if size > MAX_CHUNK_BYTES:
        raise TooLarge(
            f"a chunk that decompresses to {size} bytes, over the limit of {MAX_CHUNK_BYTES}"
        )
    try:
        if chunk.compression == "":
            data = chunk.data
        elif chunk.compression == "zstd":
            with zstandard.ZstdDecompressor().stream_reader(chunk.data) as reader:
                data = _read_up_to(reader, size + 1)
        elif chunk.compression == "lz4":
            data = lz4.frame.LZ4FrameDecompressor().decompress(chunk.data, max_length=size + 1)
        else:
            raise _Cut(f"compression {chunk.compression[:20]!r} is not MCAP's")
    except (zstandard.ZstdError, RuntimeError, OSError) as exc:
        raise _Cut(f"it cannot be decompressed: {_reason(exc)}") from None
    if len(data) != size:
        raise _Cut(f"it decompresses to {len(data)} bytes, not the {size} it claims")
    return bytes(data)


def _read_up_to(reader: zstandard.ZstdDecompressionReader, size: int) -> bytes:
    """Read until ``size`` bytes or the end, whichever comes first."""
    parts, left = [], size
    while left > 0 and (part := reader.read(min(left, 1 << 20))):
        parts.append(part)
        left -= len(part)
    return b"".join(parts)
