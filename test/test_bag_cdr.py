"""Track positions read from CDR bytes are the ones rclpy deserialises."""

from __future__ import annotations

import math

import numpy as np
from geometry_msgs.msg import PoseStamped
from nav_msgs.msg import Odometry
from rclpy.serialization import serialize_message

from sim_runtime.bag.cdr import track_positions
from sim_runtime.msgs import pose_msg


def test_positions_of_poses_and_odometry_with_any_frame_names_match_rclpy():
    rng = np.random.default_rng(0)
    poses, odoms, expected = [], [], []
    for k in range(40):
        x, y = rng.normal(size=2) * 100
        pose = PoseStamped(pose=pose_msg(x, y, 0.3))
        pose.header.frame_id = "m" * (k % 11)  # every alignment of what follows the string
        odom = Odometry(child_frame_id="b" * (k % 7))
        odom.header.frame_id = "o" * (k % 5)
        odom.pose.pose = pose_msg(x, y, -1.0)
        poses.append(serialize_message(pose))
        odoms.append(serialize_message(odom))
        expected.append((x, y))
    np.testing.assert_array_equal(track_positions("geometry_msgs/msg/PoseStamped", poses), expected)
    np.testing.assert_array_equal(track_positions("nav_msgs/msg/Odometry", odoms), expected)


def test_a_message_cut_short_is_nan_and_other_types_are_not_read():
    whole = serialize_message(PoseStamped(pose=pose_msg(1.0, 2.0, 0.0)))
    xy = track_positions("geometry_msgs/msg/PoseStamped", [whole, whole[:30], b"", b"\x01\x00\x00\x00" + whole[4:]])
    assert xy[0].tolist() == [1.0, 2.0]
    assert all(math.isnan(v) for v in xy[1:].ravel())  # cut short, empty, big-endian
    assert track_positions("sensor_msgs/msg/LaserScan", [whole]) is None
