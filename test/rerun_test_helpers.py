"""Helpers for the Rerun tests: write small rosbag2-style MCAP bags, read entities back from .rrd."""

from __future__ import annotations

from pathlib import Path

import pyarrow as pa
import rerun.chunk as rrc
from builtin_interfaces.msg import Time
from mcap.writer import Writer
from rclpy.serialization import serialize_message

from sim_runtime.rerun_view.logger import type_name

NS = 1_000_000_000


def stamp(t: float) -> Time:
    ns = int(round(t * NS))
    return Time(sec=ns // NS, nanosec=ns % NS)


def write_bag(path: Path, messages: list[tuple[str, object, float]]) -> Path:
    """A minimal rosbag2-style MCAP (ros2 profile, cdr) holding ``(topic, msg, t)``, t in seconds."""
    with path.open("wb") as f:
        writer = Writer(f)
        writer.start(profile="ros2", library="test")
        channels: dict[str, int] = {}
        for topic, msg, t in messages:
            if topic not in channels:
                schema = writer.register_schema(name=type_name(msg), encoding="ros2msg", data=b"")
                channels[topic] = writer.register_channel(topic=topic, message_encoding="cdr", schema_id=schema)
            ns = int(round(t * NS))
            writer.add_message(channels[topic], log_time=ns, data=serialize_message(msg), publish_time=ns)
        writer.finish()
    return path


def load_entities(rrd: Path) -> dict[str, list[pa.RecordBatch]]:
    """entity path → record batches of its chunks."""
    out: dict[str, list[pa.RecordBatch]] = {}
    for chunk in rrc.RrdReader(rrd).stream().to_chunks():
        out.setdefault(str(chunk.entity_path), []).append(chunk.to_record_batch())
    return out


def column(batches: list[pa.RecordBatch], name: str) -> list:
    values: list = []
    for b in batches:
        if name in b.schema.names:
            values += b.column(name).to_pylist()
    return values
