"""The player: timing, /clock, filters, pause/step, and record → replay → record."""

from __future__ import annotations

import time

from rclpy.qos import DurabilityPolicy, ReliabilityPolicy
from rclpy.serialization import serialize_message
from rosgraph_msgs.msg import Clock
from sensor_msgs.msg import LaserScan
from std_msgs.msg import String
from std_srvs.srv import SetBool, Trigger

from sim_runtime.bag.reader import open_bag
from sim_runtime.bag.record import Recorder
from sim_runtime.bag.replay import Player, play_bag, replay_qos
from sim_runtime.bag.writer import BagWriter, qos_profiles_yaml
from sim_runtime.qos import LATCHED_QOS, SENSOR_SUBSCRIBER_QOS
from sim_runtime.testing import Collector, spin_until, wait_for_match

T0 = 5_000_000_000
STEP = 20_000_000
LATCHED = qos_profiles_yaml([{"history": "keep_last", "depth": 1, "durability": "transient_local"}])


def make_bag(folder, n=20, prefix="/rp"):
    """n strings on {prefix}/chatter 20 ms apart, a latched map, and a scan every other step."""
    with BagWriter(folder) as w:
        chatter = w.add_topic(f"{prefix}/chatter", "std_msgs/msg/String", qos_profiles_yaml([{}]))
        scans = w.add_topic(
            f"{prefix}/scan", "sensor_msgs/msg/LaserScan", qos_profiles_yaml([{"reliability": "best_effort"}])
        )
        latched = w.add_topic(f"{prefix}/map", "std_msgs/msg/String", LATCHED)
        w.write(latched, T0, serialize_message(String(data="map")))
        for i in range(n):
            w.write(chatter, T0 + i * STEP, serialize_message(String(data=f"m{i}")))
            if i % 2:
                w.write(scans, T0 + i * STEP + 1, serialize_message(LaserScan(ranges=[float(i)])))
    return open_bag(folder)


def test_replay_qos_follows_the_recorded_offer():
    latched = replay_qos(LATCHED)
    assert latched.durability == DurabilityPolicy.TRANSIENT_LOCAL and latched.depth == 1
    sensor = replay_qos(qos_profiles_yaml([{"reliability": "best_effort"}]))
    assert sensor.reliability == ReliabilityPolicy.BEST_EFFORT
    mixed = replay_qos(qos_profiles_yaml([{"reliability": "best_effort"}, {}]))
    assert mixed.reliability == ReliabilityPolicy.RELIABLE
    assert replay_qos("").reliability == ReliabilityPolicy.RELIABLE


def test_replay_with_timing_and_clock(executor, make_node, tmp_path):
    bag = make_bag(tmp_path / "bag")
    node = make_node("listener")
    chatter = Collector(node, String, "/rp/chatter", 100)
    scans = Collector(node, LaserScan, "/rp/scan", SENSOR_SUBSCRIBER_QOS)
    the_map = Collector(node, String, "/rp/map", LATCHED_QOS)
    clock = Collector(node, Clock, "/clock", 1000)
    start = time.monotonic()
    stats = play_bag(bag, executor, wait_for_subscribers=1, rate=2.0)
    elapsed = time.monotonic() - start
    assert spin_until(executor, lambda: len(chatter.msgs) == 20 and len(scans.msgs) == 10)
    assert elapsed >= (bag.end_ns - bag.start_ns) / 1e9 / 2.0  # never ahead of schedule
    assert stats.published == 31
    assert [m.data for m in chatter.msgs] == [f"m{i}" for i in range(20)]
    assert [list(m.ranges) for m in scans.msgs] == [[float(i)] for i in range(1, 20, 2)]
    assert [m.data for m in the_map.msgs] == ["map"]
    assert spin_until(
        executor, lambda: clock.msgs and clock.last.clock.sec * 10**9 + clock.last.clock.nanosec == bag.end_ns
    )
    clock_ns = [c.clock.sec * 10**9 + c.clock.nanosec for c in clock.msgs]
    assert clock_ns[0] == T0 and clock_ns == sorted(clock_ns)
    assert {T0 + i * STEP for i in range(20)} <= set(clock_ns)  # the clock reaches each message


def test_offset_duration_topics_and_remap(executor, make_node, tmp_path):
    bag = make_bag(tmp_path / "bag")
    node = make_node("listener")
    renamed = Collector(node, String, "/rp/renamed", 100)
    stats = play_bag(
        bag,
        executor,
        wait_for_subscribers=1,
        rate=5.0,
        start_offset=0.1,
        duration=0.1,
        topics=["/rp/chatter"],
        remap={"/rp/chatter": "/rp/renamed"},
    )
    assert spin_until(executor, lambda: len(renamed.msgs) == stats.published)
    assert [m.data for m in renamed.msgs] == [f"m{i}" for i in range(5, 11)]


def call(executor, node, srv_type, name, request):
    client = node.create_client(srv_type, name)
    assert client.wait_for_service(timeout_sec=5.0)
    future = client.call_async(request)
    executor.spin_until_future_complete(future, timeout_sec=5.0)
    assert future.done() and future.result().success
    return future.result()


def test_pause_resume_and_step_services(executor, make_node, tmp_path):
    bag = make_bag(tmp_path / "bag", n=6)
    player = Player(bag, topics=["/rp/chatter"], start_paused=True, node_name="step_player")
    executor.add_node(player)
    node = make_node("controller")
    chatter = Collector(node, String, "/rp/chatter", 100)
    assert wait_for_match(executor, player.topic_publishers["/rp/chatter"])
    player.start()
    call(executor, node, Trigger, "/step_player/step", Trigger.Request())
    assert spin_until(executor, lambda: len(chatter.msgs) == 1)
    call(executor, node, Trigger, "/step_player/step", Trigger.Request())
    assert spin_until(executor, lambda: len(chatter.msgs) == 2)
    spin_until(executor, lambda: len(chatter.msgs) > 2, timeout=0.3)  # still paused: nothing more
    assert [m.data for m in chatter.msgs] == ["m0", "m1"]
    call(executor, node, SetBool, "/step_player/set_paused", SetBool.Request(data=False))
    assert spin_until(executor, lambda: player.finished.done())
    assert spin_until(executor, lambda: len(chatter.msgs) == 6)
    assert [m.data for m in chatter.msgs] == [f"m{i}" for i in range(6)]
    call(executor, node, Trigger, "/step_player/pause", Trigger.Request())
    assert player.paused
    call(executor, node, Trigger, "/step_player/resume", Trigger.Request())
    assert not player.paused


def test_unknown_type_is_skipped(executor, make_node, tmp_path):
    with BagWriter(tmp_path / "bag") as w:
        weird = w.add_topic("/rp/weird", "foo_msgs/msg/Bar", qos_profiles_yaml([{}]))
        ok = w.add_topic("/rp/ok", "std_msgs/msg/String", qos_profiles_yaml([{}]))
        w.write(weird, T0, b"\x00\x01\x00\x00junk")
        w.write(ok, T0 + 1, serialize_message(String(data="fine")))
    node = make_node("listener")
    got = Collector(node, String, "/rp/ok", 10)
    stats = play_bag(tmp_path / "bag", executor, wait_for_subscribers=1)
    assert stats.published == 1
    assert spin_until(executor, lambda: [m.data for m in got.msgs] == ["fine"])


def test_record_replay_record_round_trip(executor, tmp_path):
    original = make_bag(tmp_path / "a", prefix="/rt")
    recorder = Recorder(BagWriter(tmp_path / "b"), ["/rt/.*"], node_name="rt_recorder")
    executor.add_node(recorder)
    play_bag(original, executor, wait_for_subscribers=1, rate=2.0)
    assert spin_until(executor, lambda: recorder.writer.message_count == original.message_count)
    recorder.close()
    copy = open_bag(tmp_path / "b")
    assert copy.topics == original.topics
    for topic in original.topics:
        before = [m.msg for m in original.messages(topics=[topic])]
        after = list(copy.messages(topics=[topic]))
        assert [m.msg for m in after] == before, topic
        # stamped with the player's /clock: the recorded (sim) times come back
        for m, t in zip(after, [m.log_time_ns for m in original.messages(topics=[topic])], strict=True):
            assert abs(m.log_time_ns - t) <= STEP
    assert copy.topic_metadata["/rt/map"]["offered_qos_profiles"] != ""
    assert "transient_local" in copy.topic_metadata["/rt/map"]["offered_qos_profiles"]


def test_loop_plays_again_until_stopped(executor, make_node, tmp_path):
    bag = make_bag(tmp_path / "bag", n=5)
    player = Player(bag, topics=["/rp/chatter"], loop=True, rate=10.0, node_name="loop_player")
    executor.add_node(player)
    node = make_node("loop_listener")
    chatter = Collector(node, String, "/rp/chatter", 100)
    assert wait_for_match(executor, player.topic_publishers["/rp/chatter"])
    player.start()
    assert spin_until(executor, lambda: len(chatter.msgs) >= 12)
    player.stop()
    assert player.finished.done()  # stop() ends the loop
    assert [m.data for m in chatter.msgs[:12]] == [f"m{i % 5}" for i in range(12)]


def test_a_player_refused_for_its_options_or_a_topic_name_leaves_no_node_behind(make_node, tmp_path):
    import pytest
    from rclpy.exceptions import InvalidTopicNameException

    from sim_runtime.errors import InputError

    bag = make_bag(tmp_path / "bag")
    probe = make_node("probe")
    for options in ({"rate": 0.0}, {"start_offset": -1.0}, {"exclude": "("}):
        with pytest.raises(InputError):
            Player(bag, node_name="refused_player", **options)
    with pytest.raises(InvalidTopicNameException):
        Player(bag, remap={"/rp/chatter": "/bad name"}, node_name="refused_player")
    assert "refused_player" not in probe.get_node_names()
    player = Player(bag, node_name="refused_player")  # the name is free again
    assert "refused_player" in probe.get_node_names()
    player.destroy_node()


def test_stopping_a_looping_replay_at_any_moment_ends_its_threads(executor, tmp_path):
    import random
    import threading

    bag = make_bag(tmp_path / "bag", n=3)
    rng = random.Random(7)
    for i in range(40):
        player = Player(bag, topics=["/rp/chatter"], loop=True, rate=1000.0, node_name=f"stop_player_{i}")
        executor.add_node(player)
        player.start()
        # At rate 1000 a pass of the 3-message bag lasts ~3 ms: random stops land anywhere in a
        # pass, in the reader's end mark and between passes (where the hang of old was).
        time.sleep(rng.uniform(0.0, 0.02))
        player.stop()
        assert not player._thread.is_alive(), f"stop {i}: the player thread is still running"
        assert player.finished.done()
        executor.remove_node(player)
        player.destroy_node()
    assert not [t for t in threading.enumerate() if t.name in ("bag-player", "bag-reader") and t.is_alive()]
