"""CreateNav-v0 and the ROS create_world stepped together: the same commands, the same readings."""

from __future__ import annotations

import numpy as np
from geometry_msgs.msg import PoseStamped, Twist
from rclpy.parameter import Parameter
from sensor_msgs.msg import LaserScan, Range

from create_sim import spec
from sim_runtime.paths import config_path
from sim_runtime.qos import COMMAND_PUBLISHER_QOS, SENSOR_SUBSCRIBER_QOS
from sim_runtime.testing import Collector, spin_until, wait_for_match
from sim_tools.adapters.contract import world_part
from sim_tools.rl.create_nav import CreateNavEnv

START = (-1.5, -1.0, 0.3)
STEPS = 40


def test_the_env_and_the_ros_world_given_the_same_commands_give_the_same_scans_sonars_and_poses(executor, make_node):
    # noise-free: the world reads each sensor on its own schedule, so noisy draws come in another order
    files = {"map": str(config_path("create/example.map")), "config": str(config_path("create/ideal_config.txt"))}
    sensors = ("lidar", "sonar")
    env = CreateNavEnv(files["map"], files["config"], sensors=sensors, lidar_beams=681, start=START, goal=(3, 1))
    obs, _info = env.reset(seed=0)
    world = world_part("create").make_world(files, START, [Parameter("real_time_factor", value=0.0)])
    executor.add_node(world)
    node = make_node("rl_create_twin")
    scans = Collector(node, LaserScan, "/scan", SENSOR_SUBSCRIBER_QOS)
    poses = Collector(node, PoseStamped, "/overhead_pose", SENSOR_SUBSCRIBER_QOS)
    sonars = [Collector(node, Range, f"/sonar/{name}", SENSOR_SUBSCRIBER_QOS) for name in spec.SONAR_NAMES]
    cmd = node.create_publisher(Twist, "/cmd_vel", COMMAND_PUBLISHER_QOS)
    assert all(wait_for_match(executor, c.subscription) for c in [scans, poses, *sonars])
    assert wait_for_match(executor, cmd)
    rng = np.random.default_rng(3)
    substeps = env.substeps
    for k in range(1, STEPS + 1):
        action = rng.uniform(env.action_space.low, env.action_space.high).astype(np.float32)
        obs, _r, terminated, _t, info = env.step(action)
        msg = Twist()
        msg.linear.x, msg.angular.z = float(action[0]), float(action[1])
        cmd.publish(msg)
        assert spin_until(executor, lambda k=k: world.commands_received == k)
        world.step(substeps)
        stamp = round(k * substeps / spec.PHYSICS_RATE, 9)
        for c in [scans, poses, *sonars]:
            assert spin_until(executor, lambda c=c, s=stamp: bool(c.msgs) and _seconds(c.last) == s)
        ranges = np.clip(np.array(scans.last.ranges, dtype=np.float32), *env.model.LIDAR_RANGE)
        sonar = np.clip(np.array([c.last.range for c in sonars], dtype=np.float32), 0.0, env.model.SONAR_RANGE[1])
        assert np.array_equal(obs, np.concatenate([ranges, sonar])), f"step {k}"
        p = poses.last.pose.position
        assert (p.x, p.y) == tuple(info["pose"][:2]), f"step {k}"
        if terminated:
            break
    assert k > 10  # long enough to compare


def _seconds(msg) -> float:
    return round(msg.header.stamp.sec + msg.header.stamp.nanosec * 1e-9, 9)
