"""Live view: a world's topics drawn in-process through the same RerunLogger (file sink, no viewer)."""

from __future__ import annotations

import math

import numpy as np
import rerun as rr
from geometry_msgs.msg import Point, PoseStamped, Twist
from rerun_test_helpers import column, load_entities
from sensor_msgs.msg import LaserScan
from visualization_msgs.msg import Marker, MarkerArray

from sim_runtime.msgs import float32_array, pose_msg
from sim_runtime.qos import COMMAND_PUBLISHER_QOS, LATCHED_QOS, SENSOR_PUBLISHER_QOS
from sim_runtime.testing import spin_until, wait_for_match
from sim_runtime.world_node import SimWorldNode
from sim_tools.rerun_view.live import attach_live_view


class ToyWorld(SimWorldNode):
    """A robot driving along x at 1 m/s with a latched wall marker and a 3-beam scan."""

    def __init__(self) -> None:
        super().__init__("toy_world", physics_rate=50.0, namespace="toy")
        self.x = 0.0
        self.pub_pose = self.create_publisher(PoseStamped, "overhead_pose", SENSOR_PUBLISHER_QOS)
        self.pub_scan = self.create_publisher(LaserScan, "scan", SENSOR_PUBLISHER_QOS)
        self.pub_map = self.create_publisher(MarkerArray, "map_markers", LATCHED_QOS)
        wall = Marker(ns="walls", id=0, type=Marker.LINE_LIST, points=[Point(x=0.0, y=1.0), Point(x=2.0, y=1.0)])
        wall.header.frame_id = "map"
        wall.scale.x = 0.03
        self.pub_map.publish(MarkerArray(markers=[wall]))
        self.every(10.0, self._publish_pose)
        self.every(5.0, self._publish_scan)

    def physics_step(self) -> None:
        self.x += self.physics_dt

    def _publish_pose(self) -> None:
        msg = PoseStamped(pose=pose_msg(self.x, 0.0, 0.0))
        msg.header.stamp, msg.header.frame_id = self.stamp(), "map"
        self.pub_pose.publish(msg)

    def _publish_scan(self) -> None:
        msg = LaserScan(
            angle_min=-math.pi / 2, angle_max=math.pi / 2, angle_increment=math.pi / 2, range_min=0.02, range_max=4.0
        )
        msg.header.stamp, msg.header.frame_id = self.stamp(), "toy/laser"
        msg.ranges = float32_array(np.array([1.0, math.inf, 1.0]))
        self.pub_scan.publish(msg)


def test_live_view_draws_the_worlds_topics_and_discovers_others(executor, make_node, tmp_path):
    world = ToyWorld()
    executor.add_node(world)
    rec = rr.RecordingStream("robot_sims_test")
    out = tmp_path / "live.rrd"
    rec.save(out)
    view = attach_live_view(world, recording=rec)
    assert {"/toy/overhead_pose", "/toy/scan", "/toy/map_markers"} <= set(view.subscriptions)

    controller = make_node("controller")
    cmd = controller.create_publisher(Twist, "/toy/cmd_vel", COMMAND_PUBLISHER_QOS)
    assert spin_until(executor, lambda: "/toy/cmd_vel" in dict(world.get_topic_names_and_types()))
    view.discover()  # what the discovery timer does every DISCOVERY_PERIOD s
    assert "/toy/cmd_vel" in view.subscriptions
    assert wait_for_match(executor, cmd)

    assert spin_until(executor, lambda: view.message_count >= 1)  # the latched map
    world.step(50)  # 1 s: 10 poses, 5 scans
    cmd.publish(Twist())
    assert spin_until(executor, lambda: view.message_count >= 1 + 10 + 5 + 1)
    view.close()
    rec.disconnect()

    ents = load_entities(out)
    assert len(column(ents["/top/map/map_markers/walls/0"], "LineStrips2D:strips")) == 1
    poses = column(ents["/top/map/robots/toy"], "Transform3D:translation")
    assert len(poses) == 10 and poses[-1][0] == [1.0, 0.0, 0.0]
    assert len(column(ents["/top/map/tracks/toy/truth/0"], "LineStrips2D:strips")[-1][0]) == 10
    scans = column(ents["/top/map/robots/toy/laser/scan"], "Points2D:positions")
    assert len(scans) == 5 and len(scans[-1]) == 2  # the +inf beam has no point
    assert "/plots/commands/toy/cmd_vel_linear_x" in ents
