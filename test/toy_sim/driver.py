"""``toy_circle``: the toy simulator's own controller, driving an arc at ``speed`` and ``turn``.

It answers every odometry message with a command, so it starts once the world's first ``odom``
(at 10 Hz of sim time) arrives."""

from __future__ import annotations

from typing import Any

from geometry_msgs.msg import Twist
from nav_msgs.msg import Odometry

from sim_runtime.params import CheckedNode
from sim_runtime.qos import COMMAND_PUBLISHER_QOS, SENSOR_SUBSCRIBER_QOS


class CircleNode(CheckedNode):
    """``cmd_vel`` = (``speed`` m/s, ``turn`` rad/s) after every ``odom``."""

    def __init__(self, node_name: str = "toy_circle", **node_kwargs: Any) -> None:
        super().__init__(node_name, **node_kwargs)
        self.speed = self.declare_checked("speed", 0.3, None, "forward speed (m/s)", bounds=(-10.0, 10.0))
        self.turn = self.declare_checked("turn", 0.5, None, "turn rate (rad/s)", bounds=(-10.0, 10.0))
        self.cmd_pub = self.create_publisher(Twist, "cmd_vel", COMMAND_PUBLISHER_QOS)
        self.create_subscription(Odometry, "odom", self._on_odom, SENSOR_SUBSCRIBER_QOS)

    def _on_odom(self, _msg: Odometry) -> None:
        cmd = Twist()
        cmd.linear.x, cmd.angular.z = float(self.speed), float(self.turn)
        self.cmd_pub.publish(cmd)
