"""The recorder node: what it records, in-process and as `robot_sims record` in a subprocess."""

from __future__ import annotations

import os
import signal
import subprocess
import sys
import time
import warnings
from pathlib import Path

import pytest
import yaml
from mcap.reader import make_reader
from rclpy.duration import Duration
from rclpy.qos import qos_profile_sensor_data
from rclpy.serialization import serialize_message
from rosbags.rosbag2 import Reader as RosbagsReader
from rosbags.typesys import Stores, get_typestore
from rosgraph_msgs.msg import Clock
from sensor_msgs.msg import LaserScan
from std_msgs.msg import String
from std_srvs.srv import Trigger

from sim_runtime.bag.reader import BagWarning, open_bag
from sim_runtime.bag.record import Recorder
from sim_runtime.bag.writer import BagWriter, qos_profiles_yaml
from sim_runtime.qos import COMMAND_PUBLISHER_QOS, LATCHED_QOS
from sim_runtime.testing import Collector, spin_until, wait_for_match

ROOT = Path(__file__).resolve().parent.parent
TYPESTORE = get_typestore(Stores.ROS2_JAZZY)


def scan(i: int) -> LaserScan:
    msg = LaserScan(range_min=0.1, range_max=5.0, ranges=[0.5 + i, float("inf"), -float("inf")])
    msg.header.frame_id = "laser"
    msg.header.stamp.sec = i
    return msg


def start_recorder(executor, folder, topics, **kw):
    recorder = Recorder(BagWriter(folder), topics, node_name=f"recorder_{os.getpid()}_{time.monotonic_ns()}", **kw)
    executor.add_node(recorder)
    return recorder


def test_records_every_message_with_publisher_qos(executor, make_node, tmp_path):
    node = make_node("talker")
    chatter = node.create_publisher(String, "/rec_test/chatter", COMMAND_PUBLISHER_QOS)
    scans = node.create_publisher(LaserScan, "/rec_test/scan", qos_profile_sensor_data)
    latched = node.create_publisher(String, "/rec_test/map", LATCHED_QOS)
    latched.publish(String(data="the map"))  # before the recorder exists: latched
    recorder = start_recorder(executor, tmp_path / "bag", ["/rec_test/.*"])
    for pub in (chatter, scans, latched):
        assert wait_for_match(executor, pub)
    for i in range(50):
        chatter.publish(String(data=f"msg {i}"))
        scans.publish(scan(i))
    assert spin_until(executor, lambda: recorder.writer.message_count >= 101)
    recorder.close()
    executor.remove_node(recorder)
    recorder.destroy_node()

    with RosbagsReader(tmp_path / "bag") as reader:
        got: dict[str, list] = {}
        for conn, _t, raw in reader.messages():
            got.setdefault(conn.topic, []).append(TYPESTORE.deserialize_cdr(raw, conn.msgtype))
        qos = {c.topic: c.ext.offered_qos_profiles[0] for c in reader.connections}
    assert [m.data for m in got["/rec_test/chatter"]] == [f"msg {i}" for i in range(50)]
    assert [m.data for m in got["/rec_test/map"]] == ["the map"]
    assert [list(m.ranges) for m in got["/rec_test/scan"]] == [
        [0.5 + i, float("inf"), -float("inf")] for i in range(50)
    ]
    assert [m.header.stamp.sec for m in got["/rec_test/scan"]] == list(range(50))
    assert qos["/rec_test/scan"].reliability.name == "BEST_EFFORT"
    assert qos["/rec_test/map"].durability.name == "TRANSIENT_LOCAL"
    assert qos["/rec_test/chatter"].reliability.name == "RELIABLE"

    bag = open_bag(tmp_path / "bag")
    assert bag.topics["/rec_test/scan"] == "sensor_msgs/msg/LaserScan"
    assert bag.topic_metadata["/rec_test/scan"]["topic_type_hash"].startswith("RIHS01_")
    info = yaml.safe_load((tmp_path / "bag" / "metadata.yaml").read_text())["rosbag2_bagfile_information"]
    for entry in info["topics_with_message_count"]:
        meta = entry["topic_metadata"]
        assert meta["offered_qos_profiles"] == yaml.safe_load(bag.topic_metadata[meta["name"]]["offered_qos_profiles"])


def test_topics_appearing_later_and_exclude(executor, make_node, tmp_path):
    recorder = start_recorder(executor, tmp_path / "bag", ["/late_test/.*"], exclude=".*/secret")
    node = make_node("late")
    pub = node.create_publisher(String, "/late_test/hello", 10)
    secret = node.create_publisher(String, "/late_test/secret", 10)
    assert wait_for_match(executor, pub)
    pub.publish(String(data="hi"))
    secret.publish(String(data="hidden"))
    assert spin_until(executor, lambda: recorder.writer.message_count >= 1)
    recorder.close()
    bag = open_bag(tmp_path / "bag")
    assert set(bag.topics) == {"/late_test/hello"}
    assert [m.msg.data for m in bag.messages()] == ["hi"]
    assert secret.get_subscription_count() == 0


def test_sim_time_from_clock(executor, make_node, tmp_path):
    node = make_node("sim")
    clock = node.create_publisher(Clock, "/clock", 10)
    pub = node.create_publisher(String, "/sim_test/data", 10)
    recorder = start_recorder(executor, tmp_path / "bag", ["/sim_test/data"])
    assert wait_for_match(executor, pub) and wait_for_match(executor, clock)
    for i in range(5):
        tick = Clock()
        tick.clock.sec, tick.clock.nanosec = 100 + i, 250_000_000
        clock.publish(tick)
        assert spin_until(executor, lambda i=i: recorder._sim_ns == (100 + i) * 10**9 + 250_000_000)
        pub.publish(String(data=str(i)))
        assert spin_until(executor, lambda i=i: recorder.writer.message_count == i + 1)
    recorder.close()
    times = [m.log_time_ns for m in open_bag(tmp_path / "bag").messages()]
    assert times == [(100 + i) * 10**9 + 250_000_000 for i in range(5)]


def test_disk_full_stops_the_recorder_cleanly(executor, make_node, tmp_path):
    from test_bag_writer import FullDisk

    node = make_node("full")
    pub = node.create_publisher(String, "/full_test/data", 100)
    writer = BagWriter(tmp_path / "bag", compression="none", chunk_size=200, open_stream=lambda p: FullDisk(p, 3000))
    recorder = Recorder(writer, ["/full_test/data"], node_name="full_recorder")
    executor.add_node(recorder)
    assert wait_for_match(executor, pub)
    for i in range(300):
        pub.publish(String(data=f"payload {i:04d} " + "x" * 40))
        executor.spin_once(timeout_sec=0)
    assert spin_until(executor, lambda: recorder.done.done())
    assert "No space left" in str(recorder.error)
    assert pub.get_subscription_count() == 0 or spin_until(executor, lambda: pub.get_subscription_count() == 0)
    recorder.close()
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", BagWarning)
        got = [m.msg.data for m in open_bag(tmp_path / "bag").messages()]
    assert got and got == [f"payload {i:04d} " + "x" * 40 for i in range(len(got))]
    assert (tmp_path / "bag" / "metadata.yaml").is_file()


def run_recorder(folder: Path, *args: str) -> subprocess.Popen:
    env = dict(os.environ, PYTHONPATH=str(ROOT))
    return subprocess.Popen(
        [sys.executable, "-m", "sim_runtime.bag.record", "-o", str(folder), *args],
        env=env,
        stdout=subprocess.PIPE,
        stderr=subprocess.STDOUT,
        text=True,
    )


def publish_for(executor, pub, seconds: float, rate: float) -> int:
    """Publish numbered strings at `rate` for `seconds` of wall time; returns how many."""
    n, start = 0, time.monotonic()
    while time.monotonic() - start < seconds:
        pub.publish(String(data=str(n)))
        n += 1
        executor.spin_once(timeout_sec=1.0 / rate)
    return n


def test_sigkill_loses_at_most_the_last_second(executor, make_node, tmp_path):
    node = make_node("victim")
    pub = node.create_publisher(String, "/kill_test/data", 100)
    proc = run_recorder(tmp_path / "bag", "/kill_test/data")
    try:
        assert wait_for_match(executor, pub, timeout=15)
        rate = 200.0
        sent = publish_for(executor, pub, 2.5, rate)
        proc.send_signal(signal.SIGKILL)
        proc.wait(10)
    finally:
        proc.kill()
    assert not (tmp_path / "bag" / "metadata.yaml").exists()
    with pytest.warns(BagWarning):
        got = [m.msg.data for m in open_bag(tmp_path / "bag").messages()]
    assert got == [str(i) for i in range(len(got))]
    assert len(got) >= sent - rate * 1.0

    from sim_runtime.bag.record import main

    assert main(["record", "--reindex", str(tmp_path / "bag")]) == 0
    with RosbagsReader(tmp_path / "bag") as reader:
        assert reader.message_count == len(got)


def test_ctrl_c_finishes_the_bag(executor, make_node, tmp_path):
    node = make_node("calm")
    pub = node.create_publisher(String, "/int_test/data", 100)
    proc = run_recorder(tmp_path / "bag", "/int_test/data", "--compression", "lz4", "--max-bag-duration", "0.2")
    try:
        assert wait_for_match(executor, pub, timeout=15)
        sent = publish_for(executor, pub, 0.5, 200.0)
        # every message reaches the recorder before we stop it (reliable, depth 100)
        assert pub.wait_for_all_acked(Duration(seconds=10))
        proc.send_signal(signal.SIGINT)
        out, _ = proc.communicate(timeout=15)
    finally:
        proc.kill()
    assert proc.returncode == 0, out
    splits = sorted((tmp_path / "bag").glob("*.mcap"))
    assert len(splits) >= 2  # --max-bag-duration 0.2 over 0.5 s of messages
    total = 0
    for split in splits:
        with split.open("rb") as stream:
            summary = make_reader(stream).get_summary()
        total += summary.statistics.message_count
        assert {c.compression for c in summary.chunk_indexes} <= {"lz4"}
    assert total == sent
    with RosbagsReader(tmp_path / "bag") as reader:
        assert [TYPESTORE.deserialize_cdr(raw, c.msgtype).data for c, _t, raw in reader.messages()] == [
            str(i) for i in range(sent)
        ]


def test_cli_refuses_existing_output(tmp_path):
    (tmp_path / "bag").mkdir()
    from sim_runtime.bag.record import main

    assert main(["record", "-o", str(tmp_path / "bag")]) == 2
    assert list((tmp_path / "bag").iterdir()) == []


def test_replay_cli_republishes_a_bag(executor, make_node, tmp_path):
    with BagWriter(tmp_path / "bag") as w:
        tid = w.add_topic("/cli_test/data", "std_msgs/msg/String", qos_profiles_yaml([{}]))
        for i in range(20):
            w.write(tid, 10**9 + i * 10**7, serialize_message(String(data=str(i))))
    node = make_node("cli_listener")
    got = Collector(node, String, "/cli_test/renamed", 100)
    proc = subprocess.Popen(
        [
            sys.executable,
            "-m",
            "sim_runtime.bag.replay",
            str(tmp_path / "bag"),
            "--start-paused",
            # our subscription may see the player's publisher before the publisher sees it: until
            # then what it publishes reaches no one
            "--wait-for-subscribers",
            "1",
            "--remap",
            "/cli_test/data:=/cli_test/renamed",
            "--ros-args",
            "-r",
            "__node:=cli_player",
        ],
        env=dict(os.environ, PYTHONPATH=str(ROOT)),
        stdout=subprocess.PIPE,
        stderr=subprocess.STDOUT,
        text=True,
    )
    try:
        assert wait_for_match(executor, got.subscription, timeout=15)
        client = node.create_client(Trigger, "/cli_player/resume")
        assert client.wait_for_service(timeout_sec=15)
        future = client.call_async(Trigger.Request())
        executor.spin_until_future_complete(future, timeout_sec=5)
        assert spin_until(executor, lambda: len(got.msgs) == 20, timeout=10)
        out, _ = proc.communicate(timeout=15)
    finally:
        proc.kill()
    assert proc.returncode == 0, out
    assert [m.data for m in got.msgs] == [str(i) for i in range(20)]
    assert "published 20 messages" in out


def test_resubscribes_when_a_best_effort_publisher_joins(executor, make_node, tmp_path):
    node = make_node("mixed")
    reliable = node.create_publisher(String, "/mixed_test/data", COMMAND_PUBLISHER_QOS)
    recorder = start_recorder(executor, tmp_path / "bag", ["/mixed_test/data"])
    assert wait_for_match(executor, reliable)
    reliable.publish(String(data="from reliable"))
    assert spin_until(executor, lambda: recorder.writer.message_count == 1)
    best_effort = node.create_publisher(String, "/mixed_test/data", qos_profile_sensor_data)
    assert wait_for_match(executor, best_effort)  # only after the recorder resubscribed
    best_effort.publish(String(data="from best effort"))
    assert spin_until(executor, lambda: recorder.writer.message_count == 2)
    recorder.close()
    assert [m.msg.data for m in open_bag(tmp_path / "bag").messages()] == ["from reliable", "from best effort"]


def test_world_started_after_the_recorder_gets_sim_time(executor, make_node, tmp_path):
    """`robot_sims record` first, then the simulation: times still come from /clock, and the
    recorder's own /rosout lines are not stamped with wall time in between."""
    recorder = start_recorder(executor, tmp_path / "bag", ["/later_world/.*", "/rosout"])
    recorder.get_logger().info("a log line before any simulation exists")
    node = make_node("later_world")
    clock = node.create_publisher(Clock, "/clock", 10)
    pub = node.create_publisher(String, "/later_world/data", 10)
    assert wait_for_match(executor, pub) and wait_for_match(executor, clock)
    tick = Clock()
    tick.clock.sec = 42
    clock.publish(tick)
    pub.publish(String(data="hello"))
    assert spin_until(
        executor, lambda: recorder.topic_ids.get("/later_world/data") is not None and recorder.writer.message_count >= 2
    )
    recorder.close()
    times = {m.topic: m.log_time_ns for m in open_bag(tmp_path / "bag").messages()}
    assert times["/later_world/data"] == 42 * 10**9
    assert times["/rosout"] <= 42 * 10**9  # held, then stamped with sim time, not wall time
