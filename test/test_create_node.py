"""create_world end to end in one process: the world and a probe node in one executor, stepped."""

from __future__ import annotations

import io
import math
import os
import signal
import subprocess
from pathlib import Path

import numpy as np
import pytest
import yourdfpy
from geometry_msgs.msg import PoseStamped, Twist, TwistStamped
from nav_msgs.msg import OccupancyGrid, Odometry
from rclpy.parameter import Parameter
from rosgraph_msgs.msg import Clock
from sensor_msgs.msg import BatteryState, Illuminance, JointState, Joy, LaserScan, Range
from std_srvs.srv import SetBool, Trigger
from visualization_msgs.msg import MarkerArray

from create_sim.bump_turn import BumpTurnNode, demo
from create_sim.spec import ODOMETRY_RESOLUTION, WHEEL_BASE_M, WHEEL_RADIUS_M
from create_sim.urdf import create_urdf
from create_sim.world_node import SONAR_FIELD_OF_VIEW, CreateWorldNode
from sim_runtime.errors import InputError
from sim_runtime.msgs import pose_msg, time_from_msg, time_msg, yaw_from_quaternion
from sim_runtime.qos import COMMAND_PUBLISHER_QOS, LATCHED_QOS, SENSOR_SUBSCRIBER_QOS
from sim_runtime.testing import Collector, TfBuffer, drain, spin_until, wait_for_match
from sim_tools.cli import executable_command

# A 4 m x 4 m room around the origin, a floor line at x = 1, a beacon ahead, a virtual wall.
ROOM = """\
% test room
wall -2 -2  2 -2
wall  2 -2  2  2
wall  2  2 -2  2
wall -2  2 -2 -2
line  1 -1  1  1
beacon 1.5 0 [1 0 0] Red1
beacon -1.5 0 [0 0 1] behindMe
virtwall -1.5 -1.5 0.785 1
"""

SENSOR_TOPICS = {
    "odom": Odometry,
    "overhead_pose": PoseStamped,
    "bump/left": Range,
    "bump/right": Range,
    "wall": Range,
    "virtual_wall": Range,
    "cliff/left": Illuminance,
    "cliff/front_left": Illuminance,
    "cliff/front_right": Illuminance,
    "cliff/right": Illuminance,
    "sonar/front": Range,
    "sonar/left": Range,
    "sonar/back": Range,
    "sonar/right": Range,
    "scan": LaserScan,
    "camera/beacons": MarkerArray,
    "buttons": Joy,
    "battery_state": BatteryState,
}
DEFAULT_RATES = {
    "odom": 50,
    "overhead_pose": 50,
    "bump/left": 50,
    "bump/right": 50,
    "wall": 50,
    "virtual_wall": 50,
    "cliff/left": 50,
    "cliff/front_left": 50,
    "cliff/front_right": 50,
    "cliff/right": 50,
    "sonar/front": 20,
    "sonar/left": 20,
    "sonar/back": 20,
    "sonar/right": 20,
    "scan": 10,
    "camera/beacons": 10,
    "buttons": 10,
    "battery_state": 1,
}
FRAMES = {
    "odom": "odom",
    "overhead_pose": "map",
    "bump/left": "bump_left",
    "bump/right": "bump_right",
    "wall": "wall_ir",
    "virtual_wall": "virtual_wall_ir",
    "cliff/left": "cliff_left",
    "cliff/front_left": "cliff_front_left",
    "cliff/front_right": "cliff_front_right",
    "cliff/right": "cliff_right",
    "sonar/front": "sonar_front",
    "sonar/left": "sonar_left",
    "sonar/back": "sonar_back",
    "sonar/right": "sonar_right",
    "scan": "laser",
    "buttons": "base_link",
    "battery_state": "base_link",
}


class Rig:
    """A world plus a probe node in one executor; ``step`` advances sim time deterministically."""

    def __init__(
        self, executor, make_node, tmp_path, map_text: str = ROOM, config_text: str | None = None, **params
    ) -> None:
        self.executor = executor
        map_file = tmp_path / "world.map"
        map_file.write_text(map_text)
        overrides = {"map_file": str(map_file), "real_time_factor": 0.0, **params}
        if config_text is not None:
            config_file = tmp_path / "world.cfg"
            config_file.write_text(config_text)
            overrides["config_file"] = str(config_file)
        self.world = make_world(overrides)
        executor.add_node(self.world)
        self.probe = make_node("probe")
        self.collectors: dict[str, Collector] = {}
        stamped = params.get("cmd_vel_stamped", False)
        self.cmd_pub = self.probe.create_publisher(TwistStamped if stamped else Twist, "cmd_vel", COMMAND_PUBLISHER_QOS)
        assert wait_for_match(executor, self.cmd_pub)

    def listen(self, *topics: str) -> None:
        for topic in topics:
            qos = LATCHED_QOS if topic == "map_markers" else SENSOR_SUBSCRIBER_QOS
            msg_type = MarkerArray if topic == "map_markers" else SENSOR_TOPICS[topic]
            self.collectors[topic] = Collector(self.probe, msg_type, topic, qos)
            assert wait_for_match(self.executor, self.collectors[topic].subscription)

    def __getitem__(self, topic: str) -> Collector:
        return self.collectors[topic]

    def step(self, n: int = 1) -> None:
        for _ in range(n):
            self.world.step()
            drain(self.executor)

    def wait(self, predicate) -> None:
        assert spin_until(self.executor, predicate), "expected messages did not arrive"

    def drive(self, v: float, w: float = 0.0) -> None:
        """Publish a command and wait until the world has received it."""
        received = self.world.commands_received
        twist = Twist()
        twist.linear.x, twist.angular.z = v, w
        if self.world.cmd_vel_stamped:
            msg = TwistStamped(twist=twist)
            self.cmd_pub.publish(msg)
        else:
            self.cmd_pub.publish(twist)
        self.wait(lambda: self.world.commands_received > received)
        self.step()

    def call(self, client_type, name: str, request):
        client = self.probe.create_client(client_type, name)
        assert client.wait_for_service(timeout_sec=5.0)
        future = client.call_async(request)
        assert spin_until(self.executor, future.done)
        return future.result()


def make_world(params: dict) -> CreateWorldNode:
    return CreateWorldNode(parameter_overrides=[Parameter(k, value=v) for k, v in params.items()])


@pytest.fixture
def rig(executor, make_node, tmp_path):
    return Rig(executor, make_node, tmp_path)


def test_every_topic_has_its_type_frame_rate_and_sim_time_stamps(rig):
    rig.listen(*SENSOR_TOPICS)
    clock = Collector(rig.probe, Clock, "/clock", 10)
    assert wait_for_match(rig.executor, clock.subscription)
    rig.step(200)  # 2 s
    rig.wait(lambda: all(len(rig[t].msgs) >= 2 * DEFAULT_RATES[t] - 2 for t in SENSOR_TOPICS))
    for topic, msg_type in SENSOR_TOPICS.items():
        msgs = rig[topic].msgs
        assert all(isinstance(m, msg_type) for m in msgs)
        # Best effort may drop a message or two, never add any.
        assert 2 * DEFAULT_RATES[topic] - 2 <= len(msgs) <= 2 * DEFAULT_RATES[topic], topic
        period = 1.0 / DEFAULT_RATES[topic]
        for m in msgs:
            t = time_from_msg(m.header.stamp) if hasattr(m, "header") else time_from_msg(m.markers[0].header.stamp)
            assert t <= 2.0 + 1e-9
            assert abs(t / period - round(t / period)) < 1e-6, (topic, t)
        if topic in FRAMES:
            assert msgs[-1].header.frame_id == FRAMES[topic]
    assert rig["odom"].last.child_frame_id == "base_link"
    rig.wait(lambda: clock.last is not None and time_from_msg(clock.last.clock) == pytest.approx(2.0))


def test_scan_geometry_and_ranges(rig):
    rig.listen("scan")
    rig.step(10)
    rig.wait(lambda: rig["scan"].last is not None)
    scan = rig["scan"].last
    assert len(scan.ranges) == 681
    assert scan.angle_min == pytest.approx(-math.radians(120), abs=1e-6)
    assert scan.angle_max == pytest.approx(math.radians(120), abs=1e-6)
    assert scan.angle_min + 680 * scan.angle_increment == pytest.approx(scan.angle_max, abs=1e-5)
    assert (scan.range_min, scan.range_max) == pytest.approx((0.02, 4.0))
    # The laser sits at the front of the body (x = 0.16): the wall at x = 2 is 1.84 m ahead.
    assert scan.ranges[340] == pytest.approx(1.84, abs=1e-4)
    # Straight left (+90°, beam 340 + 255) the wall at y = 2 is 2 m from the laser's origin line.
    assert scan.ranges[340 + 255] == pytest.approx(2.0, abs=1e-3)


def test_driving_into_a_wall_bumps_both_and_odometry_follows(rig):
    rig.listen("bump/left", "bump/right", "odom", "overhead_pose", "sonar/front", "cliff/front_left")
    rig.drive(0.5)
    rig.step(99)
    rig.wait(lambda: rig["odom"].last is not None and time_from_msg(rig["odom"].last.header.stamp) >= 1.0)
    odom = rig["odom"].last.pose.pose.position
    assert odom.x == pytest.approx(0.5, abs=0.011)  # noise-free odometry: 1 s at 0.5 m/s
    assert rig["odom"].last.twist.twist.linear.x == pytest.approx(0.5)
    assert rig["bump/left"].last.range == math.inf and rig["bump/right"].last.range == math.inf
    rig.step(400)  # reaches the wall at x = 2 - 0.16 and stays there
    rig.wait(lambda: time_from_msg(rig["overhead_pose"].last.header.stamp) >= 5.0 - 1e-9)
    pose = rig["overhead_pose"].last.pose
    assert pose.position.x == pytest.approx(1.84, abs=1e-3)
    assert pose.position.x == pytest.approx(rig.world.model.pose[0])  # overhead pose is exact
    assert rig["bump/left"].last.range == -math.inf and rig["bump/right"].last.range == -math.inf
    assert rig["bump/left"].last.min_range == rig["bump/left"].last.max_range
    assert rig["sonar/front"].last.range == -math.inf  # touching: closer than the 0.02 m minimum
    # It crossed the floor line at x = 1 on the way and is past it now: floor reading again.
    assert rig["cliff/front_left"].last.illuminance == pytest.approx(21.5)


def test_cliff_sensor_reads_a_floor_line(executor, make_node, tmp_path):
    rig = Rig(executor, make_node, tmp_path, initial_pose=[1.0 - 0.16 * math.cos(0.1 * math.pi), 0.0, 0.0])
    rig.listen("cliff/front_left", "cliff/front_right", "cliff/left")
    rig.step(2)
    rig.wait(lambda: rig["cliff/front_left"].last is not None and rig["cliff/left"].last is not None)
    assert rig["cliff/front_left"].last.illuminance == pytest.approx(1.5)
    assert rig["cliff/front_right"].last.illuminance == pytest.approx(1.5)
    assert rig["cliff/left"].last.illuminance == pytest.approx(21.5)


def test_sonar_virtual_wall_and_wall_sensor(executor, make_node, tmp_path):
    rig = Rig(executor, make_node, tmp_path, initial_pose=[-1.0, -1.0, math.pi / 2])
    rig.listen("sonar/front", "sonar/left", "sonar/back", "sonar/right", "virtual_wall", "wall")
    rig.step(5)
    rig.wait(lambda: all(rig[f"sonar/{s}"].last is not None for s in ("front", "left", "back", "right")))
    # Facing +y at (-1, -1): sonar distances are from the body's edge (radius 0.16).
    assert rig["sonar/front"].last.range == pytest.approx(2.84, abs=1e-6)
    assert rig["sonar/left"].last.range == pytest.approx(0.84, abs=1e-6)
    assert rig["sonar/back"].last.range == pytest.approx(0.84, abs=1e-6)
    assert rig["sonar/right"].last.range == pytest.approx(2.84, abs=1e-6)
    assert (rig["sonar/front"].last.min_range, rig["sonar/front"].last.max_range) == pytest.approx((0.02, 3.0))
    assert rig["sonar/front"].last.radiation_type == Range.ULTRASOUND
    # The receiver at (-1, -0.84) is inside the field of the virtual wall at (-1.5, -1.5) facing 45°.
    rig.wait(lambda: rig["virtual_wall"].last is not None and rig["wall"].last is not None)
    assert rig["virtual_wall"].last.range == -math.inf
    assert rig["virtual_wall"].last.radiation_type == Range.INFRARED
    assert rig["wall"].last.range == math.inf
    # Wall 0.096 m to the right of the IR sensor (range 0.1), virtual wall out of sight.
    rig.world.model.set_pose(0.0, -1.8, 0.0)
    rig["wall"].clear()
    rig["virtual_wall"].clear()
    rig.step(2)
    rig.wait(lambda: rig["wall"].last is not None and rig["virtual_wall"].last is not None)
    assert rig["wall"].last.range == -math.inf
    assert rig["wall"].last.min_range == rig["wall"].last.max_range == pytest.approx(0.1)
    assert rig["virtual_wall"].last.range == math.inf


def test_map_markers_are_latched_and_complete(rig):
    rig.listen("map_markers")
    rig.wait(lambda: rig["map_markers"].last is not None)
    markers = rig["map_markers"].last.markers
    by_ns: dict[str, list] = {}
    for m in markers:
        by_ns.setdefault(m.ns, []).append(m)
        assert m.header.frame_id == "map"
    assert len(by_ns["walls"]) == 1 and len(by_ns["walls"][0].points) == 8  # 4 walls, 2 points each
    assert len(by_ns["lines"][0].points) == 2
    assert [m.text for m in by_ns["beacon_ids"]] == ["Red1", "behindMe"]
    assert len(by_ns["beacons"]) == 2
    assert len(by_ns["virtual_wall_halos"]) == 1 and len(by_ns["virtual_wall_fields"]) == 1
    assert len(by_ns["virtual_wall_fields"][0].points) == 4  # closed triangle


def test_camera_sees_the_beacon_ahead_with_its_id(rig):
    rig.listen("camera/beacons")
    rig.step(10)
    rig.wait(lambda: rig["camera/beacons"].last is not None)
    markers = rig["camera/beacons"].last.markers
    assert [m.text for m in markers] == ["Red1"]  # "behindMe" is behind the camera
    m = markers[0]
    assert m.header.frame_id == "camera"
    assert (m.pose.position.x, m.pose.position.y) == pytest.approx((1.5 - 0.13, 0.0), abs=1e-6)
    assert (m.color.r, m.color.g, m.color.b) == pytest.approx((1.0, 0.0, 0.0))


def test_buttons_toggle_and_battery_constants(rig):
    rig.listen("buttons", "battery_state")
    response = rig.call(SetBool, "press_play", SetBool.Request(data=True))
    assert response.success
    rig.step(100)  # the battery reports at 1 Hz
    rig.wait(lambda: rig["buttons"].last is not None and rig["battery_state"].last is not None)
    assert list(rig["buttons"].last.buttons) == [1, 0]
    rig.call(SetBool, "press_advance", SetBool.Request(data=True))
    rig.call(SetBool, "press_play", SetBool.Request(data=False))
    rig["buttons"].clear()
    rig.step(10)
    rig.wait(lambda: rig["buttons"].last is not None)
    assert list(rig["buttons"].last.buttons) == [0, 1]
    battery = rig["battery_state"].last
    assert battery.voltage == pytest.approx(17.2)
    assert battery.current == pytest.approx(-3.0)
    assert battery.charge == pytest.approx(3.0) and battery.capacity == pytest.approx(3.0)
    assert battery.percentage == pytest.approx(1.0)
    assert battery.temperature == pytest.approx(25.0)


def test_cmd_vel_timeout_stops_the_robot(executor, make_node, tmp_path):
    rig = Rig(executor, make_node, tmp_path, cmd_vel_timeout=0.5)
    rig.drive(0.4)
    rig.step(199)
    assert rig.world.model.pose[0] == pytest.approx(0.2, abs=0.005)  # 0.5 s at 0.4 m/s, then stopped
    assert rig.world.model.command == (0.0, 0.0)


def test_default_holds_the_last_command_forever(rig):
    rig.drive(0.2)
    rig.step(299)
    assert rig.world.model.pose[0] == pytest.approx(0.6, abs=0.005)


def test_cmd_vel_stamped(executor, make_node, tmp_path):
    rig = Rig(executor, make_node, tmp_path, cmd_vel_stamped=True)
    rig.drive(0.0, 1.0)
    rig.step(99)
    assert rig.world.model.pose[2] == pytest.approx(1.0, abs=0.02)


@pytest.mark.parametrize("bad", [(math.nan, 0.0), (0.0, math.inf), (-math.inf, 0.0), (1e9, 0.0), (0.0, -1e9)])
def test_non_finite_or_absurd_commands_are_rejected_and_change_nothing(rig, bad):
    rig.drive(0.2, 0.1)
    before = rig.world.model.command
    assert rig.world.command(*bad) is False
    twist = Twist()
    twist.linear.x, twist.angular.z = bad
    rig.cmd_pub.publish(twist)
    rig.step(20)
    assert rig.world.model.command == before
    assert all(math.isfinite(v) for v in rig.world.model.pose)


def test_over_limit_command_is_clamped_per_wheel(rig):
    rig.drive(0.0, 5.0)  # wheels ±0.645 m/s → ±0.5: pure rotation at 0.5/0.129 rad/s
    v, w = rig.world.model.command
    assert v == pytest.approx(0.0)
    assert w == pytest.approx(0.5 / 0.129)


def test_initial_pose_inside_a_wall_is_a_clear_error(ros, tmp_path):
    map_file = tmp_path / "room.map"
    map_file.write_text(ROOM)
    with pytest.raises(InputError, match=r"'initial_pose'.*inside a wall"):
        make_world({"map_file": str(map_file), "initial_pose": [1.9, 0.0, 0.0]})


@pytest.mark.parametrize(
    ("name", "value"),
    [
        ("rate.scan", -1.0),
        ("rate.bump", 1000.0),
        ("cmd_vel_timeout", -0.5),
        ("real_time_factor", -1.0),
        ("initial_pose", [0.0, 0.0]),
        ("initial_pose", [0.0, math.nan, 0.0]),
    ],
)
def test_parameter_out_of_range_is_a_clear_error(ros, name, value):
    with pytest.raises(InputError, match=f"'{name}'"):
        make_world({"map_file": "", name: value})


def test_missing_map_file_names_the_parameter_and_path(ros, tmp_path):
    with pytest.raises(InputError, match=r"'map_file'.*nope\.map"):
        make_world({"map_file": str(tmp_path / "nope.map")})


def test_robot_driven_off_an_open_map_keeps_working(executor, make_node, tmp_path):
    rig = Rig(executor, make_node, tmp_path, map_text="wall 1 1 1 2\n")
    rig.listen("scan", "odom")
    rig.drive(0.5)
    rig.step(4000)  # 40 s: 20 m away from the only wall
    rig.wait(lambda: time_from_msg(rig["scan"].last.header.stamp) >= 40.0 - 1e-9)
    assert rig.world.model.pose[0] == pytest.approx(20.0, abs=0.01)
    assert all(r == math.inf for r in rig["scan"].last.ranges)


def test_reset_and_set_pose(executor, make_node, tmp_path):
    rig = Rig(executor, make_node, tmp_path, initial_pose=[-1.0, 0.5, 0.3])
    rig.listen("overhead_pose")
    rig.drive(0.3, 0.2)
    rig.step(100)
    target = PoseStamped(pose=pose_msg(0.5, -0.5, -1.0))
    target.header.frame_id = "map"
    pub = rig.probe.create_publisher(PoseStamped, "set_pose", COMMAND_PUBLISHER_QOS)
    assert wait_for_match(rig.executor, pub)
    pub.publish(target)
    rig.wait(lambda: tuple(rig.world.model.pose[:2]) == pytest.approx((0.5, -0.5)))
    assert rig.world.model.pose[2] == pytest.approx(-1.0)
    # Inside a wall: ignored with a warning, the robot stays where it was.
    pub.publish(PoseStamped(pose=pose_msg(2.0, 0.0, 0.0)))
    rig.step(5)
    drain(rig.executor)
    assert rig.world.model.pose[0] != pytest.approx(2.0, abs=0.1)
    assert rig.call(Trigger, "reset", Trigger.Request()).success
    assert tuple(rig.world.model.pose) == pytest.approx((-1.0, 0.5, 0.3))
    assert rig.world.model.command == (0.0, 0.0)
    assert tuple(rig.world.model.odometry_pose) == (0.0, 0.0, 0.0)
    rig.step(10)
    rig.wait(lambda: time_from_msg(rig["overhead_pose"].last.header.stamp) >= rig.world.sim_time - 1e-9)
    assert yaw_from_quaternion(rig["overhead_pose"].last.pose.orientation) == pytest.approx(0.3)


def test_com_delay_delays_commands_and_sensor_messages(executor, make_node, tmp_path):
    rig = Rig(executor, make_node, tmp_path, config_text="com_delay 0.2\n")
    rig.listen("odom")
    rig.drive(0.5)  # received at t = 0, takes effect at t = 0.2
    rig.step(19)
    assert rig.world.model.pose[0] == 0.0
    assert rig["odom"].msgs == []  # the first reading (t = 0.02) is published at t = 0.22
    rig.step(30)  # t = 0.5
    assert rig.world.model.pose[0] == pytest.approx(0.15, abs=1e-6)
    rig.wait(lambda: rig["odom"].msgs and time_from_msg(rig["odom"].last.header.stamp) >= 0.3 - 1e-9)
    stamps = [time_from_msg(m.header.stamp) for m in rig["odom"].msgs]
    assert max(stamps) == pytest.approx(0.3)  # published at 0.5: measured 0.2 s earlier


def test_namespace_prefixes_robot_frames(executor, make_node, tmp_path):
    rig = Rig(executor, make_node, tmp_path)
    world = CreateWorldNode(namespace="robot2", parameter_overrides=[Parameter("map_file", value="")])
    executor.add_node(world)
    scan = Collector(rig.probe, LaserScan, "/robot2/scan", SENSOR_SUBSCRIBER_QOS)
    odom = Collector(rig.probe, Odometry, "/robot2/odom", SENSOR_SUBSCRIBER_QOS)
    assert wait_for_match(executor, scan.subscription) and wait_for_match(executor, odom.subscription)
    world.step(10)
    assert spin_until(executor, lambda: scan.last is not None and odom.last is not None)
    assert scan.last.header.frame_id == "robot2/laser"
    # Each robot has its own odometry frame (REP-105 with a prefix per robot).
    assert odom.last.header.frame_id == "robot2/odom" and odom.last.child_frame_id == "robot2/base_link"
    explicit = CreateWorldNode(
        namespace="robot3",
        parameter_overrides=[Parameter("map_file", value=""), Parameter("frame_prefix", value="kitchen/create_")],
    )
    assert explicit.frame("laser") == "kitchen/create_laser"
    explicit.destroy_node()


def test_bump_turn_escapes_a_wall(executor, make_node, tmp_path):
    rig = Rig(executor, make_node, tmp_path, initial_pose=[1.5, 0.5, 0.0])
    controller = BumpTurnNode()
    executor.add_node(controller)
    for subscription in controller.subscriptions:
        assert wait_for_match(executor, subscription)
    assert wait_for_match(executor, controller.cmd_pub)
    touching = 0
    for _ in range(1500):  # 15 s in a 4 m room, starting 0.34 m from a wall
        rig.step()
        touching += rig.world.model.clearance() < 1e-3
    assert controller.bumps >= 2
    assert touching < 0.2 * 1500  # each bump is followed by backing off, not pushing on


def test_demo_runs_bump_turn_on_the_example_map(ros):
    summary = demo(5.0)
    assert summary["sim_seconds"] == pytest.approx(5.0)
    assert summary["distance_m"] > 1.0  # 0.3 m/s forward most of the time
    assert len(summary["final_pose"]) == 3 and summary["bumps"] >= 0


def test_bad_row_in_the_map_file_names_parameter_file_line_and_value(ros, tmp_path):
    map_file = tmp_path / "bad.map"
    map_file.write_text("wall 0 0 1 1\nwall 0 0 x 1\n")
    with pytest.raises(InputError, match=r"'map_file'.*bad.map:2.*'x'"):
        make_world({"map_file": str(map_file)})


def test_seeded_noise_does_not_depend_on_who_listens(executor, make_node, tmp_path):
    config = tmp_path / "noisy.cfg"
    config.write_text("odometry -0.02 0.06\nsonar 0 0.004\nlidar 0 0.001\ncamera 0 0.02\ncliff 3 6.9\nwall 0 0.01\n")
    map_file = tmp_path / "room.map"
    map_file.write_text(ROOM)
    params = [
        Parameter("map_file", value=str(map_file)),
        Parameter("config_file", value=str(config)),
        Parameter("seed", value=7),
    ]
    heard = CreateWorldNode(namespace="heard", parameter_overrides=params)
    alone = CreateWorldNode(namespace="alone", parameter_overrides=params)
    probe = make_node("noise_probe")
    executor.add_node(heard)
    executor.add_node(alone)
    collectors = [
        Collector(probe, msg_type, f"/heard/{topic}", SENSOR_SUBSCRIBER_QOS)
        for topic, msg_type in SENSOR_TOPICS.items()
    ]
    odom = Collector(probe, Odometry, "/alone/odom", SENSOR_SUBSCRIBER_QOS)
    for c in [*collectors, odom]:
        assert wait_for_match(executor, c.subscription)
    for world in (heard, alone):
        world.command(0.3, 0.4)
        world.step(150)
    assert tuple(heard.model.odometry_pose) == tuple(alone.model.odometry_pose)
    assert tuple(heard.model.odometry_pose) != pytest.approx(tuple(heard.model.pose))  # noise did act


def _bumper(pressed: bool, t: float) -> Range:
    msg = Range(range=-math.inf if pressed else math.inf)
    msg.header.stamp = time_msg(t)
    return msg


@pytest.mark.parametrize(("left", "right", "turn_sign"), [(True, False, -1), (False, True, 1), (True, True, 1)])
def test_bump_turn_backs_up_then_turns_away_from_the_bumper_hit(ros, left, right, turn_sign):
    controller = BumpTurnNode()
    try:
        t = 0.0
        for pressed_left, pressed_right in [(False, False), (left, right)] + [(False, False)] * 60:
            t += 0.02
            controller.on_bump("left", _bumper(pressed_left, t))
            controller.on_bump("right", _bumper(pressed_right, t))
            if controller.state == "turn":
                break
        assert controller.bumps == 1
        assert controller.state == "turn" and t == pytest.approx(0.04 + 0.5)  # backed up for 0.5 s first
        assert math.copysign(1, controller.turn_rate) == turn_sign
    finally:
        controller.destroy_node()


@pytest.mark.parametrize("rtf", [0.0, 1.0])
def test_create_world_process_serves_another_process(executor, make_node, rtf):
    """The README's two-terminal use: `robot_sims create_world` and the user's own node."""
    root = Path(__file__).resolve().parent.parent
    world = subprocess.Popen(
        executable_command("create_world", ["--ros-args", "-p", f"real_time_factor:={rtf}", "-r", "__ns:=/e2e"]),
        env=dict(os.environ, PYTHONPATH=str(root)),
        cwd=root,
        stderr=subprocess.PIPE,
        text=True,
    )
    try:
        probe = make_node("user_node")
        odom = Collector(probe, Odometry, "/e2e/odom", SENSOR_SUBSCRIBER_QOS)
        scan = Collector(probe, LaserScan, "/e2e/scan", SENSOR_SUBSCRIBER_QOS)
        cmd = probe.create_publisher(Twist, "/e2e/cmd_vel", COMMAND_PUBLISHER_QOS)
        for endpoint in (odom.subscription, scan.subscription, cmd):
            assert wait_for_match(executor, endpoint, timeout=30.0)
        assert spin_until(executor, lambda: odom.last is not None and scan.last is not None, timeout=10.0)
        assert len(scan.last.ranges) == 681 and scan.last.header.frame_id == "e2e/laser"
        forward = Twist()
        forward.linear.x = 0.5
        cmd.publish(forward)
        assert spin_until(executor, lambda: odom.last.pose.pose.position.x > 0.2, timeout=10.0)
        world.send_signal(signal.SIGINT)  # Ctrl-C
        assert world.wait(timeout=10.0) == 0
        errors = world.stderr.read()
        assert "Traceback" not in errors and "FATAL" not in errors, errors
    finally:
        if world.poll() is None:
            world.kill()
            world.wait()


# ---------------------------------------------------------------- what Nav2 / robot_localization users expect
def test_base_footprint_sonar_cone_and_odometry_covariances_as_nav2_expects_them(rig):
    """REP-120's base_footprint in TF, a sonar cone a range layer can use, and covariances an EKF can
    fuse although the world is noise-free (the rounding variance of what the Create resolves)."""
    tf = TfBuffer(rig.probe)
    for subscription in tf.subscriptions:
        assert wait_for_match(rig.executor, subscription)
    rig.listen("odom", "sonar/front")
    rig.drive(0.2, 0.5)
    rig.step(20)
    rig.wait(lambda: tf.can_transform("odom", "base_footprint") and rig["sonar/front"].last is not None)
    np.testing.assert_allclose(tf.lookup("base_link", "base_footprint"), np.eye(4), atol=1e-12)
    assert rig["sonar/front"].last.field_of_view == pytest.approx(SONAR_FIELD_OF_VIEW)
    assert 0.05 < SONAR_FIELD_OF_VIEW < 0.06  # the cone within which one ray reads as a cone, to 1 mm at 3 m
    odom = rig["odom"].last
    pose, twist = np.reshape(odom.pose.covariance, (6, 6)), np.reshape(odom.twist.covariance, (6, 6))
    step_m, step_rad, step_speed = ODOMETRY_RESOLUTION
    assert np.diag(pose)[[0, 1, 5]] == pytest.approx([step_m**2 / 12, step_m**2 / 12, step_rad**2 / 12])
    assert twist[0, 0] == pytest.approx(step_speed**2 / 12) and twist[5, 5] > 0.0
    assert np.count_nonzero(pose - np.diag(np.diag(pose))) == 0  # independent errors, z/roll/pitch exact


def test_the_wheels_joint_states_follow_the_odometry_and_the_urdf_names_them(rig):
    joints = Collector(rig.probe, JointState, "joint_states", SENSOR_SUBSCRIBER_QOS)
    assert wait_for_match(rig.executor, joints.subscription)
    rig.listen("odom")

    def settle() -> tuple[JointState, Odometry]:
        """The latest joint state and the odometry of the same instant."""
        rig.step(1)
        now = rig.world.sim_time
        stamped = lambda c: c.last is not None and time_from_msg(c.last.header.stamp) >= now - 0.02 - 1e-9  # noqa: E731
        rig.wait(lambda: stamped(joints) and stamped(rig["odom"]))
        pair = [(j, o) for j in joints.msgs for o in rig["odom"].msgs if j.header.stamp == o.header.stamp]
        return pair[-1]

    rig.drive(0.2)
    rig.step(100)  # 1 s straight at 0.2 m/s
    state, odom = settle()
    assert list(state.name) == ["left_wheel_joint", "right_wheel_joint"]
    assert list(state.position) == pytest.approx([odom.pose.pose.position.x / WHEEL_RADIUS_M] * 2)
    assert list(state.velocity) == pytest.approx([0.2 / WHEEL_RADIUS_M] * 2)
    rig.drive(0.0, 1.0)  # on the spot, counter-clockwise: the left wheel backwards, the right forwards
    rig.step(50)
    turned_state, turned_odom = settle()
    turned = yaw_from_quaternion(turned_odom.pose.pose.orientation) - yaw_from_quaternion(odom.pose.pose.orientation)
    wheel = 0.5 * WHEEL_BASE_M * turned / WHEEL_RADIUS_M
    expected = [state.position[0] - wheel, state.position[1] + wheel]
    assert list(turned_state.position) == pytest.approx(expected, abs=1e-6)
    assert turned_state.velocity[0] == pytest.approx(-turned_state.velocity[1])
    urdf = yourdfpy.URDF.load(io.StringIO(create_urdf()), load_meshes=False)
    assert urdf.actuated_joint_names == list(state.name)
    assert "base_footprint" in urdf.link_map


def test_an_empty_map_publishes_no_grid_and_switching_to_one_withdraws_the_old_grid(executor, make_node, tmp_path):
    world = make_world({"map_file": "", "real_time_factor": 0.0})
    executor.add_node(world)
    probe = make_node("probe")

    def late_joiner() -> Collector:
        grids = Collector(probe, OccupancyGrid, "map", LATCHED_QOS)
        assert wait_for_match(executor, grids.subscription)
        markers = Collector(probe, MarkerArray, "map_markers", LATCHED_QOS)  # latched too: comes with it
        assert wait_for_match(executor, markers.subscription)
        assert spin_until(executor, lambda: markers.last is not None)
        world.step(5)
        drain(executor)
        return grids

    assert late_joiner().msgs == []  # as map_server without a map: no grid, never a 0 x 0 one
    room = tmp_path / "room.map"
    room.write_text(ROOM)
    assert world.set_parameters([Parameter("map_file", value=str(room))])[0].successful
    walls = late_joiner()
    assert spin_until(executor, lambda: walls.last is not None)
    assert walls.last.info.width > 0 and walls.last.info.height > 0
    assert world.set_parameters([Parameter("map_file", value="")])[0].successful
    # the grid's publisher is replaced: once the old one has left the graph, nobody gets the room's walls
    assert spin_until(executor, lambda: probe.count_publishers("/map") == 1)
    assert late_joiner().msgs == []
