"""BagWriter + reader: rosbag2-compatible files read back by independent readers, bad input."""

from __future__ import annotations

import errno
import warnings
from pathlib import Path

import numpy as np
import pytest
import yaml
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st
from mcap.reader import make_reader
from mcap_ros2.decoder import DecoderFactory
from nav_msgs.msg import Odometry
from rclpy.serialization import serialize_message
from rosbags.rosbag2 import Reader as RosbagsReader
from rosbags.typesys import Stores, get_typestore
from sensor_msgs.msg import LaserScan
from std_msgs.msg import String

from sim_runtime.bag import msgdefs
from sim_runtime.bag.reader import BagWarning, UnknownMessageType, open_bag
from sim_runtime.bag.writer import BagWriteError, BagWriter, qos_profiles_yaml
from sim_runtime.errors import InputError

TYPESTORE = get_typestore(Stores.ROS2_JAZZY)
LATCHED = qos_profiles_yaml([{"history": "keep_last", "depth": 1, "durability": "transient_local"}])
SENSOR = qos_profiles_yaml([{"reliability": "best_effort"}])


def assert_same(expected, actual, path="msg"):
    """Field-by-field equality of an rclpy message and another reader's decoded object."""
    if hasattr(expected, "get_fields_and_field_types"):
        for name in expected.get_fields_and_field_types():
            assert_same(getattr(expected, name), getattr(actual, name), f"{path}.{name}")
    elif isinstance(expected, (str, bool, int, float)):
        assert actual == expected, path
    elif len(expected) and hasattr(expected[0], "get_fields_and_field_types"):
        assert len(actual) == len(expected), path
        for i, (e, a) in enumerate(zip(expected, actual, strict=True)):
            assert_same(e, a, f"{path}[{i}]")
    else:
        np.testing.assert_array_equal(np.asarray(actual), np.asarray(expected), err_msg=path)


def assert_same_messages(got, msgs):
    """`got` BagMessages carry the messages `msgs` (from sample_messages), in order.

    Compared decoded: CDR alignment padding bytes are not deterministic, so equal messages
    may serialise to different bytes.
    """
    assert len(got) == len(msgs)
    for m, (topic, _type, _qos, msg, _t) in zip(got, msgs, strict=True):
        assert m.topic == topic
        assert_same(msg, m.msg)


def sample_messages(n=30):
    """(topic, type, qos, rclpy msg, time ns) of three kinds, 10 ms apart."""
    out = []
    for i in range(n):
        t = 1_000_000_000 + i * 10_000_000
        scan = LaserScan(angle_min=-1.0, angle_max=1.0, ranges=[float(i), float("inf"), 0.5])
        scan.header.stamp.sec, scan.header.frame_id = i, "laser"
        odom = Odometry(child_frame_id="base_link")
        odom.pose.pose.position.x = 0.1 * i
        odom.pose.covariance[0] = float(i)
        kind = i % 3
        out.append(
            [
                ("/chatter", "std_msgs/msg/String", LATCHED, String(data=f"hello {i}")),
                ("/scan", "sensor_msgs/msg/LaserScan", SENSOR, scan),
                ("/odom", "nav_msgs/msg/Odometry", qos_profiles_yaml([{}]), odom),
            ][kind]
            + (t,)
        )
    return out


def write_bag(folder, messages, **kw):
    with BagWriter(folder, **kw) as w:
        ids = {}
        for topic, type_name, qos, msg, t in messages:
            if topic not in ids:
                ids[topic] = w.add_topic(topic, type_name, qos, "RIHS01_" + "0" * 64)
            w.write(ids[topic], t, serialize_message(msg))
    return w


@pytest.mark.parametrize("compression", ["zstd", "lz4", "none"])
def test_independent_readers_decode_every_message(tmp_path, compression):
    msgs = sample_messages()
    write_bag(tmp_path / "bag", msgs, compression=compression)

    with RosbagsReader(tmp_path / "bag") as reader:
        got = [(c.topic, TYPESTORE.deserialize_cdr(raw, c.msgtype), t) for c, t, raw in reader.messages()]
    assert len(got) == len(msgs)
    for (topic, _ty, _q, msg, t), (gtopic, gmsg, gt) in zip(msgs, got, strict=True):
        assert (gtopic, gt) == (topic, t)
        assert_same(msg, gmsg)

    decoded = []
    for f in sorted((tmp_path / "bag").glob("*.mcap")):
        with f.open("rb") as stream:
            mcap = make_reader(stream, decoder_factories=[DecoderFactory()])
            assert mcap.get_header().profile == "ros2"
            summary = mcap.get_summary()
            assert summary.statistics.message_count == len(msgs)
            assert summary.chunk_indexes and all(ci.message_index_offsets for ci in summary.chunk_indexes)
            assert {s.encoding for s in summary.schemas.values()} == {"ros2msg"}
            assert {c.message_encoding for c in summary.channels.values()} == {"cdr"}
            expected_compression = {"none": ""}.get(compression, compression)
            assert {ci.compression for ci in summary.chunk_indexes} == {expected_compression}
            decoded += [(c.topic, d) for _s, c, _m, d in mcap.iter_decoded_messages()]
    for (topic, _ty, _q, msg, _t), (dtopic, dmsg) in zip(msgs, decoded, strict=True):
        assert dtopic == topic
        assert_same(msg, dmsg)


def test_schema_is_full_definition_like_rosbag2(tmp_path):
    write_bag(tmp_path / "bag", sample_messages(3))
    with (tmp_path / "bag" / "bag_0.mcap").open("rb") as stream:
        schemas = {s.name: s.data.decode() for s in make_reader(stream).get_summary().schemas.values()}
    odom = schemas["nav_msgs/msg/Odometry"]
    assert odom.startswith("# This represents an estimate of a position and velocity")
    sep = "=" * 80 + "\nMSG: "
    deps = [part.split("\n", 1)[0] for part in odom.split(sep)[1:]]
    assert sorted(deps) == sorted(set(deps))  # each dependency once
    assert {
        "std_msgs/Header",
        "builtin_interfaces/Time",
        "geometry_msgs/PoseWithCovariance",
        "geometry_msgs/Quaternion",
        "geometry_msgs/Vector3",
    } <= set(deps)


def test_metadata_yaml_matches_channels_and_counts(tmp_path):
    msgs = sample_messages(30)
    write_bag(tmp_path / "bag", msgs)
    info = yaml.safe_load((tmp_path / "bag" / "metadata.yaml").read_text())["rosbag2_bagfile_information"]
    assert info["version"] == 9 and info["storage_identifier"] == "mcap"
    assert info["message_count"] == 30
    assert info["relative_file_paths"] == ["bag_0.mcap"]
    assert info["starting_time"]["nanoseconds_since_epoch"] == msgs[0][4]
    assert info["duration"]["nanoseconds"] == msgs[-1][4] - msgs[0][4]
    with (tmp_path / "bag" / "bag_0.mcap").open("rb") as stream:
        channels = {c.topic: c.metadata for c in make_reader(stream).get_summary().channels.values()}
    for entry in info["topics_with_message_count"]:
        meta = entry["topic_metadata"]
        assert entry["message_count"] == 10
        assert meta["offered_qos_profiles"] == yaml.safe_load(channels[meta["name"]]["offered_qos_profiles"])
        assert meta["type_description_hash"] == channels[meta["name"]]["topic_type_hash"]
    latched = next(e for e in info["topics_with_message_count"] if e["topic_metadata"]["name"] == "/chatter")
    assert latched["topic_metadata"]["offered_qos_profiles"][0]["durability"] == "transient_local"


def test_existing_output_is_never_overwritten(tmp_path):
    (tmp_path / "bag").mkdir()
    (tmp_path / "bag" / "keep.txt").write_text("precious")
    with pytest.raises(InputError, match="exists"):
        BagWriter(tmp_path / "bag")
    assert (tmp_path / "bag" / "keep.txt").read_text() == "precious"


def test_split_by_duration_and_size(tmp_path):
    msgs = sample_messages(30)  # 0.29 s of messages
    write_bag(tmp_path / "dur", msgs, max_bag_duration_ns=100_000_000)
    write_bag(tmp_path / "size", msgs, max_bag_size=500)
    for name in ("dur", "size"):
        bag = open_bag(tmp_path / name)
        assert len(bag.files) >= 3
        info = yaml.safe_load((tmp_path / name / "metadata.yaml").read_text())["rosbag2_bagfile_information"]
        assert info["relative_file_paths"] == [f.name for f in bag.files]
        assert sum(f["message_count"] for f in info["files"]) == 30
        assert_same_messages(list(bag.messages()), msgs)
        with RosbagsReader(tmp_path / name) as reader:
            assert sum(1 for _ in reader.messages()) == 30


def test_reader_time_and_topic_filters(tmp_path):
    msgs = sample_messages(30)
    write_bag(tmp_path / "bag", msgs)
    bag = open_bag(tmp_path / "bag")
    assert bag.topics == {
        "/chatter": "std_msgs/msg/String",
        "/scan": "sensor_msgs/msg/LaserScan",
        "/odom": "nav_msgs/msg/Odometry",
    }
    assert (bag.start_ns, bag.end_ns, bag.message_count) == (msgs[0][4], msgs[-1][4], 30)
    got = list(bag.messages(topics=["/scan"], start=msgs[3][4], end=msgs[12][4]))
    assert [m.log_time_ns for m in got] == [msgs[i][4] for i in (4, 7, 10)]
    assert list(got[0].msg.ranges)[:1] == [4.0]
    assert open_bag(tmp_path / "bag" / "bag_0.mcap").message_count == 30


@settings(max_examples=25, deadline=None, suppress_health_check=[HealthCheck.function_scoped_fixture])
@given(cut=st.floats(0.05, 0.999))
def test_truncated_file_reads_the_intact_prefix(tmp_path_factory, cut):
    folder = tmp_path_factory.mktemp("trunc") / "bag"
    msgs = sample_messages(60)
    # chunks close every few messages, so most cuts leave complete chunks behind
    write_bag(folder, msgs, chunk_size=400, compression="none")
    path = folder / "bag_0.mcap"
    data = path.read_bytes()
    path.write_bytes(data[: int(len(data) * cut)])
    with pytest.warns(BagWarning, match=r"bag_0\.mcap"):  # noqa: PT031 - opening or reading finds the cut
        bag = open_bag(folder)
        got = list(bag.messages())
    assert_same_messages(got, msgs[: len(got)])
    assert bag.message_count == len(got)


def test_corrupt_chunk_is_skipped_with_a_warning(tmp_path):
    msgs = sample_messages(60)
    write_bag(tmp_path / "bag", msgs, chunk_size=400, compression="zstd")
    path = tmp_path / "bag" / "bag_0.mcap"
    with path.open("rb") as stream:
        chunk = make_reader(stream).get_summary().chunk_indexes[2]
    data = bytearray(path.read_bytes())
    middle = chunk.chunk_start_offset + chunk.chunk_length // 2
    data[middle : middle + 8] = b"\xff" * 8
    path.write_bytes(bytes(data))
    with pytest.warns(BagWarning, match="corrupt"):
        got = list(open_bag(tmp_path / "bag").messages())
    assert 0 < len(got) < len(msgs)
    by_time = {m[4]: m for m in msgs}
    assert_same_messages(got, [by_time[m.log_time_ns] for m in got])
    assert got[0].log_time_ns == msgs[0][4] and got[-1].log_time_ns == msgs[-1][4]


def test_not_a_bag_is_a_clear_error(tmp_path):
    with pytest.raises(InputError, match="no such bag"):
        open_bag(tmp_path / "missing")
    (tmp_path / "empty").mkdir()
    with pytest.raises(InputError, match=r"no \.mcap"):
        open_bag(tmp_path / "empty")
    junk = tmp_path / "junk.mcap"
    junk.write_bytes(b"not an mcap file at all")
    with pytest.warns(BagWarning, match="junk.mcap"):
        assert open_bag(junk).message_count == 0


def test_unknown_type_names_type_and_topic(tmp_path):
    with BagWriter(tmp_path / "bag") as w:
        tid = w.add_topic("/weird", "foo_msgs/msg/Bar", qos_profiles_yaml([{}]))
        assert w.missing_definitions(tid) == ("foo_msgs/msg/Bar",)
        w.write(tid, 5, b"\x00\x01\x00\x00abcd")
    (m,) = open_bag(tmp_path / "bag").messages()
    assert m.topic == "/weird" and m.type == "foo_msgs/msg/Bar"
    with pytest.raises(UnknownMessageType, match=r"'/weird'.*foo_msgs/msg/Bar"):
        _ = m.msg


def test_missing_msg_files_record_what_is_available(tmp_path, monkeypatch):
    """Only Odometry.msg installed: its text is kept, the other types are rebuilt from the
    Python classes (fields only), and an independent decoder still decodes the messages."""
    prefix = tmp_path / "prefix"
    src = next(p for p in msgdefs.share_prefixes() if (p / "share/nav_msgs/msg/Odometry.msg").is_file())
    (prefix / "share/nav_msgs/msg").mkdir(parents=True)
    (prefix / "share/nav_msgs/msg/Odometry.msg").write_text((src / "share/nav_msgs/msg/Odometry.msg").read_text())
    monkeypatch.setattr(msgdefs, "share_prefixes", lambda: [prefix])
    msgdefs.full_definition.cache_clear()
    msgdefs._msg_text.cache_clear()
    odom = Odometry(child_frame_id="b")
    odom.pose.pose.orientation.w = 0.5
    odom.twist.covariance[35] = 7.0
    try:
        with BagWriter(tmp_path / "bag") as w:
            tid = w.add_topic("/odom", "nav_msgs/msg/Odometry", qos_profiles_yaml([{}]))
            assert {"std_msgs/Header", "geometry_msgs/PoseWithCovariance", "builtin_interfaces/Time"} <= set(
                w.missing_definitions(tid)
            )
            w.write(tid, 1, serialize_message(odom))
    finally:
        msgdefs.full_definition.cache_clear()
        msgdefs._msg_text.cache_clear()
    (m,) = open_bag(tmp_path / "bag").messages()
    assert m.msg.child_frame_id == "b"
    with (tmp_path / "bag" / "bag_0.mcap").open("rb") as stream:
        reader = make_reader(stream, decoder_factories=[DecoderFactory()])
        (schema,) = reader.get_summary().schemas.values()
        ((_s, _c, _m, decoded),) = reader.iter_decoded_messages()
    assert schema.data.decode().startswith("# This represents an estimate")
    assert "\nMSG: geometry_msgs/Quaternion\nfloat64 x\n" in schema.data.decode()
    assert_same(odom, decoded)


class FullDisk:
    """A binary file that accepts `capacity` bytes, then fails like a full disk."""

    def __init__(self, path: Path, capacity: int) -> None:
        self._file = path.open("wb")
        self._left = capacity

    def write(self, data):
        n = min(len(data), self._left)
        self._file.write(bytes(data[:n]))
        self._left -= n
        if n < len(data):
            self._file.flush()
            raise OSError(errno.ENOSPC, "No space left on device")
        return n

    def tell(self):
        return self._file.tell()

    def flush(self):
        self._file.flush()

    def close(self):
        self._file.close()


def test_disk_full_stops_cleanly_and_leaves_a_readable_bag(tmp_path):
    msgs = sample_messages(200)
    w = BagWriter(tmp_path / "bag", compression="none", chunk_size=300, open_stream=lambda p: FullDisk(p, 6000))
    ids = {}
    written = 0

    def write_all() -> None:
        nonlocal written
        for topic, type_name, qos, msg, t in msgs:
            if topic not in ids:
                ids[topic] = w.add_topic(topic, type_name, qos)
            w.write(ids[topic], t, serialize_message(msg))
            written += 1

    with pytest.raises(BagWriteError, match="No space left"):
        write_all()
    assert w.error is not None and written < len(msgs)
    w.close()  # no exception: the bag is left as flushed
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", BagWarning)
        bag = open_bag(tmp_path / "bag")
        got = list(bag.messages())
    assert 0 < len(got) <= written
    assert_same_messages(got, msgs[: len(got)])
    info = yaml.safe_load((tmp_path / "bag" / "metadata.yaml").read_text())["rosbag2_bagfile_information"]
    assert info["message_count"] == len(got)
