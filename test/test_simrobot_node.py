"""SIMROBOT world node: topics, commands, services, lockstep (one executor, stepped by hand)."""

from __future__ import annotations

import math
import subprocess
import sys
import threading
import time

import numpy as np
import pytest
from geometry_msgs.msg import PoseStamped, Twist, TwistStamped
from nav_msgs.msg import OccupancyGrid, Odometry
from rclpy.parameter import Parameter
from sensor_msgs.msg import JointState, LaserScan, Range
from std_msgs.msg import Bool, Float64MultiArray, UInt8
from std_srvs.srv import SetBool, Trigger
from visualization_msgs.msg import MarkerArray

from sim_runtime.msgs import time_from_msg, yaw_from_quaternion
from sim_runtime.qos import COMMAND_PUBLISHER_QOS, LATCHED_QOS, SENSOR_SUBSCRIBER_QOS
from sim_runtime.run import drain, make_executor, spin_steps
from sim_runtime.testing import Collector, TfBuffer, spin_until, wait_for_match
from simrobot_sim.avoid import AvoidNode
from simrobot_sim.world_file import RobotSpec, SensorSpec, WorldSpec
from simrobot_sim.world_node import SimrobotWorldNode


def box_walls(nx: int = 200, ny: int = 100, wall_from_x: int | None = 150) -> np.ndarray:
    walls = np.zeros((nx, ny), dtype=bool)
    walls[0, :] = walls[-1, :] = walls[:, 0] = walls[:, -1] = True
    if wall_from_x is not None:
        walls[wall_from_x:, :] = True
    return walls


SONAR = SensorSpec("front", "ultrasonic", position=(0.05, 0.0), range=0.6, rays=1)
LASER = SensorSpec("scan", "laser", position=(0.05, 0.0), beamwidth=math.radians(90), range=2.0, rays=3)


def two_robot_world(executor, **kw) -> SimrobotWorldNode:
    spec = WorldSpec(
        walls=box_walls(),
        robots=(
            RobotSpec("a", (1.0, 0.5), color=(1.0, 0.0, 0.0), sensors=(SONAR, LASER)),
            RobotSpec("b", (1.3, 0.5), color=(0.0, 0.0, 1.0)),
        ),
        **kw,
    )
    world = SimrobotWorldNode(spec)
    executor.add_node(world)
    return world


def collect(node, executor, specs):
    out = {}
    for topic, msg_type, qos in specs:
        out[topic] = Collector(node, msg_type, topic, qos)
        assert wait_for_match(executor, out[topic].subscription)
    return out


def test_topics_carry_sensor_pose_and_map_data(executor, make_node):
    world = two_robot_world(executor)
    node = make_node("probe")
    got = collect(
        node,
        executor,
        [
            ("/a/front", Range, SENSOR_SUBSCRIBER_QOS),
            ("/a/front/obstacle", UInt8, SENSOR_SUBSCRIBER_QOS),
            ("/a/scan", LaserScan, SENSOR_SUBSCRIBER_QOS),
            ("/a/odom", Odometry, SENSOR_SUBSCRIBER_QOS),
            ("/a/pose", PoseStamped, SENSOR_SUBSCRIBER_QOS),
            ("/a/crashed", Bool, LATCHED_QOS),
            ("/map", OccupancyGrid, LATCHED_QOS),
            ("/robots", MarkerArray, SENSOR_SUBSCRIBER_QOS),
        ],
    )
    world.step()
    assert spin_until(executor, lambda: all(c.msgs for c in got.values()) and got["/a/scan"].last.header.stamp.sec == 1)

    sonar = got["/a/front"].last
    assert sonar.header.frame_id == "a/front" and sonar.radiation_type == Range.ULTRASOUND
    assert sonar.range == pytest.approx(0.23, abs=1e-6) and sonar.max_range == pytest.approx(0.6)
    assert got["/a/front/obstacle"].last.data == 3  # robot b

    scan = got["/a/scan"].last
    assert time_from_msg(scan.header.stamp) == 1.0 and scan.header.frame_id == "a/scan"
    assert scan.angle_min == pytest.approx(-math.pi / 4) and scan.angle_increment == pytest.approx(math.pi / 4)
    assert list(scan.ranges) == pytest.approx([0.45 * math.sqrt(2), 0.23, 0.45 * math.sqrt(2)], abs=1e-6)
    assert list(scan.intensities) == [1.0, 3.0, 1.0]

    pose = got["/a/pose"].last
    assert pose.header.frame_id == "map"
    assert (pose.pose.position.x, pose.pose.position.y) == pytest.approx((1.0, 0.5))
    odom = got["/a/odom"].last
    assert (odom.header.frame_id, odom.child_frame_id) == ("a/odom", "a/base_link")
    # exact odometry, yet covariances an EKF can fuse: one 0.01 m cell (and one per 1 s dt), step²/12
    pose_cov, twist_cov = np.reshape(odom.pose.covariance, (6, 6)), np.reshape(odom.twist.covariance, (6, 6))
    assert np.diag(pose_cov).tolist() == pytest.approx([1e-4 / 12, 1e-4 / 12, 0, 0, 0, 1e-4 / 12])
    assert np.diag(twist_cov).tolist() == pytest.approx([1e-4 / 12, 1e-4 / 12, 0, 0, 0, 1e-4 / 12])
    assert got["/a/crashed"].last.data is False

    grid = got["/map"].last
    assert (grid.info.width, grid.info.height, grid.info.resolution) == (200, 100, pytest.approx(0.01))
    data = np.array(grid.data, dtype=np.int8).reshape(100, 200)
    assert data[50, 160] == 100 and data[50, 100] == 0 and data[0, 50] == 100
    markers = got["/robots"].last.markers
    assert len(markers) == 2 and (markers[1].color.b, markers[1].pose.position.x) == (1.0, pytest.approx(1.3))


def test_cmd_vel_and_wheel_cmd_move_the_robot_and_nan_is_rejected(executor, make_node):
    world = two_robot_world(executor)
    node = make_node("driver")
    cmd = node.create_publisher(Twist, "/a/cmd_vel", COMMAND_PUBLISHER_QOS)
    wheels = node.create_publisher(JointState, "/b/wheel_cmd", COMMAND_PUBLISHER_QOS)
    assert wait_for_match(executor, cmd) and wait_for_match(executor, wheels)
    poses = Collector(node, PoseStamped, "/a/pose", SENSOR_SUBSCRIBER_QOS)
    assert wait_for_match(executor, poses.subscription)

    cmd.publish(Twist())  # zero first, so a rejected command would visibly leave it
    bad = Twist()
    bad.linear.x = math.nan
    cmd.publish(bad)
    good = Twist()
    good.linear.x = -0.01
    good.angular.z = 0.1
    cmd.publish(good)
    wheels.publish(JointState(velocity=[math.inf, 1.0]))
    wheels.publish(JointState(velocity=[0.5, 0.5]))
    assert spin_until(executor, lambda: world.model.vel[0, 0] != 0.0 and world.model.vel[1, 0] == 0.5)
    assert tuple(world.model.vel[0]) == pytest.approx(((-0.01 - 0.003) / 0.01, (-0.01 + 0.003) / 0.01))
    world.step()
    assert spin_until(executor, lambda: poses.msgs and poses.last.header.stamp.sec == 1)
    p = poses.last.pose
    assert p.position.x == pytest.approx(0.99) and yaw_from_quaternion(p.orientation) == pytest.approx(0.1)
    assert world.model.poses()[1, 0] == pytest.approx(1.305)

    # Finite but absurd (1e308 overflows the kinematics into inf): rejected, state unchanged.
    before = world.model.vel.copy()
    huge = Twist()
    huge.linear.x = huge.angular.z = 1e308
    cmd.publish(huge)
    wheels.publish(JointState(velocity=[1e308, 1e308]))
    drain(executor)
    assert np.array_equal(world.model.vel, before)


def call(executor, node, srv_type, name, request):
    client = node.create_client(srv_type, name)
    assert client.wait_for_service(timeout_sec=5.0)
    future = client.call_async(request)
    assert spin_until(executor, future.done)
    return future.result()


def test_crash_is_published_and_services_clear_it_and_cut_power(executor, make_node):
    world = two_robot_world(executor)
    node = make_node("operator")
    crashed = Collector(node, Bool, "/b/crashed", LATCHED_QOS)
    assert wait_for_match(executor, crashed.subscription)
    world.model.set_wheel_speeds(1, 2.0, 2.0)  # b drives into the wall at x = 1.5
    for _ in range(12):
        world.step()
    assert world.model.crashed[1]
    assert spin_until(executor, lambda: crashed.last is not None and crashed.last.data)
    x_crash = world.model.poses()[1, 0]
    assert x_crash + 0.04 <= 1.5

    assert call(executor, node, Trigger, "/b/clear_crash", Trigger.Request()).success
    assert spin_until(executor, lambda: crashed.last.data is False)
    assert not world.model.crashed[1]

    assert call(executor, node, SetBool, "/b/set_power", SetBool.Request(data=False)).success
    world.model.set_wheel_speeds(1, -1.0, -1.0)
    world.step(3)
    assert world.model.poses()[1, 0] == x_crash
    call(executor, node, SetBool, "/b/set_power", SetBool.Request(data=True))
    world.step()
    assert world.model.poses()[1, 0] == pytest.approx(x_crash - 0.01)


def test_the_power_flag_is_latched_and_follows_set_power(executor, make_node):
    world = two_robot_world(executor)
    node = make_node("power_watcher")
    power = Collector(node, Bool, "/b/power", LATCHED_QOS)  # joins after the world started: latched
    assert spin_until(executor, lambda: power.last is not None and power.last.data is True)
    assert call(executor, node, SetBool, "/b/set_power", SetBool.Request(data=False)).success
    assert spin_until(executor, lambda: power.last.data is False)
    assert not world.model.power[1]


def test_robot_states_hold_every_pose_flag_and_nearest_hit_in_one_message(executor, make_node):
    world = two_robot_world(executor)
    node = make_node("states_watcher")
    states = Collector(node, Float64MultiArray, "/robot_states", SENSOR_SUBSCRIBER_QOS)
    assert wait_for_match(executor, states.subscription)
    world.model.set_wheel_speeds(1, 2.0, 2.0)  # b drives into the wall at x = 1.5 and crashes
    world.model.set_power(0, False)
    world.step(12)
    assert spin_until(executor, lambda: states.last is not None and states.last.data[0] == world.sim_time)
    data = np.asarray(states.last.data)
    assert [d.label for d in states.last.layout.dim] == ["header", "robots", "sensors"]
    assert data[1:3].tolist() == [2, 2]
    robots = data[3:13].reshape(2, 5)
    assert np.allclose(robots[:, :3], world.model.poses())
    assert robots[:, 3].tolist() == [0.0, 1.0] and robots[:, 4].tolist() == [0.0, 1.0]  # b crashed, a off
    assert data[13] == world.model.nearest(0)[0]  # the sonar's nearest hit
    assert data[14] == np.min(world.model.ranges(1)[0])  # the laser's nearest ray


def crowded_spec(steps: int = 1000) -> WorldSpec:
    rng = np.random.default_rng(7)
    walls = box_walls(70, 70, None)
    robots: list[RobotSpec] = []
    sonar = SensorSpec("sens1", "ultrasonic")
    candidates = [(x, y) for x in (0.12, 0.35, 0.58) for y in (0.12, 0.35, 0.58)]
    for i, (x, y) in enumerate(candidates[:7]):
        robots.append(RobotSpec(f"r{i}", (x, y), heading=float(rng.uniform(-math.pi, math.pi)), sensors=(sonar,)))
    return WorldSpec(walls=walls, robots=tuple(robots), lockstep=True, lockstep_timeout=10.0, steps_limit=steps)


def run_crowd(steps: int) -> tuple[np.ndarray, float]:
    executor = make_executor()
    spec = crowded_spec()
    world = SimrobotWorldNode(spec)
    nodes = [world] + [AvoidNode(robot=r.name) for r in spec.robots]
    for node in nodes:
        executor.add_node(node)
    try:
        for c in nodes[1:]:
            assert wait_for_match(executor, c.publisher) and wait_for_match(executor, c.subscription)
        start = time.monotonic()
        assert spin_steps(executor, world, steps) == steps
        return world.model.history.array(), time.monotonic() - start
    finally:
        for node in nodes:
            executor.remove_node(node)
            node.destroy_node()
        executor.shutdown()


def test_lockstep_runs_are_identical_under_cpu_load(ros):
    quiet, _ = run_crowd(60)
    stop = threading.Event()

    def burn() -> None:
        while not stop.is_set():
            sum(i * i for i in range(20000))

    hog = subprocess.Popen([sys.executable, "-c", "while True: pass"])
    thread = threading.Thread(target=burn, daemon=True)
    thread.start()
    try:
        loaded, _ = run_crowd(60)
    finally:
        stop.set()
        hog.kill()
        hog.wait()
        thread.join()
    assert quiet.shape == (61, 7, 3)
    assert np.array_equal(quiet, loaded)
    assert np.any(quiet[-1, :, :2] != quiet[0, :, :2])  # the robots did move
    assert np.any(np.abs(np.diff(quiet[:, :, 2], axis=0)) > 0.01)  # and alg2 turned some of them


def test_lockstep_waits_for_commands_then_times_out_with_a_warning(executor, make_node):
    spec = WorldSpec(
        walls=box_walls(),
        robots=(RobotSpec("mute", (0.5, 0.5)), RobotSpec("talker", (1.0, 0.5))),
        lockstep=True,
        lockstep_timeout=0.3,
    )
    world = SimrobotWorldNode(spec)
    executor.add_node(world)
    node = make_node("talker_ctl")
    pub = node.create_publisher(JointState, "/talker/wheel_cmd", COMMAND_PUBLISHER_QOS)
    assert wait_for_match(executor, pub)
    drain(executor)
    world._published_wall = time.monotonic()  # start the wait now, after discovery
    assert not world.ready_to_step()
    pub.publish(JointState(velocity=[1.0, 1.0]))
    assert spin_until(executor, lambda: world._answered[1])
    assert not world.ready_to_step()  # "mute" has not answered
    start = time.monotonic()
    assert spin_until(executor, world.ready_to_step, timeout=5.0)
    assert time.monotonic() - start > 0.1
    world.step()
    assert world.model.poses()[1, 0] == pytest.approx(1.01)  # the world went on
    world.model.set_power(0, False)  # an unpowered robot need not answer
    pub.publish(JointState(velocity=[1.0, 1.0]))
    assert spin_until(executor, world.ready_to_step, timeout=0.25)


def test_world_file_parameter_and_steps_limit(executor, tmp_path):
    from PIL import Image

    Image.fromarray(np.where(box_walls().T[::-1], 0, 255).astype(np.uint8)).convert("1").save(tmp_path / "m.png")
    (tmp_path / "w.yaml").write_text(
        "map: m.png\nsteps_limit: 2\ndt: 0.5\nrobots:\n  - {name: solo, position: [0.5, 0.5]}\n"
    )
    world = SimrobotWorldNode(parameter_overrides=[Parameter("world_file", value=str(tmp_path / "w.yaml"))])
    executor.add_node(world)
    assert world.physics_dt == 0.5 and world.model.names == ["solo"]
    assert spin_steps(executor, world, 5) == 2
    assert world.finished and not world.ready_to_step() and world.sim_time == 1.0


def test_cmd_vel_stamped_parameter_takes_twist_stamped(executor, make_node):
    spec = WorldSpec(walls=box_walls(), robots=(RobotSpec("a", (1.0, 0.5)),), lockstep=True)
    world = SimrobotWorldNode(spec, parameter_overrides=[Parameter("cmd_vel_stamped", value=True)])
    executor.add_node(world)
    node = make_node("stamped_driver")
    pub = node.create_publisher(TwistStamped, "/a/cmd_vel", COMMAND_PUBLISHER_QOS)
    assert wait_for_match(executor, pub)
    world.step()
    cmd = TwistStamped()
    cmd.header.stamp = world.stamp()
    cmd.twist.linear.x = 0.01
    pub.publish(cmd)
    assert spin_until(executor, world.ready_to_step)
    stale = TwistStamped()
    stale.twist.linear.x = 0.05
    stale.header.stamp.nanosec = 1  # an answer to step 0 arriving during step 1: ignored
    pub.publish(stale)
    assert not spin_until(executor, lambda: world.model.vel[0, 0] == 5.0, timeout=0.5)
    world.step()
    assert world.model.poses()[0, 0] == pytest.approx(1.01)


def test_demo_runs_the_four_robots_for_300_steps_and_draws_tracks(ros, tmp_path):
    from PIL import Image

    from simrobot_sim.demo import run_demo

    summary = run_demo(tmp_path)
    assert summary["steps"] == 300
    travelled = summary["travelled_m"]
    assert sorted(travelled) == ["r1", "r2", "r3", "r4", "r5"]
    # alg2 moves at 0.5 cm per step, straight or turning: every robot covers most of 1.5 m
    assert all(1.0 < travelled[name] <= 1.5 + 1e-6 for name in ("r1", "r2", "r3", "r4"))
    # except r5, which never turns: it crashes into the wall 0.96 m ahead
    assert summary["crashed"] == ["r5"] and 0.9 < travelled["r5"] < 0.96
    assert Image.open(summary["tracks_png"]).size[0] > 400


def test_every_robot_has_a_base_footprint_at_its_base_link(executor, make_node):
    world = two_robot_world(executor)
    tf = TfBuffer(make_node("probe"))
    for subscription in tf.subscriptions:
        assert wait_for_match(executor, subscription)
    world.step()
    assert spin_until(executor, lambda: all(tf.can_transform("map", f"{r}/base_footprint") for r in "ab"))
    for robot in "ab":
        np.testing.assert_allclose(tf.lookup(f"{robot}/base_link", f"{robot}/base_footprint"), np.eye(4), atol=1e-12)
