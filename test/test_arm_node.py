"""The arm node through its topics (launch-free: node and test node in one executor)."""

from __future__ import annotations

import io
import math
import os
import subprocess
from pathlib import Path

import numpy as np
import pytest
import yourdfpy
from builtin_interfaces.msg import Duration
from geometry_msgs.msg import PoseStamped
from rclpy.parameter import Parameter
from rclpy.parameter_client import AsyncParameterClient
from sensor_msgs.msg import JointState
from std_msgs.msg import String
from trajectory_msgs.msg import JointTrajectory, JointTrajectoryPoint
from visualization_msgs.msg import Marker, MarkerArray

from arm_sim.arm import Arm
from arm_sim.arm_node import ArmNode
from sim_runtime.msgs import matrix_from_quaternion, quaternion_from_matrix
from sim_runtime.paths import config_path, mesh_uri
from sim_runtime.qos import COMMAND_PUBLISHER_QOS, LATCHED_QOS, SENSOR_SUBSCRIBER_QOS, TF_QOS
from sim_runtime.testing import Collector, TfBuffer, drain, spin_until, wait_for_match
from sim_tools.cli import executable_command

JOINTS = [f"joint_{i}" for i in range(1, 7)]


def make_arm_node(executor, node_name: str = "arm", **params) -> ArmNode:
    node = ArmNode(node_name, parameter_overrides=[Parameter(k, value=v) for k, v in params.items()])
    executor.add_node(node)
    return node


@pytest.fixture
def world(executor):
    return make_arm_node(executor)


def publish_and_wait(executor, node, topic, msg_type, msg, done):
    """Publish on ``topic`` once the arm subscribes, spin until ``done()``."""
    pub = node.create_publisher(msg_type, topic, COMMAND_PUBLISHER_QOS)
    assert wait_for_match(executor, pub)
    pub.publish(msg)
    assert spin_until(executor, done), f"{topic} message not handled"


def collect(executor, node, msg_type, topic, qos=SENSOR_SUBSCRIBER_QOS) -> Collector:
    collector = Collector(node, msg_type, topic, qos)
    assert wait_for_match(executor, collector.subscription)
    return collector


def run(executor, world, steps):
    """Step the world one physics step at a time, delivering every message in between (the
    reliable depth-10 queues would drop older messages of a long burst)."""
    for _ in range(steps):
        world.step()
        drain(executor)


def trajectory(points, names=JOINTS) -> JointTrajectory:
    msg = JointTrajectory(joint_names=list(names))
    for t, positions in points:
        msg.points.append(
            JointTrajectoryPoint(
                positions=[float(p) for p in positions],
                time_from_start=Duration(sec=int(t), nanosec=int(round((t % 1) * 1e9))),
            )
        )
    return msg


def stamp_seconds(msg) -> float:
    return msg.header.stamp.sec + 1e-9 * msg.header.stamp.nanosec


def test_trajectory_reaches_its_points_on_time_within_velocity_limits(executor, make_node, world):
    test = make_node()
    states = collect(executor, test, JointState, "joint_states")
    arm = world.arm("")
    goal1 = [0.3, -0.2, 0.1, 0.4, -0.3, 0.5]
    goal2 = [0.6, 0.2, -0.3, 0.0, 0.5, -0.5]
    publish_and_wait(
        executor,
        test,
        "joint_trajectory",
        JointTrajectory,
        trajectory([(1.0, goal1), (2.0, goal2)]),
        lambda: np.allclose(arm.motion.goal, goal2),
    )
    start = world.sim_time
    run(executor, world, 200)
    assert spin_until(executor, lambda: states.msgs and stamp_seconds(states.last) >= start + 2.0 - 1e-9)
    by_time = {round(stamp_seconds(m) - start, 6): m for m in states.msgs}
    np.testing.assert_allclose(by_time[1.0].position, goal1, atol=1e-9)
    np.testing.assert_allclose(by_time[2.0].position, goal2, atol=1e-9)
    vmax = world.arm("").arm.velocity_limits
    for m in states.msgs:
        assert np.all(np.abs(m.velocity) <= vmax + 1e-9)
        assert len(m.effort) == 6 and np.isfinite(m.effort).all()


def test_too_fast_trajectory_is_followed_at_the_velocity_limit(executor, make_node, world):
    test = make_node()
    states = collect(executor, test, JointState, "joint_states")
    arm = world.arm("")
    goal = [1.5, 0.0, 0.0, 0.0, 0.0, 0.0]  # 1.5 rad in 0.1 s: 15 rad/s against 4.36 rad/s
    publish_and_wait(
        executor,
        test,
        "joint_trajectory",
        JointTrajectory,
        trajectory([(0.1, goal)]),
        lambda: np.allclose(arm.motion.goal, goal),
    )
    run(executor, world, 100)
    assert spin_until(executor, lambda: len(states.msgs) >= 50)
    positions = np.array([m.position for m in states.msgs])
    times = np.array([stamp_seconds(m) for m in states.msgs])
    speeds = np.abs(np.diff(positions[:, 0])) / np.diff(times)
    assert speeds.max() <= np.radians(250) + 1e-6
    np.testing.assert_allclose(positions[-1], goal, atol=1e-9)  # caught up after 1.5/4.36 = 0.34 s


def test_joint_command_is_clamped_to_limits_and_moved_within_velocity_limits(executor, make_node, world):
    test = make_node()
    states = collect(executor, test, JointState, "joint_states")
    arm = world.arm("")
    command = JointState(name=["joint_3", "joint_1"], position=[2.0, -1.0])  # joint_3 max is +70°
    publish_and_wait(executor, test, "joint_command", JointState, command, lambda: arm.motion.goal[0] == -1.0)
    np.testing.assert_allclose(arm.motion.goal, [-1.0, 0, math.radians(70), 0, 0, 0])
    run(executor, world, 100)
    assert spin_until(executor, lambda: len(states.msgs) >= 50)
    final = states.last.position
    np.testing.assert_allclose(final, [-1.0, 0, math.radians(70), 0, 0, 0], atol=1e-9)
    vmax = arm.arm.velocity_limits
    assert all(np.all(np.abs(m.velocity) <= vmax + 1e-9) for m in states.msgs)
    # the move takes at least the time the slowest joint needs at full speed
    moving = [m for m in states.msgs if np.any(np.abs(m.velocity) > 0)]
    assert len(moving) / 50.0 >= 1.0 / np.radians(250) - 0.02


def test_target_pose_is_reached_within_a_millimetre(executor, make_node, world):
    test = make_node()
    poses = collect(executor, test, PoseStamped, "end_effector_pose")
    arm = world.arm("")
    target_q = np.array([0.4, 0.3, -0.2, 0.5, 0.6, -0.3])
    T = arm.arm.fkine(target_q)
    msg = PoseStamped()
    msg.header.frame_id = "world"
    msg.pose.position.x, msg.pose.position.y, msg.pose.position.z = T[:3, 3].tolist()
    q = quaternion_from_matrix(T[:3, :3])
    # a non-unit quaternion is normalised, not rejected
    msg.pose.orientation.x, msg.pose.orientation.y = 2 * q.x, 2 * q.y
    msg.pose.orientation.z, msg.pose.orientation.w = 2 * q.z, 2 * q.w
    publish_and_wait(executor, test, "target_pose", PoseStamped, msg, lambda: arm.motion.moving)
    world.step(300)
    assert spin_until(executor, lambda: poses.msgs and stamp_seconds(poses.last) >= world.sim_time - 1e-9)
    reached = poses.last.pose
    position = np.array([reached.position.x, reached.position.y, reached.position.z])
    assert np.linalg.norm(position - T[:3, 3]) < 1e-3
    R = matrix_from_quaternion(reached.orientation)
    assert np.arccos(np.clip((np.trace(R.T @ T[:3, :3]) - 1) / 2, -1, 1)) < 1e-3


def test_unreachable_or_nan_target_pose_causes_no_motion(world):
    arm = world.arm("")
    msg = PoseStamped()
    msg.header.frame_id = "world"
    msg.pose.position.x = 3.0  # the IRB120 reaches 0.58 m
    msg.pose.orientation.w = 1.0
    arm.on_target_pose(msg)
    assert not arm.motion.moving
    msg.pose.position.x = 0.3
    msg.pose.orientation.w = math.nan
    arm.on_target_pose(msg)
    msg.pose.orientation.w = 1.0
    msg.header.frame_id = "elsewhere"
    arm.on_target_pose(msg)
    world.step(50)
    assert not arm.motion.moving
    np.testing.assert_array_equal(arm.motion.q, np.zeros(6))


def test_bad_commands_are_rejected_and_change_nothing(world):
    arm = world.arm("")
    goal = arm.motion.goal
    # non-increasing times
    arm.on_trajectory(trajectory([(1.0, [0.1] * 6), (1.0, [0.2] * 6)]))
    # wrong joint names
    arm.on_trajectory(trajectory([(1.0, [0.1] * 6)], names=[*JOINTS[:5], "elbow"]))
    # NaN position
    arm.on_trajectory(trajectory([(1.0, [0.1, math.nan, 0, 0, 0, 0])]))
    arm.on_joint_command(JointState(name=JOINTS, position=[0.1, math.inf, 0, 0, 0, 0]))
    arm.on_joint_command(JointState(name=["shoulder"], position=[0.1]))
    arm.on_joint_command(JointState(name=JOINTS[:2], position=[0.1]))
    np.testing.assert_array_equal(arm.motion.goal, goal)
    world.step(20)
    np.testing.assert_array_equal(arm.motion.q, np.zeros(6))


def test_new_trajectory_replaces_the_old(world):
    arm = world.arm("")
    arm.on_trajectory(trajectory([(1.0, [0.5] * 6)]))
    world.step(20)
    arm.on_trajectory(trajectory([(0.5, [0.0] * 6)]))
    world.step(100)
    np.testing.assert_allclose(arm.motion.q, np.zeros(6), atol=1e-12)


def test_markers_carry_meshes_colours_alpha_and_fk_poses(executor, make_node):
    world = make_arm_node(executor, marker_alpha=0.5)
    test = make_node()
    markers = collect(executor, test, MarkerArray, "robot_markers")
    world.step(2)
    assert spin_until(executor, lambda: markers.msgs)
    arm = world.arm("").arm
    meshes = [m for m in markers.last.markers if m.type == Marker.MESH_RESOURCE]
    assert len(meshes) == len(arm.elements) == 7
    assert any(m.type == Marker.LINE_LIST for m in markers.last.markers)  # RefSystem axes
    frames = arm.fkine_all(world.arm("").motion.q)
    for marker, element in zip(meshes, arm.elements, strict=True):
        assert marker.mesh_resource == mesh_uri(element.element.mesh)  # file:// in a checkout
        assert Path(marker.mesh_resource[len("file://") :]).is_file()
        assert marker.header.frame_id == "world"
        r, g, b, _a = element.element.color
        assert (marker.color.r, marker.color.g, marker.color.b) == pytest.approx((r, g, b))
        assert marker.color.a == pytest.approx(0.5)
        T = frames[element.link]
        p = marker.pose.position
        np.testing.assert_allclose([p.x, p.y, p.z], T[:3, 3], atol=1e-12)
        np.testing.assert_allclose(matrix_from_quaternion(marker.pose.orientation), T[:3, :3], atol=1e-9)


def test_two_arms_and_scene_objects_in_one_world(executor, make_node):
    world = make_arm_node(executor, scene_file="arm/workcell.yaml")
    test = make_node()
    scene = collect(executor, test, MarkerArray, "scene_markers", LATCHED_QOS)
    irb_states = collect(executor, test, JointState, "joint_states")
    csa_states = collect(executor, test, JointState, "csa/joint_states")
    csa_pose = collect(executor, test, PoseStamped, "csa/end_effector_pose")
    csa_markers = collect(executor, test, MarkerArray, "csa/robot_markers")
    assert spin_until(executor, lambda: scene.msgs)
    meshes = {m.ns: m for m in scene.last.markers if m.type == Marker.MESH_RESOURCE}
    assert set(meshes) == {"scene/table", "scene/box"}
    assert meshes["scene/table"].mesh_resource.endswith("/meshes/scene/table.stl")
    world.step(2)
    assert spin_until(executor, lambda: irb_states.msgs and csa_states.msgs and csa_pose.msgs and csa_markers.msgs)
    assert len(irb_states.last.position) == 6 and len(csa_states.last.position) == 7
    csa = Arm.from_file(config_path("arm/csa7.yaml"), load_meshes=False)
    expected = world.arm("csa/").arm.base @ csa.fkine(np.zeros(7))
    p = csa_pose.last.pose.position
    np.testing.assert_allclose([p.x, p.y, p.z], expected[:3, 3], atol=1e-9)
    assert p.x == pytest.approx(1.1)  # its base (scene file) stands across the table
    assert len([m for m in csa_markers.last.markers if m.type == Marker.MESH_RESOURCE]) == 24
    # the second arm moves on its own topic only
    world.arm("csa/").on_joint_command(JointState(name=["joint_2"], position=[0.5]))
    world.step(200)
    assert world.arm("csa/").motion.q[1] == pytest.approx(0.5)
    np.testing.assert_array_equal(world.arm("").motion.q, np.zeros(6))


def test_broken_mesh_fails_unless_skipped(tmp_path, executor):
    config = tmp_path / "arm.yaml"
    text = config_path("arm/irb120.yaml").read_text()
    folder = config_path("arm/meshes/irb120")
    config.write_text(text.replace("mesh_folder: meshes/irb120", f"mesh_folder: {tmp_path}"))
    for stl in folder.iterdir():
        (tmp_path / stl.name).write_bytes(stl.read_bytes())
    (tmp_path / "IRB120_link3.stl").write_bytes((folder / "IRB120_link3.stl").read_bytes()[:500])
    from sim_runtime.errors import InputError

    with pytest.raises(InputError, match=r"IRB120_link3\.stl"):
        make_arm_node(executor, robot_config_file=str(config))
    world = make_arm_node(executor, robot_config_file=str(config), skip_missing_meshes=True)
    markers = world.arm("").markers.markers
    assert sum(m.type == Marker.CUBE for m in markers) == 1
    assert sum(m.type == Marker.MESH_RESOURCE for m in markers) == 6


def test_demo_follows_the_trajectory_and_reaches_the_target(tmp_path):
    from arm_sim.demo import TRAJECTORY, run_demo

    summary = run_demo(tmp_path)
    assert summary["trajectory_final_error_rad"] < 1e-9
    assert summary["target_position_error_m"] < 1e-3
    assert summary["peak_speed_fraction"] <= 1.0 + 1e-9
    assert summary["joint_states_received"] >= 50 * TRAJECTORY[-1][0]
    assert Path(summary["png"]).stat().st_size > 1000


# --- robot_description, /tf, /tf_static -----------------------------------------------------


def pose_matrix(msg: PoseStamped) -> np.ndarray:
    T = np.eye(4)
    T[:3, :3] = matrix_from_quaternion(msg.pose.orientation)
    p = msg.pose.position
    T[:3, 3] = [p.x, p.y, p.z]
    return T


def test_every_arm_has_a_latched_robot_description_that_matches_its_motion(executor, make_node):
    world = make_arm_node(executor, scene_file="arm/workcell.yaml")
    test = make_node()
    for prefix, n in (("", 6), ("csa/", 7)):
        description = collect(executor, test, String, prefix + "robot_description", LATCHED_QOS)
        assert spin_until(executor, lambda d=description: d.msgs), prefix
        urdf = yourdfpy.URDF.load(io.StringIO(description.last.data), load_meshes=False)
        arm = world.arm(prefix)
        assert urdf.actuated_joint_names == [prefix + name for name in arm.arm.joint_names]
        assert len(urdf.actuated_joint_names) == n
        q = arm.arm.lower + 0.3 * (arm.arm.upper - arm.arm.lower)
        urdf.update_cfg(q)
        np.testing.assert_allclose(urdf.get_transform(f"{prefix}tool0", "world"), arm.arm.fkine(q), atol=1e-9)


def tf_buffer(executor, node) -> TfBuffer:
    buffer = TfBuffer(node)
    for subscription in buffer.subscriptions:
        assert wait_for_match(executor, subscription)
    return buffer


def synced(tf: TfBuffer, poses: Collector, tool: str, now: float) -> bool:
    """The newest end-effector pose and the tool's moving parent frame are both from ``now``."""
    return (
        bool(poses.msgs)
        and stamp_seconds(poses.last) == pytest.approx(now)
        and tf.can_transform("world", tool)
        and tf.stamp.get(tf.chain(tool)[1]) == pytest.approx(now)
    )


def test_tf_chains_every_arms_tool_frame_to_world_at_its_end_effector_pose(executor, make_node, tf2_msgs):
    from tf2_msgs.msg import TFMessage

    world = make_arm_node(executor, scene_file="arm/workcell.yaml")
    test = make_node()
    tf = tf_buffer(executor, test)
    moving = Collector(test, TFMessage, "/tf", TF_QOS)
    assert wait_for_match(executor, moving.subscription)
    poses = {prefix: collect(executor, test, PoseStamped, prefix + "end_effector_pose") for prefix in ("", "csa/")}
    states = collect(executor, test, JointState, "joint_states")
    commands = [
        ([0.4, -0.3, 0.2, 0.5, -0.6, 0.7], [0.5, -0.8]),
        ([-1.0, 0.6, -0.9, -1.2, 1.1, -2.0], [-0.7, 1.1]),
    ]
    seen = []
    for irb, csa in commands:
        world.arm("").on_joint_command(JointState(position=irb))
        world.arm("csa/").on_joint_command(JointState(name=["joint_2", "joint_4"], position=csa))
        run(executor, world, 30)
        now = world.sim_time
        for prefix, collector in poses.items():
            tool = f"{prefix}tool0"
            assert spin_until(executor, lambda c=collector, t=tool, n=now: synced(tf, c, t, n)), prefix
            T = tf.lookup("world", tool)
            expected = pose_matrix(collector.last)
            assert np.abs(T[:3, 3] - expected[:3, 3]).max() <= 1e-6
            assert np.abs(T[:3, :3] - expected[:3, :3]).max() <= 1e-6
            seen.append(T)
    assert not np.allclose(seen[0], seen[2]) and not np.allclose(seen[1], seen[3])  # the arms moved
    # /tf goes with every joint state, stamped with its sim time
    tf_stamps = {stamp_seconds(t) for m in moving.msgs for t in m.transforms}
    assert {stamp_seconds(m) for m in states.msgs} <= tf_stamps
    assert tf.chain("csa/tool0") == ["csa/tool0", *(f"csa/link_{k}" for k in range(7, 0, -1)), "csa/base_link", "world"]
    np.testing.assert_allclose(tf.lookup("world", "table")[:3, 3], [0.55, 0.0, 0.0], atol=1e-12)


def test_tf_of_a_namespaced_arm_carries_the_namespace_in_its_frames(executor, make_node, tf2_msgs):
    world = ArmNode(namespace="/cell1", parameter_overrides=[Parameter("scene_file", value="arm/workcell.yaml")])
    executor.add_node(world)
    test = make_node()
    tf = tf_buffer(executor, test)
    pose = collect(executor, test, PoseStamped, "/cell1/csa/end_effector_pose")
    run(executor, world, 2)
    tool = "cell1/csa/tool0"
    assert spin_until(executor, lambda: pose.msgs and tf.can_transform("world", tool) and "cell1/table" in tf.parent)
    np.testing.assert_allclose(tf.lookup("world", tool), pose_matrix(pose.last), atol=1e-6)
    assert tf.chain("cell1/link_1")[-2:] == ["cell1/base_link", "world"]


# --- parameters, as ros2 param set/get/describe reach them ------------------------------------


def call(executor, future):
    assert spin_until(executor, future.done), "parameter service did not answer"
    return future.result()


@pytest.fixture
def params(executor, make_node, world):
    client = AsyncParameterClient(make_node(), world.get_fully_qualified_name())
    assert client.wait_for_services(timeout_sec=5.0)
    return client


def set_one(executor, client, name, value):
    return call(executor, client.set_parameters([Parameter(name, value=value)])).results[0]


@pytest.mark.parametrize(
    ("name", "value", "why"),
    [
        ("robot_config_file", "arm/csa7.yaml", "read-only"),
        ("scene_file", "arm/workcell.yaml", "read-only"),
        ("frame_id", "map", "read-only"),
        ("skip_missing_meshes", True, "read-only"),
        ("marker_alpha", 7.0, "out of range"),
        ("marker_alpha", -0.1, "out of range"),
        ("marker_alpha", "abc", "wrong parameter type"),
        ("publish_rate", 500.0, "out of range"),
        ("publish_rate", -1.0, "out of range"),
        ("publish_rate", math.nan, "out of range"),
    ],
)
def test_bad_and_read_only_parameters_are_refused_with_a_reason(executor, world, params, name, value, why):
    before = call(executor, params.get_parameters([name])).values[0]
    result = set_one(executor, params, name, value)
    assert not result.successful
    assert result.reason and why.lower() in result.reason.lower(), result.reason
    assert call(executor, params.get_parameters([name])).values[0] == before


def test_a_good_marker_alpha_is_applied_to_the_next_markers(executor, make_node, world, params):
    markers = collect(executor, make_node(), MarkerArray, "robot_markers")
    result = set_one(executor, params, "marker_alpha", 0.25)
    assert result.successful, result.reason
    markers.clear()
    run(executor, world, 2)
    assert spin_until(executor, lambda: markers.msgs)
    meshes = [m for m in markers.last.markers if m.type == Marker.MESH_RESOURCE]
    assert meshes and all(m.color.a == pytest.approx(0.25) for m in meshes)
    assert call(executor, params.get_parameters(["marker_alpha"])).values[0].double_value == 0.25


def test_a_new_publish_rate_is_applied_at_once(executor, make_node, world, params):
    states = collect(executor, make_node(), JointState, "joint_states")
    assert set_one(executor, params, "publish_rate", 10).successful  # an integer, as ros2 param set sends it
    run(executor, world, 100)
    assert spin_until(executor, lambda: len(states.msgs) >= 10)
    drain(executor)
    assert len(states.msgs) == 10


def test_every_parameter_is_described_and_only_live_ones_are_writable(executor, world, params):
    names = ["robot_config_file", "scene_file", "marker_alpha", "frame_id", "publish_rate", "skip_missing_meshes"]
    descriptors = call(executor, params.describe_parameters(names)).descriptors
    for descriptor in descriptors:
        assert descriptor.description, descriptor.name
        assert descriptor.read_only == (descriptor.name not in ("marker_alpha", "publish_rate")), descriptor.name
        assert not descriptor.dynamic_typing
    alpha = descriptors[names.index("marker_alpha")].floating_point_range[0]
    assert (alpha.from_value, alpha.to_value) == (0.0, 1.0)


def test_the_old_parameter_names_still_work_at_start(executor):
    world = make_arm_node(executor, robot_config="arm/csa7.yaml", alpha=0.5)
    assert world.arm("").arm.n == 7
    assert world.get_parameter("robot_config_file").value == "arm/csa7.yaml"
    assert world.get_parameter("marker_alpha").value == 0.5
    assert {m.color.a for m in world.arm("").markers.markers if m.type == Marker.MESH_RESOURCE} == {0.5}


def test_the_node_takes_its_name_and_node_arguments(executor):
    world = make_arm_node(executor, "left_arm", publish_rate=20.0)
    assert world.get_name() == "left_arm"
    assert world.publish_rate == 20.0


def test_old_parameter_names_on_the_command_line_warn_and_still_name_a_bad_file(tmp_path):
    root = Path(__file__).resolve().parent.parent
    missing = tmp_path / "no_such_arm.yaml"
    done = subprocess.run(
        executable_command("arm", ["--ros-args", "-p", f"robot_config:={missing}", "-p", "alpha:=0.5"]),
        env=dict(os.environ, PYTHONPATH=str(root)),
        capture_output=True,
        text=True,
        timeout=120,
    )
    assert done.returncode == 2, done.stderr
    assert "'robot_config' is deprecated: use 'robot_config_file'" in done.stderr
    assert "'alpha' is deprecated: use 'marker_alpha'" in done.stderr
    assert str(missing) in done.stderr and "Traceback" not in done.stderr


def test_without_tf2_msgs_the_arm_says_tf_is_off_once_and_keeps_working(executor, make_node, monkeypatch, capfd):
    import sim_runtime.tf

    monkeypatch.setattr(sim_runtime.tf, "TFMessage", None)
    world = make_arm_node(executor, scene_file="arm/workcell.yaml")
    test = make_node()
    states = collect(executor, test, JointState, "csa/joint_states")
    description = collect(executor, test, String, "robot_description", LATCHED_QOS)
    run(executor, world, 4)
    assert spin_until(executor, lambda: states.msgs and description.msgs)
    err = capfd.readouterr().err
    assert err.count("TF is off") == 1 and "tf2_msgs is not installed" in err


def test_the_arms_state_publishers_take_qos_overrides_at_start(executor):
    from rclpy.qos import ReliabilityPolicy

    world = make_arm_node(executor, **{"qos_overrides./joint_states.publisher.reliability": "best_effort"})
    arm = world.arms[0]
    assert arm.joint_pub.qos_profile.reliability == ReliabilityPolicy.BEST_EFFORT
    assert arm.pose_pub.qos_profile.reliability == ReliabilityPolicy.RELIABLE


def test_two_arms_in_one_scene_share_no_joint_name_and_commands_take_either_name(executor, make_node):
    world = make_arm_node(executor, scene_file="arm/workcell.yaml")
    test = make_node()
    states = {prefix: collect(executor, test, JointState, prefix + "joint_states") for prefix in ("", "csa/")}
    run(executor, world, 5)
    assert spin_until(executor, lambda: all(c.msgs for c in states.values()))
    irb, csa = (list(states[p].last.name) for p in ("", "csa/"))
    assert irb == [f"joint_{k}" for k in range(1, 7)]
    assert csa == [f"csa/joint_{k}" for k in range(1, 8)]
    command = test.create_publisher(JointState, "csa/joint_command", COMMAND_PUBLISHER_QOS)
    assert wait_for_match(executor, command)
    csa_arm = world.arm("csa/")
    for names in (["csa/joint_2"], ["joint_3"]):  # joint_states' name, or the config's
        command.publish(JointState(name=names, position=[0.25]))
        k = int(names[0][-1]) - 1
        assert spin_until(executor, lambda k=k: csa_arm.motion.goal[k] == pytest.approx(0.25)), names
    run(executor, world, 200)  # 2 s: both joints there, reported under their prefixed names
    assert spin_until(executor, lambda: states["csa/"].last.position[1] == pytest.approx(0.25, abs=1e-6))
