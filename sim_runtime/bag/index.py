"""Seek anywhere in a bag: a time index built once, then the state at any instant without rescanning.

Usage::

    from sim_runtime.bag.index import BagIndex

    index = BagIndex.open('run1')                  # bag folder or .mcap, read once
    state = index.state_at(index.start_ns + 5 * 10**9)
    state['/overhead_pose'].msg                    # the latest pose at or before t = 5 s
    index.between(t0, t1)                          # messages with t0 < log time <= t1, in order

Building the index reads only what MCAP already indexes: each chunk's ``MessageIndex`` records
(log time and offset of every message, a few bytes per message; no chunk is decompressed). A chunk
written without message indexes is decompressed once and walked by :func:`_message_records`; a file
without a summary (recorder killed) is scanned once and its messages kept in memory. A seek is then a
binary search per topic and the decompression of the few chunks holding the answer (the last ones
are kept, so stepping through neighbouring instants decompresses nothing). Works for our recorder's
bags and for any rosbag2 MCAP bag.
"""

from __future__ import annotations

import struct
import warnings
from collections import OrderedDict
from collections.abc import Iterable
from dataclasses import dataclass
from pathlib import Path
from typing import Any, BinaryIO

import numba
import numpy as np
from mcap.records import ChunkIndex, Message

from sim_runtime.bag.reader import Bag, BagMessage, _chunk_records, _FileInfo, open_bag

__all__ = ["BagIndex", "TopicIndex"]

CHUNK_CACHE = 32
"""Decompressed chunks kept (about 1 MB each): a seek touches one per topic at most."""
_OP_MESSAGE = 0x05
_OP_MESSAGE_INDEX = 0x07
_RECORD_HEAD = struct.Struct("<BQ")
_MESSAGE_HEAD = struct.Struct("<HIQQ")  # channel id, sequence, log time, publish time
_INDEX_HEAD = struct.Struct("<BQHI")  # opcode, record length, channel id, byte length of the pairs

#: While indexing: per topic, pieces of (log times, chunk table rows, record offsets).
_Parts = dict[str, list[tuple[np.ndarray, np.ndarray, np.ndarray]]]


@dataclass
class TopicIndex:
    """Where one topic's messages are: ``times`` (log time, ns, sorted), and per message the chunk
    (row of the index's chunk table) and the byte offset of its record in the chunk's records."""

    name: str
    type: str
    times: np.ndarray  # int64
    chunks: np.ndarray  # int32
    offsets: np.ndarray  # int64

    def __len__(self) -> int:
        return len(self.times)

    def at_or_before(self, t_ns: int) -> int:
        """Position of the latest message with log time ≤ ``t_ns`` (-1 if none)."""
        return int(np.searchsorted(self.times, t_ns, side="right")) - 1


@numba.njit(cache=True)
def _message_records(records: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Channel ids, log times and record offsets of the Message records in a chunk's records
    (a uint8 array): opcode (1 byte), record length (u64), then channel (u16), sequence (u32),
    log time (u64), … all little-endian."""
    size = len(records)
    channels = np.empty(size // 31 + 1, np.int64)
    times = np.empty(size // 31 + 1, np.int64)
    offsets = np.empty(size // 31 + 1, np.int64)
    n = 0
    pos = 0
    while pos + 9 <= size:
        length = np.int64(0)
        for k in range(8):
            length |= np.int64(records[pos + 1 + k]) << (8 * k)
        body = pos + 9
        if records[pos] == _OP_MESSAGE and body + 22 <= size:
            channels[n] = np.int64(records[body]) | (np.int64(records[body + 1]) << 8)
            t = np.int64(0)
            for k in range(8):
                t |= np.int64(records[body + 6 + k]) << (8 * k)
            times[n] = t
            offsets[n] = pos
            n += 1
        if length < 0 or body + length > size:
            break
        pos = body + int(length)
    return channels[:n], times[:n], offsets[:n]


class BagIndex:
    """Every message's log time and place in a bag, per topic; seek, step, read windows."""

    def __init__(self, bag: Bag) -> None:
        self.bag = bag
        self.path = bag.path
        self.topics: dict[str, str] = dict(bag.topics)
        self.start_ns = bag.start_ns
        self.end_ns = bag.end_ns
        # The chunk table: (file number, ChunkIndex) of a file's chunk, or (-1, list of inline
        # messages' bytes) for a file read by scanning.
        self._chunk_table: list[tuple[int, Any]] = []  # (file number, its ChunkIndex) or (-1, messages)
        self._cache: OrderedDict[int, bytes] = OrderedDict()
        self._streams: dict[int, BinaryIO] = {}
        parts: _Parts = {}
        for number, info in enumerate(bag._infos):
            topics_by_channel = {cid: ch.topic for cid, ch in info.channels.items()}
            if info.intact and (info.chunk_indexes or not info.counts):
                self._index_chunks(number, info, topics_by_channel, parts)
            else:
                self._index_scan(number, info, parts)
        self.by_topic: dict[str, TopicIndex] = {}
        for topic, pieces in parts.items():
            times = np.concatenate([p[0] for p in pieces])
            order = np.argsort(times, kind="stable")
            self.by_topic[topic] = TopicIndex(
                topic,
                self.topics.get(topic, ""),
                times[order],
                np.concatenate([p[1] for p in pieces])[order].astype(np.int32),
                np.concatenate([p[2] for p in pieces])[order],
            )
        self.message_count = sum(len(t) for t in self.by_topic.values())

    @classmethod
    def open(cls, path: str | Path) -> BagIndex:
        """Open a bag folder or .mcap file and index it (InputError naming the path if it is not a bag)."""
        return cls(open_bag(path))

    # ------------------------------------------------------------------ building
    def _index_chunks(self, number: int, info: _FileInfo, topics_by_channel: dict[int, str], parts: _Parts) -> None:
        stream = self._stream(number)
        for chunk_index in info.chunk_indexes:
            row = len(self._chunk_table)
            self._chunk_table.append((number, chunk_index))
            found = None
            if chunk_index.message_index_offsets and chunk_index.message_index_length:
                try:
                    found = self._message_indexes(stream, chunk_index)
                except (OSError, ValueError, struct.error):
                    found = None  # unreadable message indexes: read the chunk itself
            if found is None:
                try:
                    records = np.frombuffer(_chunk_records(stream, chunk_index), dtype=np.uint8)
                except Exception as exc:
                    warnings.warn(
                        f"{info.path}: skipping a corrupt chunk at byte {chunk_index.chunk_start_offset} ({exc})",
                        stacklevel=3,
                    )
                    continue
                channels, times, offsets = _message_records(records)
                found = {int(cid): (times[channels == cid], offsets[channels == cid]) for cid in np.unique(channels)}
            for cid, (times, offsets) in found.items():
                topic = topics_by_channel.get(cid)
                if topic is None or not len(times):
                    continue
                parts.setdefault(topic, []).append(
                    (times.astype(np.int64), np.full(len(times), row, np.int32), offsets.astype(np.int64))
                )

    @staticmethod
    def _message_indexes(stream: BinaryIO, chunk_index: ChunkIndex) -> dict[int, tuple[np.ndarray, np.ndarray]]:
        """A chunk's MessageIndex records (channel → log times, record offsets), read without
        decompressing the chunk."""
        stream.seek(chunk_index.chunk_start_offset + chunk_index.chunk_length)
        block = stream.read(chunk_index.message_index_length)
        if len(block) != chunk_index.message_index_length:
            raise ValueError("message index cut short")
        found = {}
        pos = 0
        while pos + _INDEX_HEAD.size <= len(block):
            opcode, length, channel, pairs_length = _INDEX_HEAD.unpack_from(block, pos)
            if opcode != _OP_MESSAGE_INDEX or pos + 9 + length > len(block) or pairs_length % 16:
                raise ValueError(f"not a message index record (opcode {opcode})")
            pairs = np.frombuffer(block, dtype="<u8", count=pairs_length // 8, offset=pos + _INDEX_HEAD.size)
            found[channel] = (pairs[0::2].astype(np.int64), pairs[1::2].astype(np.int64))
            pos += 9 + length
        return found

    def _index_scan(self, number: int, info: _FileInfo, parts: _Parts) -> None:
        """A file without a usable summary: read once, keep its messages' bytes."""
        row = len(self._chunk_table)
        inline: list[tuple[int, int, int, bytes]] = []  # channel, log time, publish time, data
        self._chunk_table.append((-1, inline))
        per_topic: dict[str, list[tuple[int, int]]] = {}
        for rec in self.bag._scan(info, quiet=True):
            if isinstance(rec, Message) and rec.channel_id in info.channels:
                per_topic.setdefault(info.channels[rec.channel_id].topic, []).append((rec.log_time, len(inline)))
                inline.append((rec.channel_id, rec.log_time, rec.publish_time, rec.data))
        for topic, pairs in per_topic.items():
            arr = np.array(pairs, dtype=np.int64).reshape(-1, 2)
            parts.setdefault(topic, []).append((arr[:, 0], np.full(len(arr), row, np.int32), arr[:, 1]))

    # ------------------------------------------------------------------ reading
    def _stream(self, number: int) -> BinaryIO:
        stream = self._streams.get(number)
        if stream is None:
            stream = self._streams[number] = self.bag.files[number].open("rb")
        return stream

    def close(self) -> None:
        """Close the bag's files (reading again reopens them)."""
        for stream in self._streams.values():
            stream.close()
        self._streams.clear()
        self._cache.clear()

    def __enter__(self) -> BagIndex:
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()

    def _records(self, row: int) -> bytes:
        records = self._cache.get(row)
        if records is None:
            number, chunk_index = self._chunk_table[row]
            records = _chunk_records(self._stream(number), chunk_index)
            self._cache[row] = records
            if len(self._cache) > CHUNK_CACHE:
                self._cache.popitem(last=False)
        else:
            self._cache.move_to_end(row)
        return records

    def message(self, topic: str, position: int) -> BagMessage:
        """The ``position``-th message (in log-time order) of ``topic``."""
        ti = self.by_topic[topic]
        row, offset = int(ti.chunks[position]), int(ti.offsets[position])
        number, chunk = self._chunk_table[row]
        if number < 0:
            _cid, log_time, publish_time, data = chunk[offset]
            return BagMessage(topic, ti.type, log_time, publish_time, data)
        records = self._records(row)
        opcode, length = _RECORD_HEAD.unpack_from(records, offset)
        if opcode != _OP_MESSAGE:
            raise ValueError(f"{self.path}: index points at a record of opcode {opcode}, not a message")
        _cid, _seq, log_time, publish_time = _MESSAGE_HEAD.unpack_from(records, offset + 9)
        return BagMessage(topic, ti.type, log_time, publish_time, records[offset + 31 : offset + 9 + length])

    def state_at(self, t_ns: int, topics: Iterable[str] | None = None) -> dict[str, BagMessage]:
        """The latest message of each topic with log time ≤ ``t_ns`` (topics with none are left out)."""
        state = {}
        for topic in self.by_topic if topics is None else topics:
            ti = self.by_topic.get(topic)
            if ti is None:
                continue
            i = ti.at_or_before(t_ns)
            if i >= 0:
                state[topic] = self.message(topic, i)
        return state

    def between(self, after_ns: int, until_ns: int, topics: Iterable[str] | None = None) -> list[BagMessage]:
        """Messages with ``after_ns < log time ≤ until_ns``, in log-time order (equal times as written)."""
        found = []
        for topic in self.by_topic if topics is None else topics:
            ti = self.by_topic.get(topic)
            if ti is None:
                continue
            lo = int(np.searchsorted(ti.times, after_ns, side="right"))
            hi = int(np.searchsorted(ti.times, until_ns, side="right"))
            found += [(int(ti.times[i]), int(ti.chunks[i]), int(ti.offsets[i]), topic, i) for i in range(lo, hi)]
        found.sort()  # log time, then the order written (chunk, place in it)
        return [self.message(topic, i) for *_key, topic, i in found]

    def messages(self, topic: str, start: int = 0, stop: int | None = None) -> list[BagMessage]:
        """Messages ``start:stop`` (positions in log-time order) of one topic."""
        ti = self.by_topic[topic]
        return [self.message(topic, i) for i in range(start, len(ti) if stop is None else min(stop, len(ti)))]

    def __repr__(self) -> str:
        return f"BagIndex({str(self.path)!r}, {len(self.by_topic)} topics, {self.message_count} messages)"
