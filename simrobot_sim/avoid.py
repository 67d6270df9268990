"""``simrobot_avoid``: the original SIMROBOT's demo algorithm alg2 as a ROS 2 node driving one robot.

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
from functools import partial
from typing import Any

from sensor_msgs.msg import JointState, Range

from sim_runtime.msgs import float64_array
from sim_runtime.params import CheckedNode
from sim_runtime.qos import COMMAND_PUBLISHER_QOS, SENSOR_SUBSCRIBER_QOS
from sim_runtime.run import run_nodes
from simrobot_sim.spec import WHEEL_CMD_TOPIC

#: alg2's constants: 20 cm, [0 0.5] and [0.5 0.5] rad/s.
THRESHOLD = 0.20
TURN = (0.0, 0.5)
STRAIGHT = (0.5, 0.5)


class AvoidNode(CheckedNode):
    """Drives one robot with alg2: the robot of its namespace, or ``robot`` (topics ``<robot>/…``)."""

    #: Wheel speeds [left, right] (rad/s) near an obstacle and when clear (parameters of the same names).
    turn: tuple[float, float]
    straight: tuple[float, float]

    def __init__(
        self, robot: str | None = None, sensor: str = "sens1", node_name: str | None = None, **node_kwargs: Any
    ) -> None:
        """``robot``: the robot to drive, relative to the node's namespace (default: the namespace itself,
        e.g. ``simrobot_avoid --ros-args -r __ns:=/r1``)."""
        super().__init__(node_name or (f"{robot}_avoid" if robot else "simrobot_avoid"), **node_kwargs)
        self.sensor = self.declare_checked("sensor", sensor, bool, "name of the ultrasonic sensor to steer by")
        self.threshold = self.declare_checked(
            "threshold",
            THRESHOLD,
            None,
            "turn when the sensor reads less than this (m)",
            live=True,
            on_change=lambda v: setattr(self, "threshold", v),
            bounds=(1e-6, 1e6),
        )
        for name, default in (("turn", TURN), ("straight", STRAIGHT)):
            value = self.declare_checked(
                name,
                list(default),
                lambda v: len(v) == 2 and all(math.isfinite(x) for x in v),
                f"wheel speeds [left, right] (rad/s) when {'an obstacle is near' if name == 'turn' else 'clear'}",
                live=True,
                on_change=partial(self._set_speeds, name),
            )
            self._set_speeds(name, value)
        self._cmd = JointState()
        self._cmd.name = ["left_wheel", "right_wheel"]
        prefix = f"{robot}/" if robot else ""
        self.publisher = self.create_publisher(JointState, prefix + WHEEL_CMD_TOPIC, COMMAND_PUBLISHER_QOS)
        self.subscription = self.create_subscription(Range, prefix + self.sensor, self._on_range, SENSOR_SUBSCRIBER_QOS)

    def _set_speeds(self, name: str, value: list[float]) -> None:
        setattr(self, name, tuple(value))

    def _on_range(self, msg: Range) -> None:
        speeds = self.turn if msg.range < self.threshold else self.straight
        self._cmd.header.stamp = msg.header.stamp
        self._cmd.velocity = float64_array(speeds)
        self.publisher.publish(self._cmd)


def main(args: list[str] | None = None) -> int:
    """``simrobot_avoid --ros-args -r __ns:=/<robot>``."""
    return run_nodes(lambda: [AvoidNode()], args)
