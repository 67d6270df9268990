"""``simrobot_avoid``: the seed's demo algorithm alg2 as a ROS 2 node driving one robot.

alg2 reads the front ultrasonic sensor each step: nearer than 20 cm → wheel speeds [0, 0.5] rad/s
(turn left), otherwise [0.5, 0.5] (straight on; no echo counts as far). The node answers every
sensor message with one ``wheel_cmd`` stamped with the message's stamp, so a lockstep world sees
exactly one command per step from it.

``simrobot_avoid --ros-args -r __ns:=/r1 [-p sensor:=sens1] [-p threshold:=0.2]``
Parameters: ``sensor`` (ultrasonic topic name under the namespace, default ``sens1`` as alg2),
``threshold`` (m, default 0.20), ``turn`` and ``straight`` ([left, right] rad/s).
"""

from __future__ import annotations

import math

from rclpy.node import Node
from sensor_msgs.msg import JointState, Range

from sim_runtime.errors import InputError
from sim_runtime.msgs import float64_array
from sim_runtime.qos import COMMAND_PUBLISHER_QOS, SENSOR_SUBSCRIBER_QOS
from sim_runtime.run import run_nodes

#: alg2's constants: 20 cm, [0 0.5] and [0.5 0.5] rad/s.
THRESHOLD = 0.20
TURN = (0.0, 0.5)
STRAIGHT = (0.5, 0.5)


class AvoidNode(Node):
    """Drives the robot of its namespace (or ``robot``) with alg2."""

    def __init__(self, robot: str | None = None, sensor: str = "sens1", **node_kwargs) -> None:
        """``robot``: namespace to drive (default: the node's own, e.g. from ``__ns``)."""
        if robot is not None:
            node_kwargs.setdefault("namespace", f"/{robot}")
        super().__init__("simrobot_avoid", **node_kwargs)
        self.sensor = self.declare_parameter("sensor", sensor).value
        self.threshold = float(self.declare_parameter("threshold", THRESHOLD).value)
        self.turn = tuple(float(v) for v in self.declare_parameter("turn", list(TURN)).value)
        self.straight = tuple(float(v) for v in self.declare_parameter("straight", list(STRAIGHT)).value)
        for name, value in (("turn", self.turn), ("straight", self.straight)):
            if len(value) != 2 or not all(math.isfinite(v) for v in value):
                raise InputError(f"parameter '{name}' = {list(value)!r} is invalid: expected [left, right] rad/s")
        if not (math.isfinite(self.threshold) and self.threshold > 0):
            raise InputError(f"parameter 'threshold' = {self.threshold!r} is invalid: must be > 0 m")
        self._cmd = JointState()
        self._cmd.name = ["left_wheel", "right_wheel"]
        self.publisher = self.create_publisher(JointState, "wheel_cmd", COMMAND_PUBLISHER_QOS)
        self.subscription = self.create_subscription(Range, self.sensor, self._on_range, SENSOR_SUBSCRIBER_QOS)

    def _on_range(self, msg: Range) -> None:
        speeds = self.turn if msg.range < self.threshold else self.straight
        self._cmd.header.stamp = msg.header.stamp
        self._cmd.velocity = float64_array(speeds)
        self.publisher.publish(self._cmd)


def main(args: list[str] | None = None) -> int:
    """``simrobot_avoid --ros-args -r __ns:=/<robot>``."""
    return run_nodes(lambda: [AvoidNode()], args)
