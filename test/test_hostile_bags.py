"""Bags and replay options the fuzzer found mishandled: each is now a warning or an InputError."""

from __future__ import annotations

import math
import warnings

import pytest
from geometry_msgs.msg import PoseStamped
from rclpy.serialization import serialize_message

from sim_runtime.bag.reader import BagWarning, CorruptMessage, UnknownMessageType, message_class, open_bag
from sim_runtime.bag.replay import Player, _parse_remaps
from sim_runtime.bag.writer import BagWriter, qos_profiles_yaml
from sim_runtime.errors import InputError
from sim_tools.rerun_view.tracks import tracks_from_bag


def pose_bag(folder, payloads):
    with BagWriter(folder) as bag:
        tid = bag.add_topic("/r1/pose", "geometry_msgs/msg/PoseStamped", qos_profiles_yaml([{}]))
        for k, data in enumerate(payloads):
            bag.write(tid, 1_000_000_000 + k * 1_000_000, data)
    return folder


def good(x: float) -> bytes:
    msg = PoseStamped()
    msg.pose.position.x = x
    return serialize_message(msg)


@pytest.mark.parametrize("metadata", ["- a list\n", "7\n", "rosbag2_bagfile_information: [1]\n", "\x00\x01"])
def test_a_bag_whose_metadata_is_not_a_mapping_is_read_from_its_mcap_files(tmp_path, metadata):
    bag = pose_bag(tmp_path / "bag", [good(1.0), good(2.0)])
    (bag / "metadata.yaml").write_text(metadata)
    with pytest.warns(BagWarning, match="metadata.yaml: unreadable"):
        opened = open_bag(bag)
    assert [m.msg.pose.position.x for m in opened.messages()] == [1.0, 2.0]


def test_a_message_that_does_not_decode_is_a_corrupt_message_and_draw_tracks_skips_it(tmp_path):
    bag = pose_bag(tmp_path / "bag", [good(1.0), b"\x00\x01\x00\x00\xff", good(3.0)])
    messages = list(open_bag(bag).messages())
    with pytest.raises(CorruptMessage, match=r"/r1/pose at log time 1001000000 ns: cannot deserialise 5 bytes"):
        messages[1].msg  # noqa: B018
    assert isinstance(CorruptMessage("x"), InputError)
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        data = tracks_from_bag(bag)
    assert data.tracks["r1"][:, 0].tolist() == [1.0, 3.0]
    assert any("cannot deserialise" in str(w.message) for w in caught)


@pytest.mark.parametrize("type_name", ["os/path/join", "antigravity/msg/x", "sys/msg/modules", "../x/msg/Y", "a/srv/B"])
def test_a_bag_cannot_make_the_reader_import_anything_but_a_message_class(type_name):
    with pytest.raises(UnknownMessageType, match=type_name.replace(".", r"\.")):
        message_class(type_name, "/t")


@pytest.mark.parametrize("item", ["/map:=//", "/map:=bad name", "/a:=/b/"])
def test_replay_remap_to_an_invalid_topic_name_is_an_input_error(item):
    with pytest.raises(InputError, match="is not a valid topic name"):
        _parse_remaps([item])


@pytest.mark.parametrize(
    ("offset", "duration"), [(math.inf, None), (math.nan, None), (1e300, None), (0.0, math.nan), (-1.0, None)]
)
def test_replay_refuses_an_offset_or_duration_it_cannot_play(ros, tmp_path, offset, duration):
    bag = open_bag(pose_bag(tmp_path / "bag", [good(1.0)]))
    with pytest.raises(InputError, match="--start-offset"):
        Player(bag, start_offset=offset, duration=duration, node_name="hostile_player")


def test_replay_plays_to_the_end_for_an_endless_duration(ros, tmp_path):
    bag = open_bag(pose_bag(tmp_path / "bag", [good(1.0)]))
    player = Player(bag, duration=math.inf, node_name="endless_player")
    player.destroy_node()
