"""The arm node through its topics (launch-free: node and test node in one executor)."""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pytest
from builtin_interfaces.msg import Duration
from geometry_msgs.msg import PoseStamped
from rclpy.parameter import Parameter
from sensor_msgs.msg import JointState
from trajectory_msgs.msg import JointTrajectory, JointTrajectoryPoint
from visualization_msgs.msg import Marker, MarkerArray

from arm_sim.arm import Arm
from arm_sim.arm_node import ArmNode
from sim_runtime.msgs import matrix_from_quaternion, quaternion_from_matrix
from sim_runtime.paths import config_path
from sim_runtime.qos import COMMAND_PUBLISHER_QOS, LATCHED_QOS, SENSOR_SUBSCRIBER_QOS
from sim_runtime.testing import Collector, drain, spin_until, wait_for_match

JOINTS = [f"joint_{i}" for i in range(1, 7)]


def make_arm_node(executor, **params) -> ArmNode:
    node = ArmNode(parameter_overrides=[Parameter(k, value=v) for k, v in params.items()])
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
    world = make_arm_node(executor, alpha=0.5)
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
        assert marker.mesh_resource.startswith("file:///")
        assert Path(marker.mesh_resource[len("file://") :]).is_file()
        assert marker.header.frame_id == "world"
        r, g, b, a = element.element.color
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

    with pytest.raises(InputError, match="IRB120_link3.stl"):
        make_arm_node(executor, robot_config=str(config))
    world = make_arm_node(executor, robot_config=str(config), skip_missing_meshes=True)
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
