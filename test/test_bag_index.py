"""BagIndex: the state at any instant equals a scan of the whole bag up to that instant."""

from __future__ import annotations

import random
import warnings
from pathlib import Path

import pytest
from geometry_msgs.msg import PoseStamped, Twist
from mcap.writer import CompressionType, IndexType, Writer
from rclpy.serialization import serialize_message
from sensor_msgs.msg import LaserScan

from sim_runtime.bag.index import BagIndex
from sim_runtime.bag.msgdefs import full_definition
from sim_runtime.bag.reader import BagWarning, open_bag
from sim_runtime.bag.writer import BagWriter, qos_profiles_yaml
from sim_runtime.errors import InputError
from sim_runtime.msgs import pose_msg

QOS = qos_profiles_yaml([{}])
TOPICS = [
    ("/overhead_pose", "geometry_msgs/msg/PoseStamped"),
    ("/cmd_vel", "geometry_msgs/msg/Twist"),
    ("/scan", "sensor_msgs/msg/LaserScan"),
    ("/robot2/overhead_pose", "geometry_msgs/msg/PoseStamped"),
]


def sample(n: int = 600, seed: int = 1) -> list[tuple[str, int, bytes]]:
    """(topic, log time, CDR) in log-time order, with repeated instants and a rare topic."""
    rng = random.Random(seed)
    out = []
    t = 1_000_000_000
    for k in range(n):
        t += rng.choice([0, 1, 10_000_000, 20_000_000])  # equal times happen (several topics per step)
        topic = rng.choice(["/overhead_pose"] * 5 + ["/cmd_vel"] * 2 + ["/scan", "/robot2/overhead_pose"])
        if k == n - 3:
            topic = "/robot2/overhead_pose"
        if topic.endswith("overhead_pose"):
            msg = PoseStamped(pose=pose_msg(k * 0.01, -k * 0.02, k * 0.001))
        elif topic == "/cmd_vel":
            msg = Twist()
            msg.linear.x = k * 0.001
        else:
            msg = LaserScan(ranges=[float(k)] * rng.randint(1, 700))
        out.append((topic, t, serialize_message(msg)))
    return out


def write_ours(folder: Path, messages, **options) -> Path:
    with BagWriter(folder, **options) as bag:
        ids = {name: bag.add_topic(name, kind, QOS) for name, kind in TOPICS}
        for topic, t, data in messages:
            bag.write(ids[topic], t, data)
    return folder


def write_mcap(path: Path, messages, **writer_options) -> Path:
    """A bag written by the mcap package's writer with the given options (no message indexes,
    no chunks…), as other tools write them."""
    with path.open("wb") as stream:
        writer = Writer(stream, **writer_options)
        writer.start(profile="ros2", library="test")
        channels = {}
        for name, kind in TOPICS:
            schema = writer.register_schema(kind, "ros2msg", full_definition(kind).text.encode())
            channels[name] = writer.register_channel(name, "cdr", schema)
        for topic, t, data in messages:
            writer.add_message(channels[topic], t, data, t)
        writer.finish()
    return path


def brute_force_state(bag_path: Path, t: int) -> dict[str, tuple[int, bytes]]:
    """The latest message per topic at or before ``t``, by reading the whole bag from its start."""
    state = {}
    for m in open_bag(bag_path).messages():
        if m.log_time_ns > t:
            break
        state[m.topic] = (m.log_time_ns, m.data)
    return state


def instants(messages) -> list[int]:
    times = sorted({t for _topic, t, _data in messages})
    return [times[0] - 1, times[0], times[1], times[len(times) // 2], times[len(times) // 2] + 1, times[-2], times[-1]]


def assert_states_match(bag_path: Path, messages) -> None:
    index = BagIndex.open(bag_path)
    assert index.message_count == len(messages)
    for t in instants(messages) + random.Random(3).sample(range(messages[0][1], messages[-1][1]), 20):
        got = {topic: (m.log_time_ns, bytes(m.data)) for topic, m in index.state_at(t).items()}
        assert got == brute_force_state(bag_path, t), f"state at {t} ns"
    index.close()


@pytest.mark.parametrize(
    "options",
    [
        {"chunk_size": 4096},
        {"chunk_size": 4096, "compression": "lz4"},
        {"chunk_size": 1 << 20, "compression": "none"},
        {"chunk_size": 8192, "max_bag_size": 60_000},  # several .mcap splits
    ],
    ids=["zstd", "lz4", "one-chunk", "splits"],
)
def test_the_state_at_any_instant_is_what_a_scan_of_our_bag_up_to_it_finds(tmp_path, options):
    messages = sample()
    bag = write_ours(tmp_path / "bag", messages, **options)
    if "max_bag_size" in options:
        assert len(open_bag(bag).files) > 1
    assert_states_match(bag, messages)


@pytest.mark.parametrize(
    "writer_options",
    [
        {"chunk_size": 4096, "index_types": IndexType.CHUNK},  # chunks without message indexes
        {"chunk_size": 4096, "compression": CompressionType.LZ4},
        {"use_chunking": False},
    ],
    ids=["no-message-index", "lz4", "unchunked"],
)
def test_bags_of_other_mcap_writers_are_indexed_too(tmp_path, writer_options):
    messages = sample(seed=2)
    assert_states_match(write_mcap(tmp_path / "other.mcap", messages, **writer_options), messages)


def test_a_bag_whose_recorder_was_killed_is_indexed_up_to_its_last_intact_chunk(tmp_path):
    messages = sample(seed=4)
    bag = write_ours(tmp_path / "bag", messages, chunk_size=4096)
    mcap_file = next(bag.glob("*.mcap"))
    data = mcap_file.read_bytes()
    mcap_file.write_bytes(data[: len(data) * 2 // 3])
    (bag / "metadata.yaml").unlink()
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", BagWarning)
        index = BagIndex.open(bag)
        kept = [(m.topic, m.log_time_ns, bytes(m.data)) for m in open_bag(bag).messages()]
        assert 0 < index.message_count == len(kept) < len(messages)
        for t in instants(kept):
            got = {topic: (m.log_time_ns, bytes(m.data)) for topic, m in index.state_at(t).items()}
            assert got == brute_force_state(bag, t)


def test_between_returns_the_messages_of_a_window_in_order_and_step_positions_follow_a_topic(tmp_path):
    messages = sample(seed=5)
    index = BagIndex.open(write_ours(tmp_path / "bag", messages, chunk_size=4096))
    t0, t1 = messages[100][1], messages[200][1]
    expected = [(topic, t) for topic, t, _ in messages if t0 < t <= t1]
    assert [(m.topic, m.log_time_ns) for m in index.between(t0, t1)] == expected
    assert [(m.topic, m.log_time_ns) for m in index.between(t0, t1, ["/cmd_vel"])] == [
        e for e in expected if e[0] == "/cmd_vel"
    ]
    poses = index.by_topic["/overhead_pose"]
    assert poses.times.tolist() == [t for topic, t, _ in messages if topic == "/overhead_pose"]
    i = poses.at_or_before(t1)
    assert index.message(poses.name, i).log_time_ns == poses.times[i] <= t1 < poses.times[i + 1]
    first = [k * 0.01 for k, (topic, _t, _d) in enumerate(messages) if topic == "/overhead_pose"][:3]
    assert [m.msg.pose.position.x for m in index.messages("/overhead_pose", 0, 3)] == first


def test_a_path_that_is_not_a_bag_is_an_input_error_naming_it(tmp_path):
    with pytest.raises(InputError, match="notabag"):
        BagIndex.open(tmp_path / "notabag")
