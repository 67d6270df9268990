"""A lean chunked MCAP writer: the `mcap` package's Writer format, a fraction of its cost.

`mcap.writer.Writer.add_message` costs ~20 µs (a dataclass and several calls per message);
the recorder needs ≥ 20,000 messages/s on one core next to DDS, so messages are appended to
the open chunk with one struct pack. Everything else (schemas, channels, chunk and message
indexes, statistics, summary offsets, footer CRC) is written with the `mcap` package's record
classes, so the output is what its Writer produces.
"""

from __future__ import annotations

import struct
import zlib
from collections.abc import Sequence
from typing import IO

import lz4.frame
import zstandard
from mcap.data_stream import RecordBuilder
from mcap.opcode import Opcode
from mcap.records import (
    Channel,
    Chunk,
    ChunkIndex,
    DataEnd,
    Footer,
    Header,
    McapRecord,
    Metadata,
    MetadataIndex,
    Schema,
    Statistics,
    SummaryOffset,
)

__all__ = ["McapFile"]

MAGIC = b"\x89MCAP0\r\n"
_MESSAGE_HEAD = struct.Struct("<BQHIQQ")  # opcode, length, channel, sequence, log, publish
_COMPRESSORS = {
    "zstd": zstandard.ZstdCompressor(level=1).compress,
    "lz4": lz4.frame.compress,
    "": None,
}


def _record_bytes(*records: McapRecord) -> bytes:
    builder = RecordBuilder()
    for record in records:
        record.write(builder)
    data: bytes = builder.end()
    return data


class McapFile:
    """One MCAP file being written to `stream`: chunked, indexed, with a full summary.

    `compression` is 'zstd', 'lz4' or '' (none). A chunk closes when it exceeds `chunk_size`
    bytes or on `flush()`.
    """

    def __init__(self, stream: IO[bytes], *, profile: str, library: str, compression: str, chunk_size: int) -> None:
        self._out = stream
        self._pos = 0
        self._compression = compression
        self._compress = _COMPRESSORS[compression]
        self._chunk_size = chunk_size
        self._schemas: list[Schema] = []
        self._channels: list[Channel] = []
        self._chunk_indexes: list[ChunkIndex] = []
        self._metadata_indexes: list[MetadataIndex] = []
        self._counts: dict[int, int] = {}
        self._message_count = 0
        self._start = 0
        self._end = 0
        self._chunk = bytearray()
        self._chunk_messages = 0
        self._chunk_start = 0
        self._chunk_end = 0
        self._index: dict[int, list[int]] = {}  # channel -> flat [log time, offset, ...]
        self._write(MAGIC + _record_bytes(Header(profile=profile, library=library)))

    def _write(self, data: bytes) -> None:
        self._out.write(data)
        self._pos += len(data)

    def add_schema(self, name: str, encoding: str, data: bytes) -> int:
        """Register a schema; returns its id."""
        schema = Schema(id=len(self._schemas) + 1, name=name, encoding=encoding, data=data)
        self._schemas.append(schema)
        self._chunk += _record_bytes(schema)  # in the data section too: recoverable after a crash
        return schema.id

    def add_channel(self, topic: str, message_encoding: str, schema_id: int, metadata: dict[str, str]) -> int:
        """Register a channel (topic); returns its id."""
        channel = Channel(
            id=len(self._channels) + 1,
            topic=topic,
            message_encoding=message_encoding,
            schema_id=schema_id,
            metadata=metadata,
        )
        self._channels.append(channel)
        self._counts[channel.id] = 0
        self._chunk += _record_bytes(channel)
        return channel.id

    def add_message(self, channel_id: int, log_time: int, publish_time: int, data: bytes) -> None:
        """Append a message (times in ns) to the open chunk, closing it when full."""
        chunk = self._chunk
        offset = len(chunk)
        chunk += _MESSAGE_HEAD.pack(Opcode.MESSAGE, 22 + len(data), channel_id, 0, log_time, publish_time)
        chunk += data
        index = self._index.get(channel_id)
        if index is None:
            index = self._index[channel_id] = []
        index.append(log_time)
        index.append(offset)
        if self._chunk_messages == 0:
            self._chunk_start = self._chunk_end = log_time
        elif log_time < self._chunk_start:
            self._chunk_start = log_time
        elif log_time > self._chunk_end:
            self._chunk_end = log_time
        self._chunk_messages += 1
        self._counts[channel_id] += 1
        if len(chunk) > self._chunk_size:
            self.close_chunk()

    def close_chunk(self) -> None:
        """Write the open chunk (if it holds messages) and its message indexes."""
        if not self._chunk_messages:
            return
        data = bytes(self._chunk)
        compressed = self._compress(data) if self._compress else data
        chunk = _record_bytes(
            Chunk(
                message_start_time=self._chunk_start,
                message_end_time=self._chunk_end,
                uncompressed_size=len(data),
                uncompressed_crc=zlib.crc32(data),
                compression=self._compression,
                data=compressed,
            )
        )
        chunk_offset = self._pos
        index_offset = chunk_offset + len(chunk)
        parts: list[bytes] = []
        offsets: dict[int, int] = {}
        for channel_id, flat in self._index.items():
            offsets[channel_id] = index_offset + sum(len(p) for p in parts)
            # MessageIndex record: channel id, byte length of (log time, offset) pairs, pairs
            parts.append(
                struct.pack(
                    f"<BQHI{len(flat)}Q", Opcode.MESSAGE_INDEX, 6 + 8 * len(flat), channel_id, 8 * len(flat), *flat
                )
            )
        indexes = b"".join(parts)
        self._write(chunk + indexes)
        self._chunk_indexes.append(
            ChunkIndex(
                message_start_time=self._chunk_start,
                message_end_time=self._chunk_end,
                chunk_start_offset=chunk_offset,
                chunk_length=len(chunk),
                message_index_offsets=offsets,
                message_index_length=len(indexes),
                compression=self._compression,
                compressed_size=len(compressed),
                uncompressed_size=len(data),
            )
        )
        if self._message_count == 0:
            self._start, self._end = self._chunk_start, self._chunk_end
        else:
            self._start = min(self._start, self._chunk_start)
            self._end = max(self._end, self._chunk_end)
        self._message_count += self._chunk_messages
        self._chunk = bytearray()
        self._chunk_messages = 0
        self._index = {}

    def flush(self) -> None:
        """Close the open chunk and hand the bytes to the OS."""
        self.close_chunk()
        self._out.flush()

    def add_metadata(self, name: str, metadata: dict[str, str]) -> None:
        """Write a metadata record (after closing the open chunk)."""
        self.close_chunk()
        record = _record_bytes(Metadata(name=name, metadata=metadata))
        self._metadata_indexes.append(MetadataIndex(offset=self._pos, length=len(record), name=name))
        self._write(record)

    def finish(self) -> None:
        """Close the chunk, write data end, summary (schemas, channels, statistics, chunk and
        metadata indexes), summary offsets and footer; does not close the stream."""
        self.close_chunk()
        self._write(_record_bytes(DataEnd(data_section_crc=0)))
        summary_start = self._pos
        stats = Statistics(
            message_count=self._message_count,
            schema_count=len(self._schemas),
            channel_count=len(self._channels),
            attachment_count=0,
            metadata_count=len(self._metadata_indexes),
            chunk_count=len(self._chunk_indexes),
            message_start_time=self._start,
            message_end_time=self._end,
            channel_message_counts=dict(self._counts),
        )
        groups: list[tuple[Opcode, Sequence[McapRecord]]] = [
            (Opcode.SCHEMA, self._schemas),
            (Opcode.CHANNEL, self._channels),
            (Opcode.STATISTICS, [stats]),
            (Opcode.CHUNK_INDEX, self._chunk_indexes),
            (Opcode.METADATA_INDEX, self._metadata_indexes),
        ]
        body = b""
        offsets = []
        for opcode, records in groups:
            if records:
                data = _record_bytes(*records)
                offsets.append(
                    SummaryOffset(group_opcode=opcode, group_start=summary_start + len(body), group_length=len(data))
                )
                body += data
        offset_start = summary_start + len(body)
        body += _record_bytes(*offsets)
        crc = zlib.crc32(body)
        crc = zlib.crc32(struct.pack("<BQQQ", Opcode.FOOTER, 20, summary_start, offset_start), crc)
        self._write(
            body
            + _record_bytes(Footer(summary_start=summary_start, summary_offset_start=offset_start, summary_crc=crc))
            + MAGIC
        )
        self._out.flush()
