"""Read rosbag2 MCAP bags (ours, `ros2 bag record -s mcap`, Foxglove exports).

Usage::

    from sim_runtime.bag.reader import open_bag

    bag = open_bag('rosbag2_2026_01_01-12_00_00')   # bag folder, or a single .mcap file
    print(bag.topics)            # {'/scan': 'sensor_msgs/msg/LaserScan', ...}
    for m in bag.messages(topics=['/scan'], start=bag.start_ns, end=bag.start_ns + 10**9):
        scan = m.msg             # deserialised rclpy message (class cached per type)
        raw = m.data             # CDR bytes, as on the wire

A file that was not finished (recorder killed, disk full, copy cut short) is read up to the
last intact chunk, with a `BagWarning` naming the file; a corrupt chunk is skipped with a
warning. `BagMessage.msg` raises `UnknownMessageType` (naming type and topic) when the type's
Python package is not installed: callers skip that topic.
"""

from __future__ import annotations

import glob
import heapq
import importlib
import importlib.util
import os
import re
import struct
import warnings
import zlib
from collections.abc import Callable, Iterable, Iterator
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import lz4.frame
import zstandard
from mcap.data_stream import ReadDataStream
from mcap.reader import SeekingReader
from mcap.records import Channel, Chunk, ChunkIndex, Footer, Message, Schema
from mcap.stream_reader import StreamReader, breakup_chunk

from sim_runtime.errors import InputError
from sim_runtime.inputfile import file_problem, is_regular_file, read_input_text, shown
from sim_runtime.yamlfile import parse_yaml, short_text

__all__ = ["Bag", "BagMessage", "BagWarning", "CorruptMessage", "UnknownMessageType", "open_bag"]


class BagWarning(UserWarning):
    """Part of a bag could not be read (truncated or corrupt file); the rest is returned."""


class UnknownMessageType(LookupError):
    """A message's type has no installed Python message class, so it cannot be deserialised."""


class CorruptMessage(InputError):
    """A message's bytes are not a valid serialised message of its topic's type."""


_MESSAGE_CLASSES: dict[str, Any] = {}
_IDENTIFIER = re.compile(r"^[A-Za-z][A-Za-z0-9_]*$")


def message_class(type_name: str, topic: str = "?") -> Any:
    """The rclpy message class for ``pkg/msg/Type`` (cached); UnknownMessageType if missing."""
    cls = _MESSAGE_CLASSES.get(type_name)
    if cls is None:
        # What rosidl_runtime_py.utilities.get_message does (that package is not installed
        # from the wheels we use): import `pkg.msg` and take the class.
        parts = type_name.split("/")
        if len(parts) == 2:
            parts = [parts[0], "msg", parts[1]]
        try:
            # A bag names the module to import: only ROS message packages, never e.g. "os/path/join".
            if len(parts) != 3 or parts[1] != "msg" or not all(_IDENTIFIER.match(p) for p in parts):
                raise ValueError("expected pkg/msg/Type")
            if not _is_message_package(parts[0]):
                raise ImportError(f"{parts[0]} is not a ROS interface package")
            cls = getattr(importlib.import_module(f"{parts[0]}.{parts[1]}"), parts[2])
            if not (isinstance(cls, type) and hasattr(cls, "get_fields_and_field_types")):
                raise ValueError("not a ROS message class")
        except (AttributeError, ImportError, ValueError) as exc:
            raise UnknownMessageType(
                f"cannot deserialise topic {topic!r}: message type {type_name!r} is not installed ({exc})"
            ) from None
        _MESSAGE_CLASSES[type_name] = cls
    return cls


def _is_message_package(package: str) -> bool:
    """Whether ``package`` is rosidl-generated (has its C type support library), found without
    importing it: a bag must not make us run the top-level code of any module it names."""
    spec = importlib.util.find_spec(package)
    for location in (spec.submodule_search_locations or []) if spec is not None else []:
        if glob.glob(os.path.join(glob.escape(location), f"{package}_s__rosidl_typesupport_c*")):
            return True
    return False


class BagMessage:
    """One recorded message: raw CDR `data` plus `msg`, deserialised on first access."""

    __slots__ = ("_msg", "data", "log_time_ns", "publish_time_ns", "topic", "type")

    def __init__(self, topic: str, type_name: str, log_time_ns: int, publish_time_ns: int, data: bytes) -> None:
        self.topic = topic
        self.type = type_name
        self.log_time_ns = log_time_ns
        self.publish_time_ns = publish_time_ns
        self.data = data
        self._msg: Any = None

    @property
    def msg(self) -> Any:
        """The deserialised message; raises UnknownMessageType naming type and topic, or
        CorruptMessage (an InputError) when the bytes do not decode as that type."""
        if self._msg is None:
            from rclpy.serialization import deserialize_message

            cls = message_class(self.type, self.topic)
            try:
                self._msg = deserialize_message(self.data, cls)
            except Exception as exc:
                raise CorruptMessage(
                    f"topic {self.topic} at log time {self.log_time_ns} ns: cannot deserialise "
                    f"{len(self.data)} bytes as {self.type} ({exc})"
                ) from None
        return self._msg

    def __repr__(self) -> str:
        return f"BagMessage({self.topic!r}, {self.type!r}, log_time_ns={self.log_time_ns}, {len(self.data)} bytes)"


@dataclass
class _FileInfo:
    """What one .mcap split holds; `intact` False when it has no readable summary."""

    path: Path
    intact: bool
    channels: dict[int, Channel] = field(default_factory=dict)
    schemas: dict[int, Schema] = field(default_factory=dict)
    counts: dict[int, int] = field(default_factory=dict)
    start_ns: int | None = None
    end_ns: int | None = None
    chunk_indexes: list[ChunkIndex] = field(default_factory=list)


def _split_number(path: Path) -> tuple[int, str]:
    match = re.search(r"_(\d+)\.mcap$", path.name)
    return (int(match.group(1)) if match else -1, path.name)


def _warn(text: str) -> None:
    warnings.warn(text, BagWarning, stacklevel=3)


class Bag:
    """An opened bag: topic list, time range, counts, and a message iterator."""

    def __init__(self, path: Path, files: list[Path], metadata: dict[str, Any] | None) -> None:
        self.path = path
        self.files = files
        #: rosbag2_bagfile_information from metadata.yaml (None for a bare .mcap or a
        #: folder whose recorder was killed before writing it).
        self.metadata = metadata
        self._infos = [self._index(f) for f in files]
        self.topics: dict[str, str] = {}
        #: channel metadata per topic (offered_qos_profiles YAML, topic_type_hash)
        self.topic_metadata: dict[str, dict[str, str]] = {}
        self.topic_counts: dict[str, int] = {}
        for info in self._infos:
            for cid, ch in info.channels.items():
                schema = info.schemas.get(ch.schema_id)
                self.topics.setdefault(ch.topic, schema.name if schema else "")
                self.topic_metadata.setdefault(ch.topic, dict(ch.metadata))
                self.topic_counts[ch.topic] = self.topic_counts.get(ch.topic, 0) + (info.counts.get(cid, 0))
        starts = [i.start_ns for i in self._infos if i.start_ns is not None]
        ends = [i.end_ns for i in self._infos if i.end_ns is not None]
        #: log time of the first / last message (0 for an empty bag)
        self.start_ns: int = min(starts) if starts else 0
        self.end_ns: int = max(ends) if ends else 0
        self.message_count: int = sum(self.topic_counts.values())

    @property
    def duration_ns(self) -> int:
        return self.end_ns - self.start_ns

    def _index(self, path: Path) -> _FileInfo:
        try:
            with path.open("rb") as stream:
                summary = SeekingReader(stream).get_summary()
        except Exception as exc:
            summary = None
            reason = str(exc) or type(exc).__name__
        else:
            reason = "no summary statistics" if summary is not None else "no summary section"
        if summary is not None and summary.statistics is not None:
            stats = summary.statistics
            has_messages = stats.message_count > 0
            return _FileInfo(
                path,
                True,
                dict(summary.channels),
                dict(summary.schemas),
                dict(stats.channel_message_counts),
                stats.message_start_time if has_messages else None,
                stats.message_end_time if has_messages else None,
                sorted(summary.chunk_indexes, key=lambda c: (c.message_start_time, c.chunk_start_offset)),
            )
        _warn(f"{path}: not a finished MCAP file ({reason}); reading what is intact")
        info = _FileInfo(path, False)
        for record in self._scan(info):
            if isinstance(record, Message):
                info.counts[record.channel_id] = info.counts.get(record.channel_id, 0) + 1
                t = record.log_time
                info.start_ns = t if info.start_ns is None else min(info.start_ns, t)
                info.end_ns = t if info.end_ns is None else max(info.end_ns, t)
        return info

    def _scan(self, info: _FileInfo, quiet: bool = False) -> Iterator[Any]:
        """Records of an unfinished file in order, skipping corrupt chunks, stopping at the cut.

        Fills `info.channels` / `info.schemas` as they appear.
        """
        with info.path.open("rb") as stream:
            reader = StreamReader(stream, emit_chunks=True)
            records = reader.records
            while True:
                try:
                    record = next(records)
                except StopIteration:
                    return
                except Exception as exc:
                    if not quiet:
                        _warn(
                            f"{info.path}: data ends or is corrupt at byte {stream.tell()} "
                            f"({str(exc) or type(exc).__name__}); later messages are lost"
                        )
                    return
                if isinstance(record, Chunk):
                    try:
                        inner = breakup_chunk(record, validate_crc=True)
                    except Exception as exc:
                        if not quiet:
                            _warn(f"{info.path}: skipping a corrupt chunk ({exc})")
                        continue
                else:
                    inner = [record]
                for rec in inner:
                    if isinstance(rec, Schema):
                        info.schemas[rec.id] = rec
                    elif isinstance(rec, Channel):
                        info.channels[rec.id] = rec
                    yield rec
                if isinstance(record, Footer):
                    return

    def _file_messages(
        self, info: _FileInfo, topics: set[str] | None, start: int | None, end: int | None
    ) -> Iterator[BagMessage]:
        types = {
            cid: (info.schemas[ch.schema_id].name if ch.schema_id in info.schemas else "")
            for cid, ch in info.channels.items()
        }
        if info.intact and (info.chunk_indexes or not info.counts):
            yield from self._chunked_messages(info, types, topics, start, end)
            return
        for rec in self._scan(info, quiet=True):
            if not isinstance(rec, Message):
                continue
            channel = info.channels.get(rec.channel_id)
            if channel is None:
                continue
            if topics is not None and channel.topic not in topics:
                continue
            if (start is not None and rec.log_time < start) or (end is not None and rec.log_time > end):
                continue
            types.setdefault(
                rec.channel_id,
                info.schemas[channel.schema_id].name if channel.schema_id in info.schemas else "",
            )
            yield BagMessage(channel.topic, types[rec.channel_id], rec.log_time, rec.publish_time, rec.data)

    def _chunked_messages(
        self,
        info: _FileInfo,
        types: dict[int, str],
        topics: set[str] | None,
        start: int | None,
        end: int | None,
    ) -> Iterator[BagMessage]:
        """Messages of a finished file via its chunk index, in log-time order.

        Parses chunk records directly (the mcap package's reader costs ~40 µs a message);
        chunks whose time ranges overlap are merged; a corrupt chunk is skipped with a warning.
        """
        wanted = {
            cid: (ch.topic, types.get(cid, ""))
            for cid, ch in info.channels.items()
            if topics is None or ch.topic in topics
        }
        lo = -1 if start is None else start
        hi = 2**64 if end is None else end
        chunks = [
            c
            for c in info.chunk_indexes
            if c.message_end_time >= lo
            and c.message_start_time <= hi
            and (not c.message_index_offsets or any(k in wanted for k in c.message_index_offsets))
        ]
        pending: list[tuple[int, int, BagMessage]] = []  # heap over overlapping chunks
        order = 0
        with info.path.open("rb") as stream:
            for chunk_index in chunks:
                while pending and pending[0][0] < chunk_index.message_start_time:
                    yield heapq.heappop(pending)[2]
                try:
                    records = _chunk_records(stream, chunk_index)
                except Exception as exc:
                    _warn(f"{info.path}: skipping a corrupt chunk at byte {chunk_index.chunk_start_offset} ({exc})")
                    continue
                for cid, log_time, publish_time, data in _messages_in(records):
                    meta = wanted.get(cid)
                    if meta is None or log_time < lo or log_time > hi:
                        continue
                    order += 1
                    heapq.heappush(
                        pending, (log_time, order, BagMessage(meta[0], meta[1], log_time, publish_time, data))
                    )
            while pending:
                yield heapq.heappop(pending)[2]

    def messages(
        self,
        topics: Iterable[str] | None = None,
        start: int | None = None,
        end: int | None = None,
    ) -> Iterator[BagMessage]:
        """Messages in log-time order, optionally only `topics` and `start <= log_time <= end` (ns)."""
        wanted = set(topics) if topics is not None else None
        streams = [self._file_messages(i, wanted, start, end) for i in self._infos]
        if len(streams) == 1:
            yield from streams[0]
        else:
            yield from heapq.merge(*streams, key=lambda m: m.log_time_ns)

    def __repr__(self) -> str:
        return (
            f"Bag({str(self.path)!r}, {len(self.topics)} topics, {self.message_count} messages, "
            f"{self.duration_ns / 1e9:.3f} s)"
        )


_DECOMPRESS: dict[str, Callable[[bytes, int], bytes]] = {
    "": lambda data, _size: data,
    "zstd": lambda data, size: zstandard.ZstdDecompressor().decompress(data, max_output_size=size),
    "lz4": lambda data, _size: lz4.frame.decompress(data),
}


def _chunk_records(stream: Any, index: ChunkIndex) -> bytes:
    """The decompressed, CRC-checked records of the chunk `index` points at."""
    stream.seek(index.chunk_start_offset + 9)  # opcode + record length
    chunk = Chunk.read(ReadDataStream(stream))
    if chunk.compression not in _DECOMPRESS:
        raise ValueError(f"unsupported chunk compression {chunk.compression!r}")
    data = _DECOMPRESS[chunk.compression](chunk.data, chunk.uncompressed_size)
    if chunk.uncompressed_crc and zlib.crc32(data) != chunk.uncompressed_crc:
        raise ValueError("chunk CRC mismatch")
    return data


_MESSAGE_HEAD = struct.Struct("<HIQQ")  # channel id, sequence, log time, publish time
_RECORD_HEAD = struct.Struct("<BQ")
_OP_MESSAGE = 0x05


def _messages_in(records: bytes) -> Iterator[tuple[int, int, int, bytes]]:
    """(channel id, log time, publish time, data) of the Message records in a chunk."""
    pos, size = 0, len(records)
    unpack_record, unpack_message = _RECORD_HEAD.unpack_from, _MESSAGE_HEAD.unpack_from
    while pos + 9 <= size:
        op, length = unpack_record(records, pos)
        body = pos + 9
        pos = body + length
        if op == _OP_MESSAGE:
            cid, _seq, log_time, publish_time = unpack_message(records, body)
            yield cid, log_time, publish_time, records[body + 22 : pos]


def open_bag(path: str | Path) -> Bag:
    """Open a bag folder (metadata.yaml + .mcap splits, or just the splits) or one .mcap file.

    Raises InputError naming the path if it is neither.
    """
    path = Path(path)
    problem = file_problem(path)  # never blocks nor raises: a FIFO, a device, a name too long
    if problem is None:
        if path.suffix != ".mcap":
            raise InputError.at(path, None, "not an MCAP file (expected a .mcap file or a bag folder)")
        return Bag(path, [path], None)
    if problem != "a directory":
        raise InputError(f"{shown(path)}: no such bag folder or .mcap file ({problem})")
    metadata = None
    meta_path = path / "metadata.yaml"
    files: list[Path] = []
    if is_regular_file(meta_path):
        try:
            metadata = parse_yaml(read_input_text(meta_path, "metadata.yaml", errors="replace"), meta_path)
            metadata = metadata["rosbag2_bagfile_information"]
            listed = [path / p for p in metadata.get("relative_file_paths") or []]
        except (KeyError, TypeError, AttributeError, ValueError, RecursionError, OSError) as exc:
            reason = short_text(f"{type(exc).__name__}: {exc}", 200)  # an InputError (bad YAML, an alias bomb) included
            _warn(f"{shown(meta_path)}: unreadable ({reason}); using the .mcap files in the folder")
            metadata, listed = None, []
        for f in listed:
            problem = file_problem(f)
            if problem is None:
                files.append(f)
            else:
                state = "missing" if problem == "not found" else problem
                _warn(f"{meta_path}: lists {shown(f.name)}, which is {state}")
    # Splits not in metadata.yaml: the recorder was killed before it could write it.
    files += [f for f in sorted(path.glob("*.mcap"), key=_split_number) if f not in files and is_regular_file(f)]
    if not files:
        raise InputError.at(path, None, "bag folder holds no .mcap files")
    return Bag(path, files, metadata)
