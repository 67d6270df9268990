"""Write rosbag2 bag folders (MCAP storage, metadata.yaml version 9); no rclpy needed.

`BagWriter` is what `robot_sims record` writes with; it is also usable on its own::

    from sim_runtime.bag.writer import BagWriter, qos_profiles_yaml

    with BagWriter('out_bag', compression='zstd') as bag:
        tid = bag.add_topic('/chatter', 'std_msgs/msg/String', qos_profiles_yaml([{}]))
        bag.write(tid, log_time_ns, cdr_bytes)

Layout (as `ros2 bag record -s mcap`): folder `NAME/` holding `NAME_0.mcap`, `NAME_1.mcap`, …
(a new split when `max_bag_size` bytes or `max_bag_duration_ns` is exceeded) and, when the
writer is closed, `metadata.yaml`. Each `.mcap` has profile ``ros2``, one ``ros2msg`` schema per
type holding the full definition, ``cdr`` channels with metadata ``offered_qos_profiles`` and
``topic_type_hash``, chunks with message indexes, and a summary with statistics and chunk
indexes. The open chunk is closed and flushed to the OS at least every `flush_interval` seconds
so a killed recorder loses at most that much. A write that fails (disk full) raises
`BagWriteError`; `close()` then still leaves everything flushed so far readable.
"""

from __future__ import annotations

import contextlib
import time
from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import IO, Any

import yaml
from mcap.writer import CompressionType, Writer

from sim_runtime.bag.mcapfile import McapFile
from sim_runtime.bag.msgdefs import full_definition
from sim_runtime.errors import InputError

__all__ = [
    "BagWriteError",
    "BagWriter",
    "qos_profiles_yaml",
    "reindex",
    "write_metadata_from_files",
]

METADATA_VERSION = 9
ROS_DISTRO = "jazzy"
_LIBRARY = "robot_sims.bag"
_INFINITE_NS = 2**63 - 1
_COMPRESSION = {"zstd": "zstd", "lz4": "lz4", "none": ""}

#: Defaults for a QoS profile dict (rosbag2's "offered QoS" fields, Jazzy enum strings).
QOS_DEFAULTS: dict[str, Any] = {
    "history": "unknown",
    "depth": 0,
    "reliability": "reliable",
    "durability": "volatile",
    "deadline": _INFINITE_NS,
    "lifespan": _INFINITE_NS,
    "liveliness": "automatic",
    "liveliness_lease_duration": _INFINITE_NS,
    "avoid_ros_namespace_conventions": False,
}


class BagWriteError(OSError):
    """Writing the bag failed (disk full, permissions); the bag holds what was flushed before."""


def _duration_yaml(ns: int, indent: str) -> str:
    return f"{indent}  sec: {ns // 1_000_000_000}\n{indent}  nsec: {ns % 1_000_000_000}\n"


def qos_profiles_yaml(profiles: Sequence[Mapping[str, Any]]) -> str:
    """`offered_qos_profiles` YAML text as rosbag2 Jazzy (yaml-cpp, version 9) writes it.

    Each profile is a dict of QOS_DEFAULTS keys (missing keys take the defaults); durations
    are nanoseconds (2**63-1 = infinite).
    """
    lines = []
    for given in profiles:
        p = {**QOS_DEFAULTS, **given}
        lines.append(
            f"- history: {p['history']}\n"
            f"  depth: {int(p['depth'])}\n"
            f"  reliability: {p['reliability']}\n"
            f"  durability: {p['durability']}\n"
            f"  deadline:\n{_duration_yaml(int(p['deadline']), '  ')}"
            f"  lifespan:\n{_duration_yaml(int(p['lifespan']), '  ')}"
            f"  liveliness: {p['liveliness']}\n"
            f"  liveliness_lease_duration:\n"
            f"{_duration_yaml(int(p['liveliness_lease_duration']), '  ')}"
            f"  avoid_ros_namespace_conventions: {'true' if p['avoid_ros_namespace_conventions'] else 'false'}"
        )
    return "\n".join(lines)


@dataclass
class _Topic:
    name: str
    type: str
    qos_yaml: str
    type_hash: str
    schema_text: str
    message_count: int = 0


@dataclass
class _FileStats:
    path: str
    start_ns: int | None = None
    end_ns: int | None = None
    message_count: int = 0


class BagWriter:
    """A rosbag2 bag folder being written (see module docstring).

    `open_stream(path)` opens each split for binary writing (default: a plain file); tests
    pass a stream that fails after N bytes to simulate a full disk.
    """

    def __init__(
        self,
        folder: str | Path,
        *,
        compression: str = "zstd",
        max_bag_size: int = 0,
        max_bag_duration_ns: int = 0,
        chunk_size: int = 1024 * 1024,
        flush_interval: float = 0.5,
        open_stream: Callable[[Path], IO[bytes]] | None = None,
        clock: Callable[[], float] = time.monotonic,
    ) -> None:
        self.folder = Path(folder)
        if compression not in _COMPRESSION:
            raise InputError(f"compression {compression!r} is not one of {', '.join(_COMPRESSION)}")
        if max_bag_size < 0 or max_bag_duration_ns < 0:
            raise InputError(f"max bag size ({max_bag_size}) and duration ({max_bag_duration_ns}) must be ≥ 0")
        if self.folder.exists():
            raise InputError.at(self.folder, None, "output folder exists; refusing to overwrite it")
        self.folder.mkdir(parents=True)
        self._compression = _COMPRESSION[compression]
        self._max_size = max_bag_size
        self._max_duration = max_bag_duration_ns
        self._chunk_size = chunk_size
        self._flush_interval = flush_interval
        self._open_stream = open_stream or (lambda p: p.open("wb"))
        self._clock = clock
        self._topics: list[_Topic] = []
        self._missing: dict[int, tuple[str, ...]] = {}
        self._files: list[_FileStats] = []
        self._writer: McapFile | None = None
        self._stream: IO[bytes] | None = None
        self._channel_ids: dict[int, int] = {}  # topic id -> channel id in the current split
        self._schema_ids: dict[str, int] = {}
        self._bytes_in_file = 0
        self._last_flush = clock()
        self._closed = False
        #: set when a write failed: nothing more is written
        self.error: BagWriteError | None = None
        self._guard(self._open_split)  # even a bag that records nothing is a valid bag

    # -- topics and messages -------------------------------------------------------------

    def add_topic(self, name: str, type_name: str, qos_yaml: str, type_hash: str = "") -> int:
        """Register a topic; returns the id to `write` with. Schema text from installed `.msg`.

        `Definition.missing` of the schema is available as `missing_definitions(id)` so the
        caller can warn about types recorded with an incomplete schema.
        """
        definition = full_definition(type_name)
        self._topics.append(_Topic(name, type_name, qos_yaml, type_hash, definition.text))
        tid = len(self._topics) - 1
        self._missing[tid] = definition.missing
        if self.error is None:
            self._guard(self._register, tid)
        return tid

    def missing_definitions(self, topic_id: int) -> tuple[str, ...]:
        """Types of this topic's schema whose `.msg` was not found (empty = complete)."""
        return self._missing.get(topic_id, ())

    def write(self, topic_id: int, log_time_ns: int, data: bytes, publish_time_ns: int | None = None) -> None:
        """Append one CDR-serialised message; raises BagWriteError if the disk refuses it."""
        if self.error is not None:
            raise self.error
        stats = self._files[-1]
        if stats.message_count and (
            (self._max_size and self._bytes_in_file >= self._max_size)
            or (
                self._max_duration and stats.start_ns is not None and log_time_ns - stats.start_ns >= self._max_duration
            )
        ):
            self._guard(self._next_split)
            stats = self._files[-1]
        try:
            self._writer.add_message(  # type: ignore[union-attr]
                self._channel_ids[topic_id],
                log_time_ns,
                log_time_ns if publish_time_ns is None else publish_time_ns,
                data,
            )
        except OSError as exc:
            self._fail(exc)
        self._bytes_in_file += len(data) + 47  # message record + index entry
        self._topics[topic_id].message_count += 1
        if stats.start_ns is None or stats.end_ns is None:  # the split's first message
            stats.start_ns = stats.end_ns = log_time_ns
        elif log_time_ns < stats.start_ns:
            stats.start_ns = log_time_ns
        elif log_time_ns > stats.end_ns:
            stats.end_ns = log_time_ns
        stats.message_count += 1
        if self._clock() - self._last_flush >= self._flush_interval:
            self.flush()

    def flush(self) -> None:
        """Close the open chunk and hand everything to the OS (crash safety point)."""
        self._last_flush = self._clock()
        if self._writer is not None and self.error is None:
            self._guard(self._writer.flush)

    def maybe_flush(self) -> None:
        """`flush` if the last one is older than `flush_interval` (call from a timer)."""
        if self._clock() - self._last_flush >= self._flush_interval:
            self.flush()

    @property
    def message_count(self) -> int:
        """Messages written so far, all topics."""
        return sum(t.message_count for t in self._topics)

    def topic_message_count(self, topic_id: int) -> int:
        """Messages written so far on one topic (an id from :meth:`add_topic`)."""
        return self._topics[topic_id].message_count

    @property
    def files(self) -> list[Path]:
        return [self.folder / f.path for f in self._files]

    # -- splits ------------------------------------------------------------------------------

    def _guard(self, fn: Callable[..., Any], *args: Any) -> Any:
        try:
            return fn(*args)
        except OSError as exc:
            self._fail(exc)

    def _fail(self, exc: OSError) -> None:
        self.error = BagWriteError(exc.errno, f"writing bag {self.folder} failed: {exc.strerror or exc}")
        raise self.error from exc

    def _open_split(self) -> None:
        name = f"{self.folder.name}_{len(self._files)}.mcap"
        self._files.append(_FileStats(name))
        self._stream = self._open_stream(self.folder / name)
        self._writer = McapFile(
            self._stream,
            profile="ros2",
            library=_LIBRARY,
            compression=self._compression,
            chunk_size=self._chunk_size,
        )
        self._schema_ids = {}
        self._channel_ids = {}
        self._bytes_in_file = 0
        for tid in range(len(self._topics)):
            self._register(tid)

    def _register(self, tid: int) -> None:
        topic = self._topics[tid]
        assert self._writer is not None
        schema_id = self._schema_ids.get(topic.type)
        if schema_id is None:
            schema_id = self._writer.add_schema(topic.type, "ros2msg", topic.schema_text.encode())
            self._schema_ids[topic.type] = schema_id
        self._channel_ids[tid] = self._writer.add_channel(
            topic.name,
            "cdr",
            schema_id,
            {"offered_qos_profiles": topic.qos_yaml, "topic_type_hash": topic.type_hash},
        )

    def _finish_split(self) -> None:
        writer, stream = self._writer, self._stream
        self._writer = self._stream = None
        if writer is None or stream is None:
            return
        try:
            writer.add_metadata(
                "rosbag2",
                {"serialized_metadata": self._metadata_yaml(), "ros_distro": ROS_DISTRO},
            )
            writer.finish()
        finally:
            stream.close()

    def _next_split(self) -> None:
        self._finish_split()
        self._open_split()

    # -- closing -----------------------------------------------------------------------------

    def close(self) -> None:
        """Finish the current split (footer, summary) and write metadata.yaml.

        After a failed write the split is left as flushed (readable up to its last complete
        chunk) and metadata.yaml is rebuilt from what the files actually hold.
        """
        if self._closed:
            return
        self._closed = True
        if self.error is None:
            try:
                self._finish_split()
            except OSError as exc:
                self.error = BagWriteError(exc.errno, f"finishing bag {self.folder} failed: {exc}")
        else:
            stream, self._writer, self._stream = self._stream, None, None
            if stream is not None:
                with contextlib.suppress(OSError):
                    stream.close()
        if self.error is None:
            (self.folder / "metadata.yaml").write_text(self._metadata_yaml())
        else:
            write_metadata_from_files(self.folder)

    def __enter__(self) -> BagWriter:
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()

    def _metadata_yaml(self) -> str:
        return metadata_yaml(
            [(t.name, t.type, t.qos_yaml, t.type_hash, t.message_count) for t in self._topics],
            [(f.path, f.start_ns, f.end_ns, f.message_count) for f in self._files],
        )


def metadata_yaml(
    topics: Sequence[tuple[str, str, str, str, int]],
    files: Sequence[tuple[str, int | None, int | None, int]],
) -> str:
    """metadata.yaml text (rosbag2_bagfile_information version 9, storage mcap).

    `topics`: (name, type, offered_qos_profiles YAML, type hash, message count);
    `files`: (relative path, first log time, last log time, message count).
    """
    starts = [s for _p, s, _e, _n in files if s is not None]
    ends = [e for _p, _s, e, _n in files if e is not None]
    start = min(starts) if starts else 0
    info = {
        "version": METADATA_VERSION,
        "storage_identifier": "mcap",
        "duration": {"nanoseconds": (max(ends) - start) if ends else 0},
        "starting_time": {"nanoseconds_since_epoch": start},
        "message_count": sum(n for *_x, n in files),
        "topics_with_message_count": [
            {
                "topic_metadata": {
                    "name": name,
                    "type": type_name,
                    "serialization_format": "cdr",
                    # The same profiles as the channel metadata: readers (rosbags) match
                    # metadata.yaml topics to MCAP channels on them.
                    "offered_qos_profiles": yaml.safe_load(qos) or [],
                    "type_description_hash": type_hash,
                },
                "message_count": count,
            }
            for name, type_name, qos, type_hash, count in topics
        ],
        # Chunk compression is internal to MCAP; rosbag2 fills these only for its own
        # file/message compression, which we do not use.
        "compression_format": "",
        "compression_mode": "",
        "relative_file_paths": [p for p, *_x in files],
        "files": [
            {
                "path": p,
                "starting_time": {"nanoseconds_since_epoch": s or 0},
                "duration": {"nanoseconds": (e - s) if s is not None and e is not None else 0},
                "message_count": n,
            }
            for p, s, e, n in files
        ],
        "custom_data": None,
        "ros_distro": ROS_DISTRO,
    }
    text: str = yaml.safe_dump({"rosbag2_bagfile_information": info}, sort_keys=False, default_flow_style=False)
    return text


def _recover_split(path: Path, bag: Any, info: Any) -> None:
    """Rewrite an unfinished split as a finished MCAP file holding its intact messages."""
    from mcap.records import Message

    tmp = path.with_suffix(".mcap.recovering")
    with tmp.open("wb") as stream:
        writer = Writer(stream, compression=CompressionType.ZSTD)
        writer.start(profile="ros2", library=_LIBRARY)
        schema_ids: dict[int, int] = {}
        channel_ids: dict[int, int] = {}
        for rec in bag._scan(info, quiet=True):
            if not isinstance(rec, Message) or rec.channel_id not in info.channels:
                continue
            if rec.channel_id not in channel_ids:
                channel = info.channels[rec.channel_id]
                schema = info.schemas.get(channel.schema_id)
                if schema is not None and schema.id not in schema_ids:
                    schema_ids[schema.id] = writer.register_schema(schema.name, schema.encoding, schema.data)
                channel_ids[rec.channel_id] = writer.register_channel(
                    channel.topic,
                    channel.message_encoding,
                    schema_ids.get(channel.schema_id, 0),
                    dict(channel.metadata),
                )
            writer.add_message(channel_ids[rec.channel_id], rec.log_time, rec.data, rec.publish_time, rec.sequence)
        writer.finish()
    tmp.replace(path)


def reindex(folder: str | Path) -> Path:
    """Make a bag whose recorder was killed (or ran out of disk) whole again.

    Unfinished .mcap splits are rewritten with the messages that are intact (like
    `mcap recover`), then metadata.yaml is rebuilt from the files (like `ros2 bag reindex`),
    so every reader, rosbag2 and `rosbags` included, opens the bag.
    """
    import warnings

    from sim_runtime.bag.reader import BagWarning, open_bag

    folder = Path(folder)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", BagWarning)
        bag = open_bag(folder)
        for info in bag._infos:
            if not info.intact:
                _recover_split(info.path, bag, info)
        return write_metadata_from_files(folder)


def write_metadata_from_files(folder: str | Path) -> Path:
    """(Re)build `folder/metadata.yaml` from the .mcap splits (like `ros2 bag reindex`).

    For a folder whose recorder was killed or ran out of disk: counts what is readable.
    """
    import warnings

    from sim_runtime.bag.reader import BagWarning, open_bag

    folder = Path(folder)
    meta = folder / "metadata.yaml"
    meta.unlink(missing_ok=True)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", BagWarning)
        bag = open_bag(folder)
        topics = []
        for name, type_name in bag.topics.items():
            chmeta = bag.topic_metadata.get(name, {})
            topics.append(
                (
                    name,
                    type_name,
                    chmeta.get("offered_qos_profiles", ""),
                    chmeta.get("topic_type_hash", ""),
                    bag.topic_counts.get(name, 0),
                )
            )
        files = []
        for info in bag._infos:
            files.append(
                (
                    info.path.name,
                    info.start_ns,
                    info.end_ns,
                    sum(info.counts.values()),
                )
            )
    meta.write_text(metadata_yaml(topics, files))
    return meta
