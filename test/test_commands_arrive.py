"""A command sent once from a fresh process (``ros2 topic pub --once``) reaches the world, and
every command subscription is reliable unless overridden with the standard QoS parameter.

The longer run (100 commands on a loaded machine) is ``bench/commands_arrive.py``."""

from __future__ import annotations

import os
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest
from rclpy.parameter import Parameter
from rclpy.qos import ReliabilityPolicy

from arm_sim.arm_node import ArmNode
from create_sim.world_node import CreateWorldNode
from sim_runtime.errors import InputError
from sim_runtime.testing import spin_until
from simrobot_sim.world_file import RobotSpec, WorldSpec
from simrobot_sim.world_node import SimrobotWorldNode

ROOT = Path(__file__).resolve().parent.parent
RELIABLE, BEST_EFFORT = ReliabilityPolicy.RELIABLE, ReliabilityPolicy.BEST_EFFORT

#: What Jazzy's ``ros2 topic pub --once /cmd_vel geometry_msgs/msg/Twist "{linear: {x: V}}"`` does:
#: a publisher with ros2topic's default profile (reliable, volatile, depth 10), wait until it
#: matches a subscription, publish once, keep the process 0.1 s (``--keep-alive``), exit.
PUBLISH_ONCE = """
import sys, time, rclpy
from geometry_msgs.msg import Twist
rclpy.init()
node = rclpy.create_node("pub_once")
publisher = node.create_publisher(Twist, "/once/cmd_vel", 10)
while publisher.get_subscription_count() < 1:
    time.sleep(0.1)
msg = Twist()
msg.linear.x = float(sys.argv[1])
publisher.publish(msg)
time.sleep(0.1)
"""


def overrides(**params) -> list[Parameter]:
    return [Parameter(k, value=v) for k, v in params.items()]


def test_ten_commands_published_once_from_fresh_processes_each_set_the_creates_speed(executor):
    world = CreateWorldNode(namespace="/once", parameter_overrides=overrides(real_time_factor=0.0))
    executor.add_node(world)
    for i in range(10):
        speed = round(0.1 + 0.01 * i, 3) * (-1) ** i
        sender = subprocess.Popen(
            [sys.executable, "-c", PUBLISH_ONCE, str(speed)], env=dict(os.environ, PYTHONPATH=str(ROOT))
        )
        try:
            assert spin_until(executor, lambda p=sender: p.poll() is not None, timeout=60.0)
            assert sender.returncode == 0
            assert spin_until(executor, lambda n=i + 1: world.commands_received == n, timeout=5.0), f"command {i}"
        finally:
            sender.kill()
            sender.wait()
        world.step()
        assert world.model.velocity[0] == pytest.approx(speed)


def command_qos(node) -> dict[str, ReliabilityPolicy]:
    """Reliability of each command subscription of ``node``, by topic."""
    commands = ("cmd_vel", "wheel_cmd", "set_pose", "joint_command", "joint_trajectory", "target_pose")
    return {s.topic_name: s.qos_profile.reliability for s in node.subscriptions if s.topic_name.endswith(commands)}


def test_every_command_subscription_is_reliable_and_takes_the_standard_qos_override(executor):
    create = CreateWorldNode(namespace="/q1", parameter_overrides=overrides(real_time_factor=0.0))
    arm = ArmNode("arm", namespace="/q2")
    executor.add_node(create)
    executor.add_node(arm)
    assert set(command_qos(create)) == {"/q1/cmd_vel", "/q1/set_pose"}
    assert set(command_qos(arm)) == {"/q2/joint_command", "/q2/joint_trajectory", "/q2/target_pose"}
    assert set(command_qos(create).values()) == set(command_qos(arm).values()) == {RELIABLE}
    joystick = CreateWorldNode(
        namespace="/q3",
        parameter_overrides=overrides(**{"qos_overrides./q3/cmd_vel.subscription.reliability": "best_effort"}),
    )
    executor.add_node(joystick)
    assert command_qos(joystick) == {"/q3/cmd_vel": BEST_EFFORT, "/q3/set_pose": RELIABLE}


def test_a_simrobot_robots_commands_are_reliable(executor):
    spec = WorldSpec(walls=np.zeros((50, 50), dtype=bool), robots=(RobotSpec("r1", (0.2, 0.2)),))
    world = SimrobotWorldNode(spec, namespace="/q4")
    executor.add_node(world)
    assert command_qos(world) == {"/q4/r1/cmd_vel": RELIABLE, "/q4/r1/wheel_cmd": RELIABLE}


def test_a_command_qos_override_rclpy_cannot_apply_is_an_input_error_naming_the_topic(ros):
    unknown = {"qos_overrides./q5/cmd_vel.subscription.reliability": "sometimes"}
    with pytest.raises(InputError, match="/q5/cmd_vel"):
        CreateWorldNode(namespace="/q5", parameter_overrides=overrides(**unknown))
