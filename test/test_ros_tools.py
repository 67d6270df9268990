"""What ROS tools and tutorial-style nodes rely on: reliable publishers, TF, live parameters."""

from __future__ import annotations

import math

import numpy as np
import pytest
from geometry_msgs.msg import PoseStamped, Twist
from nav_msgs.msg import Odometry
from rcl_interfaces.msg import ParameterType
from rclpy.parameter import Parameter
from rclpy.parameter_client import AsyncParameterClient
from sensor_msgs.msg import BatteryState, Illuminance, JointState, LaserScan, Range
from std_msgs.msg import UInt8
from visualization_msgs.msg import MarkerArray

from arm_sim.arm_node import ArmNode
from create_sim.spec import FOOTPRINT_FRAME, SENSOR_MOUNTS
from create_sim.world_node import CreateWorldNode
from sim_runtime.msgs import time_from_msg
from sim_runtime.qos import COMMAND_PUBLISHER_QOS
from sim_runtime.testing import Collector, TfBuffer, drain, spin_until, wait_for_match
from simrobot_sim.avoid import AvoidNode
from simrobot_sim.world_file import RobotSpec, SensorSpec, WorldSpec
from simrobot_sim.world_node import SimrobotWorldNode

ROOM = "wall -2 -2 2 -2\nwall 2 -2 2 2\nwall 2 2 -2 2\nwall -2 2 -2 -2\nwall 0.8 -0.6 0.8 0.6\n"

CREATE_TOPICS = {
    "odom": Odometry,
    "overhead_pose": PoseStamped,
    "bump/left": Range,
    "bump/right": Range,
    "wall": Range,
    "virtual_wall": Range,
    "cliff/left": Illuminance,
    "cliff/front_right": Illuminance,
    "sonar/front": Range,
    "sonar/back": Range,
    "scan": LaserScan,
    "camera/beacons": MarkerArray,
    "battery_state": BatteryState,
    "joint_states": JointState,
}


def overrides(**params) -> list[Parameter]:
    return [Parameter(k, value=v) for k, v in params.items()]


def step(executor, world, n: int) -> None:
    for _ in range(n):
        world.step()
        drain(executor)


def create_world(executor, tmp_path, map_text: str = ROOM, **params) -> CreateWorldNode:
    map_file = tmp_path / "room.map"
    map_file.write_text(map_text)
    world = CreateWorldNode(
        parameter_overrides=overrides(**{"map_file": str(map_file), "real_time_factor": 0.0, **params})
    )
    executor.add_node(world)
    return world


def simrobot_world(executor) -> SimrobotWorldNode:
    walls = np.zeros((200, 150), dtype=bool)
    walls[0, :] = walls[-1, :] = walls[:, 0] = walls[:, -1] = True
    walls[140:150, 40:110] = True  # a block ahead of the robot
    laser = SensorSpec(
        "scan", "laser", position=(0.05, 0.02), axis=0.3, beamwidth=math.radians(120), range=3.0, rays=41
    )
    sonar = SensorSpec("front", "ultrasonic", position=(0.05, 0.0), range=0.8, rays=5)
    spec = WorldSpec(walls=walls, robots=(RobotSpec("r1", (0.6, 0.7), heading=0.2, sensors=(laser, sonar)),))
    world = SimrobotWorldNode(spec)
    executor.add_node(world)
    return world


# -- a subscriber written as the tutorials teach: create_subscription(T, topic, cb, 10) ----------
def test_a_default_reliable_subscriber_hears_every_create_sensor(executor, make_node, tmp_path):
    world = create_world(executor, tmp_path)
    probe = make_node("tutorial")
    heard = {topic: Collector(probe, msg_type, topic, 10) for topic, msg_type in CREATE_TOPICS.items()}
    for collector in heard.values():
        assert wait_for_match(executor, collector.subscription)
    step(executor, world, 100)
    assert spin_until(executor, lambda: all(c.msgs for c in heard.values()))


def test_a_default_reliable_subscriber_hears_every_simrobot_topic(executor, make_node):
    world = simrobot_world(executor)
    probe = make_node("tutorial")
    topics = {"r1/scan": LaserScan, "r1/front": Range, "r1/front/obstacle": UInt8, "r1/odom": Odometry}
    topics |= {"r1/pose": PoseStamped, "robots": MarkerArray}
    heard = {topic: Collector(probe, msg_type, topic, 10) for topic, msg_type in topics.items()}
    for collector in heard.values():
        assert wait_for_match(executor, collector.subscription)
    step(executor, world, 1)
    assert spin_until(executor, lambda: all(c.msgs for c in heard.values()))


def test_a_default_reliable_subscriber_hears_the_arm(executor, make_node):
    world = ArmNode(parameter_overrides=overrides(real_time_factor=0.0))
    executor.add_node(world)
    probe = make_node("tutorial")
    heard = [
        Collector(probe, JointState, "joint_states", 10),
        Collector(probe, MarkerArray, "robot_markers", 10),
        Collector(probe, PoseStamped, "end_effector_pose", 10),
    ]
    for collector in heard:
        assert wait_for_match(executor, collector.subscription)
    step(executor, world, 5)
    assert spin_until(executor, lambda: all(c.msgs for c in heard))


def test_a_best_effort_command_publisher_drives_a_create_started_with_the_qos_override(executor, make_node, tmp_path):
    from rclpy.qos import qos_profile_sensor_data

    world = create_world(executor, tmp_path, **{"qos_overrides./cmd_vel.subscription.reliability": "best_effort"})
    pub = make_node("joystick").create_publisher(Twist, "cmd_vel", qos_profile_sensor_data)
    assert wait_for_match(executor, pub)
    pub.publish(Twist())
    assert spin_until(executor, lambda: world.commands_received == 1)


# -- TF -------------------------------------------------------------------------------------
def _segment_distance(points: np.ndarray, segments: np.ndarray) -> np.ndarray:
    """Distance of each point (n, 2) to the nearest of ``segments`` (m, 4)."""
    p = points[:, None, :]
    a, b = segments[None, :, :2], segments[None, :, 2:]
    ab = b - a
    t = np.clip(((p - a) * ab).sum(-1) / (ab * ab).sum(-1), 0.0, 1.0)
    return np.linalg.norm(a + t[..., None] * ab - p, axis=-1).min(axis=1)


def _scan_points(scan: LaserScan) -> tuple[np.ndarray, np.ndarray]:
    """Returns (n, 4) homogeneous points in the scan's frame and their ray directions (n, 2)."""
    ranges = np.asarray(scan.ranges, dtype=float)
    angles = scan.angle_min + scan.angle_increment * np.arange(len(ranges))
    hit = np.isfinite(ranges) & (ranges < scan.range_max) & (ranges > scan.range_min)
    r, a = ranges[hit], angles[hit]
    points = np.column_stack([r * np.cos(a), r * np.sin(a), np.zeros_like(r), np.ones_like(r)])
    return points, np.column_stack([np.cos(a), np.sin(a)])


def test_every_lidar_return_of_the_create_lands_on_a_wall_through_tf(executor, make_node, tmp_path, tf2_msgs):
    world = create_world(executor, tmp_path, initial_pose=[-0.5, 0.3, 0.4], publish_map_tf=True)
    probe = make_node("tf_listener")
    tf = TfBuffer(probe)
    scans = Collector(probe, LaserScan, "scan", 10)
    assert wait_for_match(executor, scans.subscription)
    assert spin_until(executor, lambda: "laser" in tf.parent)  # /tf_static is latched
    cmd = probe.create_publisher(Twist, "cmd_vel", COMMAND_PUBLISHER_QOS)
    assert wait_for_match(executor, cmd)
    cmd.publish(Twist(linear=world_vector(0.2), angular=world_vector(0.0, 0.0, 0.5)))
    assert spin_until(executor, lambda: world.commands_received == 1)
    step(executor, world, 150)  # drives a curve for 1.5 s; the last scan and /tf are at 1.5 s
    scan = scans.last
    assert time_from_msg(scan.header.stamp) == pytest.approx(1.5)
    assert tf.stamp["base_link"] == pytest.approx(1.5)
    assert tf.chain("laser") == ["laser", "base_link", "odom", "map"]
    points, _ = _scan_points(scan)
    assert len(points) > 500
    in_map = (tf.lookup("map", scan.header.frame_id) @ points.T).T[:, :2]
    assert _segment_distance(in_map, world.map.walls).max() < 0.01


def world_vector(x: float = 0.0, y: float = 0.0, z: float = 0.0):
    from geometry_msgs.msg import Vector3

    return Vector3(x=x, y=y, z=z)


def test_every_create_sensor_frame_is_on_tf_static_at_its_mount(executor, make_node, tmp_path, tf2_msgs):
    create_world(executor, tmp_path, frame_prefix="robot1/")
    tf = TfBuffer(make_node("tf_listener"))
    assert spin_until(executor, lambda: all(f"robot1/{name}" in tf.parent for name in SENSOR_MOUNTS))
    assert spin_until(executor, lambda: "robot1/base_footprint" in tf.parent)
    assert tf.parent["robot1/base_footprint"] == "robot1/base_link"  # REP-120, for Nav2's AMCL
    assert tf.matrix["robot1/base_footprint"] == pytest.approx(np.eye(4))
    for name, mount in SENSOR_MOUNTS.items():
        assert tf.parent[f"robot1/{name}"] == "robot1/base_link"
        m = tf.matrix[f"robot1/{name}"]
        assert m[:3, 3] == pytest.approx([mount.x_m, mount.y_m, mount.z_m])
        assert math.atan2(m[1, 0], m[0, 0]) == pytest.approx(mount.yaw_rad)


def test_every_laser_return_of_a_simrobot_robot_lands_on_a_wall_through_tf(executor, make_node, tf2_msgs):
    world = simrobot_world(executor)
    probe = make_node("tf_listener")
    tf = TfBuffer(probe)
    scans = Collector(probe, LaserScan, "r1/scan", 10)
    assert wait_for_match(executor, scans.subscription)
    wheels = probe.create_publisher(JointState, "r1/wheel_cmd", COMMAND_PUBLISHER_QOS)
    assert wait_for_match(executor, wheels)
    wheels.publish(JointState(velocity=[2.0, 3.0]))
    assert spin_until(executor, lambda: world._answered.any())
    step(executor, world, 4)
    assert spin_until(executor, lambda: "r1/scan" in tf.parent and "r1/base_link" in tf.parent)
    scan = scans.last
    assert tf.stamp["r1/base_link"] == time_from_msg(scan.header.stamp) == pytest.approx(4.0)
    assert tf.chain("r1/scan") == ["r1/scan", "r1/base_link", "r1/odom", "map"]
    points, _ = _scan_points(scan)
    assert len(points) > 20
    in_map = (tf.lookup("map", "r1/scan") @ points.T).T[:, :2]
    res = world.spec.resolution
    cells = np.argwhere(world.spec.walls)
    lo, hi = cells * res, (cells + 1) * res
    # distance from each point to the nearest occupied cell (an axis-aligned square)
    gap = np.maximum(np.maximum(lo[None] - in_map[:, None], in_map[:, None] - hi[None]), 0.0)
    assert np.linalg.norm(gap, axis=-1).min(axis=1).max() < 0.01


def test_without_tf2_msgs_the_create_world_says_tf_is_off_once_and_keeps_working(
    executor, make_node, tmp_path, monkeypatch, capfd
):
    import sim_runtime.tf

    monkeypatch.setattr(sim_runtime.tf, "TFMessage", None)
    world = create_world(executor, tmp_path)
    scans = Collector(make_node("probe"), LaserScan, "scan", 10)
    assert wait_for_match(executor, scans.subscription)
    step(executor, world, 10)
    assert spin_until(executor, lambda: scans.msgs)
    err = capfd.readouterr().err
    assert err.count("TF is off") == 1 and "tf2_msgs is not installed" in err


# -- parameters, the way `ros2 param set/get/describe` reach a node --------------------------
class Params:
    def __init__(self, executor, node, remote: str) -> None:
        self.executor = executor
        self.client = AsyncParameterClient(node, remote)
        assert self.client.wait_for_services(timeout_sec=5.0)

    def _wait(self, future):
        assert spin_until(self.executor, future.done)
        return future.result()

    def set(self, name: str, value):
        return self._wait(self.client.set_parameters([Parameter(name, value=value)])).results[0]

    def get(self, name: str):
        return self._wait(self.client.get_parameters([name])).values[0]

    def describe(self, names: list[str]):
        return self._wait(self.client.describe_parameters(names)).descriptors

    def names(self) -> list[str]:
        return list(self._wait(self.client.list_parameters()).result.names)


@pytest.fixture
def create_params(executor, make_node, tmp_path):
    world = create_world(executor, tmp_path)
    return world, Params(executor, make_node("ros2_param"), "/create_world")


@pytest.mark.parametrize(
    ("name", "value", "reason"),
    [
        ("real_time_factor", -1.0, "out of range"),
        ("real_time_factor", "abc", "type"),
        ("rate.scan", 500.0, "out of range"),
        ("cmd_vel_timeout", math.nan, "out of range"),
        ("cmd_vel_stamped", True, "read-only"),
        ("initial_pose", [1.0, 0.0, 0.0], "read-only"),
        ("frame_prefix", "x/", "read-only"),
        ("seed", 3, "read-only"),
        ("map_file", "no_such.map", "no such file"),
    ],
)
def test_ros2_param_set_refuses_bad_and_read_only_values_with_a_reason(create_params, name, value, reason):
    _world, params = create_params
    before = params.get(name)
    result = params.set(name, value)
    assert not result.successful
    assert reason in result.reason.lower()
    after = params.get(name)
    assert after.type == before.type and after == before  # the node keeps what it uses


def test_ros2_param_set_applies_a_live_rate_at_once_even_given_as_a_whole_number(executor, make_node, create_params):
    world, params = create_params
    scans = Collector(make_node("probe"), LaserScan, "scan", 10)
    assert wait_for_match(executor, scans.subscription)
    assert params.set("rate.scan", 5).successful  # `ros2 param set /create_world rate.scan 5` sends an int
    assert params.get("rate.scan").type == ParameterType.PARAMETER_DOUBLE
    step(executor, world, 200)
    assert spin_until(executor, lambda: len(scans.msgs) >= 10)
    assert len(scans.msgs) == 10  # 2 s at 5 Hz


def test_ros2_param_set_changes_the_pace_of_a_running_world(create_params):
    world, params = create_params
    assert params.set("real_time_factor", 2).successful
    assert world.real_time_factor == 2.0


def test_a_live_map_file_loads_unless_it_puts_the_robot_in_a_wall(executor, make_node, tmp_path, create_params):
    world, params = create_params
    through_robot = tmp_path / "through.map"
    through_robot.write_text("wall -1 0 1 0\n")
    result = params.set("map_file", str(through_robot))
    assert not result.successful and "inside a wall" in result.reason
    beside = tmp_path / "beside.map"
    beside.write_text("wall 1 -1 1 1\n")
    assert params.set("map_file", str(beside)).successful
    scans = Collector(make_node("probe"), LaserScan, "scan", 10)
    assert wait_for_match(executor, scans.subscription)
    step(executor, world, 10)
    assert spin_until(executor, lambda: scans.msgs)
    ahead = scans.last.ranges[len(scans.last.ranges) // 2]
    assert ahead == pytest.approx(1.0 - SENSOR_MOUNTS["laser"].x_m, abs=1e-6)


def test_every_parameter_of_every_node_has_a_description(executor, make_node, tmp_path):
    nodes = [
        create_world(executor, tmp_path),
        simrobot_world(executor),
        AvoidNode(robot="r1"),
    ]
    executor.add_node(nodes[-1])
    probe = make_node("ros2_param")
    for node in nodes:
        params = Params(executor, probe, node.get_fully_qualified_name())
        names = [n for n in params.names() if n != "use_sim_time" and not n.startswith("qos_overrides")]
        assert names
        for descriptor in params.describe(names):
            assert descriptor.description, f"{node.get_name()}: {descriptor.name} has no description"
            assert descriptor.type != ParameterType.PARAMETER_NOT_SET and not descriptor.dynamic_typing


def test_ranges_show_in_ros2_param_describe(create_params):
    _, params = create_params
    (rate,) = params.describe(["rate.scan"])
    assert (rate.floating_point_range[0].from_value, rate.floating_point_range[0].to_value) == (0.0, 100.0)
    assert not rate.read_only
    (pose,) = params.describe(["initial_pose"])
    assert pose.read_only


def test_simrobot_topics_follow_the_namespace(executor, make_node):
    spec = WorldSpec(walls=np.zeros((50, 50), dtype=bool), robots=(RobotSpec("r1", (0.2, 0.2)),))
    world = SimrobotWorldNode(spec, namespace="/sim1")
    executor.add_node(world)
    probe = make_node("probe")
    odom = Collector(probe, Odometry, "/sim1/r1/odom", 10)
    assert wait_for_match(executor, odom.subscription)
    step(executor, world, 1)
    assert spin_until(executor, lambda: odom.msgs)
    assert odom.last.header.frame_id == "sim1/r1/odom"
    topics = {name for name, _ in probe.get_topic_names_and_types()}
    assert {"/sim1/map", "/sim1/robots", "/sim1/r1/cmd_vel"} <= topics


def test_a_sensor_publishers_qos_can_be_overridden_at_start_as_in_any_ros_driver(executor, tmp_path):
    from rclpy.qos import ReliabilityPolicy

    world = create_world(executor, tmp_path, **{"qos_overrides./scan.publisher.reliability": "best_effort"})
    assert world.pub_scan.qos_profile.reliability == ReliabilityPolicy.BEST_EFFORT
    assert world.pub_odom.qos_profile.reliability == ReliabilityPolicy.RELIABLE


def test_a_recorder_started_after_the_world_still_gets_its_static_transforms_and_replay_latches_them(
    executor, make_node, tmp_path, tf2_msgs
):
    from sim_runtime.bag.reader import open_bag
    from sim_runtime.bag.record import Recorder
    from sim_runtime.bag.replay import Player
    from sim_runtime.bag.writer import BagWriter

    world = create_world(executor, tmp_path, frame_prefix="late/")
    step(executor, world, 10)  # /tf_static went out before anyone recorded
    recorder = Recorder(BagWriter(tmp_path / "bag"), ["/tf", "/tf_static"], node_name="tf_recorder")
    executor.add_node(recorder)
    assert spin_until(executor, lambda: {"/tf", "/tf_static"} <= set(recorder.topic_ids))
    probe = make_node("tf_probe")
    tf_probe = TfBuffer(probe)  # subscribing to /tf makes the world publish it
    assert spin_until(executor, lambda: world.tf.heard())
    step(executor, world, 10)

    def recorded(topic: str) -> int:
        return recorder.writer.topic_message_count(recorder.topic_ids[topic])

    assert spin_until(executor, lambda: recorded("/tf_static") >= 1 and recorded("/tf") >= 1)
    recorder.close()
    executor.remove_node(recorder)
    recorder.destroy_node()
    bag = open_bag(tmp_path / "bag")
    static = [m.msg for m in bag.messages() if m.topic == "/tf_static"]
    # every sensor's mount and the footprint (REP-120) under base_link
    assert {t.child_frame_id for t in static[0].transforms} == {f"late/{n}" for n in (*SENSOR_MOUNTS, FOOTPRINT_FRAME)}
    assert any(m.topic == "/tf" for m in bag.messages())
    assert "transient_local" in bag.topic_metadata["/tf_static"]["offered_qos_profiles"]

    # replayed, the static transforms stay latched: a listener joining after the replay started gets them
    executor.remove_node(world)
    world.destroy_node()
    player = Player(open_bag(tmp_path / "bag"), node_name="tf_player", topics=["/tf_static"], rate=100.0)
    executor.add_node(player)
    player.start()
    assert spin_until(executor, player.finished.done, timeout=10.0)
    late = TfBuffer(make_node("late_listener"))
    assert spin_until(executor, lambda: "late/laser" in late.parent)
    assert tf_probe.parent


def test_the_create_publishes_a_latched_robot_description_with_every_sensor_frame(executor, make_node, tmp_path):
    import yourdfpy
    from std_msgs.msg import String

    from sim_runtime.qos import LATCHED_QOS

    create_world(executor, tmp_path, frame_prefix="robot1/")
    description = Collector(make_node("robot_state_publisher"), String, "robot_description", LATCHED_QOS)
    assert spin_until(executor, lambda: description.msgs)
    urdf = tmp_path / "create.urdf"
    urdf.write_text(description.last.data)
    robot = yourdfpy.URDF.load(str(urdf), load_meshes=False)
    assert {f"robot1/{name}" for name in SENSOR_MOUNTS} <= set(robot.link_map)
    assert robot.base_link == "robot1/base_link"
    assert robot.actuated_joint_names == ["robot1/left_wheel_joint", "robot1/right_wheel_joint"]


def test_a_paused_world_holds_its_time_and_the_step_service_advances_one_physics_step(executor, make_node, tmp_path):
    import time

    from std_srvs.srv import Trigger

    world = create_world(executor, tmp_path, real_time_factor=1.0)
    probe = make_node("gui")
    params = Params(executor, probe, "/create_world")
    assert params.set("paused", True).successful
    world.start_pacing()
    world._pace_origin = (time.monotonic() - 1.0, 0.0)  # a second of wall time is due...
    world._pace()
    assert world.sim_time == 0.0  # ...but a paused world does not step
    client = probe.create_client(Trigger, "step")
    assert client.wait_for_service(timeout_sec=5.0)
    future = client.call_async(Trigger.Request())
    assert spin_until(executor, future.done)
    assert future.result().success and world.sim_time == pytest.approx(0.01)
    assert params.set("paused", False).successful
    assert spin_until(executor, lambda: world.sim_time > 0.05)
    future = client.call_async(Trigger.Request())
    assert spin_until(executor, future.done)
    assert not future.result().success and "not paused" in future.result().message
