"""A new MATLAB bridge's first command reaches the world, however discovery went.

A program commands once and waits (``SetFwdVelAngVelCreate`` then a loop of readings). A bridge
started just before it publishes from a new writer: the writer may have matched only another
subscription to cmd_vel (the studio shows each robot's commands), or the world's reader before
the world matched the writer; a sample published then never reaches the world. The bridge sends
its first command again until the robot's odometry shows it. Each round here is a fresh world and
a fresh bridge, with a second cmd_vel subscriber up first, as in the studio.
"""

from __future__ import annotations

import os
import signal
import socket
import subprocess
from pathlib import Path

import pytest
from geometry_msgs.msg import Twist
from nav_msgs.msg import Odometry

from sim_runtime.qos import COMMAND_SUBSCRIBER_QOS, SENSOR_SUBSCRIBER_QOS
from sim_runtime.testing import Collector, spin_until
from sim_tools.cli import executable_command
from sim_tools.matlab.bridge import spawn_bridge

ROOT = Path(__file__).resolve().parent.parent
NAMESPACE = "/first_command"
ENV = dict(os.environ, PYTHONPATH=str(ROOT))
ROUNDS = 3


def first_call(port: int, line: str) -> str:
    """Connect as a program does, send one request, return the bridge's reply."""
    with socket.create_connection(("127.0.0.1", port), timeout=120) as sock:
        reader = sock.makefile("r")
        reader.readline()  # the greeting
        sock.sendall(line.encode() + b"\n")
        return reader.readline().strip()


@pytest.mark.parametrize("round_", range(ROUNDS))
def test_a_new_bridges_first_and_only_command_moves_the_robot(executor, make_node, round_):
    node = make_node(f"first_command_probe_{round_}")
    odom = Collector(node, Odometry, f"{NAMESPACE}/odom", SENSOR_SUBSCRIBER_QOS)
    Collector(node, Twist, f"{NAMESPACE}/cmd_vel", COMMAND_SUBSCRIBER_QOS)  # as the studio's command display
    world = subprocess.Popen(
        executable_command("create_world", ["--ros-args", "-r", f"__ns:={NAMESPACE}"]),
        env=ENV,
        cwd=ROOT,
        stdout=subprocess.DEVNULL,
        stderr=subprocess.DEVNULL,
    )
    bridge = None
    try:
        assert spin_until(executor, lambda: odom.last is not None, 300), "create_world did not start"
        bridge, port = spawn_bridge(NAMESPACE, env=ENV)
        speed = 0.1 + 0.01 * round_  # a new speed each round: this round's command, not a leftover
        assert first_call(port, f"@1 SetFwdVelAngVelCreate {speed} 0") == "@1 ok"
        # The reply comes once the odometry has shown it; the test's own copy may come a little later.
        shown = spin_until(executor, lambda: odom.last.twist.twist.linear.x == pytest.approx(speed), 30)
        assert shown, f"the first command never reached the world (odometry says {odom.last.twist.twist.linear.x})"
    finally:
        if bridge is not None:
            bridge.send_signal(signal.SIGINT)
            bridge.wait(timeout=60)
        world.send_signal(signal.SIGINT)
        world.wait(timeout=60)
