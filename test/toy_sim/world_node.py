"""The toy simulator's world node: a :class:`~toy_sim.model.PointRobot` on ``cmd_vel`` and ``odom``."""

from __future__ import annotations

from typing import Any

from geometry_msgs.msg import Twist
from nav_msgs.msg import Odometry

from sim_runtime.msgs import all_finite, command_ok, set_planar_pose
from sim_runtime.qos import create_command_subscription, create_sensor_publisher
from sim_runtime.world_node import SimWorldNode, namespace_prefix
from toy_sim.model import PointRobot

#: Physics steps per sim second.
PHYSICS_RATE = 50.0
#: Odometry messages per sim second.
ODOM_RATE = 10.0


class ToyWorldNode(SimWorldNode):
    """``cmd_vel`` (geometry_msgs/Twist) in, ``odom`` (nav_msgs/Odometry, ground truth) out."""

    def __init__(self, node_name: str = "toy_world", **node_kwargs: Any) -> None:
        super().__init__(node_name, physics_rate=PHYSICS_RATE, **node_kwargs)
        start = self.declare_checked(
            "initial_pose", [0.0, 0.0, 0.0], lambda p: len(p) == 3 and all_finite(*p), "x y theta at start (m, m, rad)"
        )
        self.parameters_declared()
        x, y, theta = (float(v) for v in start)
        self.model = PointRobot((x, y, theta))
        self.prefix = namespace_prefix(self.get_namespace())
        self.pub_odom = create_sensor_publisher(self, Odometry, "odom")
        create_command_subscription(self, Twist, "cmd_vel", self._on_cmd_vel)
        self.every(ODOM_RATE, self._publish_odom)

    def _on_cmd_vel(self, msg: Twist) -> None:
        if command_ok(msg.linear.x, msg.angular.z):
            self.model.command(msg.linear.x, msg.angular.z)
        else:
            self.warn_throttled("cmd_vel", "rejected a cmd_vel that is not finite or absurdly large")

    def physics_step(self) -> None:
        self.model.step(self.physics_dt)

    def _publish_odom(self) -> None:
        msg = Odometry()
        msg.header.stamp = self.stamp()
        msg.header.frame_id = f"{self.prefix}odom"
        msg.child_frame_id = f"{self.prefix}base_link"
        x, y, theta = self.model.pose.tolist()
        set_planar_pose(msg.pose.pose, x, y, theta)
        msg.twist.twist.linear.x = self.model.v
        msg.twist.twist.angular.z = self.model.w
        self.pub_odom.publish(msg)


def main(args: list[str] | None = None) -> None:
    """Run the toy world (``python -m toy_sim.world_node``)."""
    from sim_runtime.run import run_nodes

    raise SystemExit(run_nodes(lambda: [ToyWorldNode()], args=args))


if __name__ == "__main__":
    main()
