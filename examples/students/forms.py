"""One bump-and-turn controller written in each form ``robot_sims batch`` runs (see
``forms_sweep.yaml`` next to this file, and "Controller forms" in docs/batch.md):

- ``Tutorial``: a node class whose ``__init__`` takes nothing, as in the ROS 2 tutorials;
- ``main``: the tutorial's entry point, ``rclpy.spin(node)``;
- ``loop``: a ``rclpy.spin_once`` loop that publishes from the loop body;
- ``Ticking``: a node with a ``create_timer`` (on sim time in a batch episode).

Each drives forward and turns left for ``turn_s`` seconds after a bump (the Create's left bumper).
"""

import rclpy
from geometry_msgs.msg import Twist
from rclpy.executors import ExternalShutdownException
from rclpy.node import Node
from sensor_msgs.msg import Range


class Tutorial(Node):
    def __init__(self):
        super().__init__("tutorial")
        self.turn_s = float(self.declare_parameter("turn_s", 1.0).value)
        self.pub = self.create_publisher(Twist, "cmd_vel", 10)
        self.create_subscription(Range, "bump/left", self.on_bump, 10)
        self.turn_until = 0.0

    def now(self) -> float:
        return self.get_clock().now().nanoseconds * 1e-9  # sim time in a batch episode

    def on_bump(self, msg: Range) -> None:
        if msg.range == float("-inf"):
            self.turn_until = self.now() + self.turn_s
        self.drive()

    def drive(self) -> None:
        cmd = Twist()
        if self.now() < self.turn_until:
            cmd.angular.z = 1.5
        else:
            cmd.linear.x = 0.3
        self.pub.publish(cmd)


def main(args=None):
    try:
        rclpy.init(args=args)
        node = Tutorial()
        rclpy.spin(node)
    except (KeyboardInterrupt, ExternalShutdownException):
        pass


def loop():
    rclpy.init()
    node = Tutorial()
    while rclpy.ok():
        rclpy.spin_once(node, timeout_sec=0.1)  # in a batch episode: returns after the next step
        node.drive()
    node.destroy_node()
    rclpy.shutdown()


class Ticking(Tutorial):
    """Drives from a 10 Hz timer; the bumper callback only notes the bump."""

    def __init__(self):
        super().__init__()
        self.create_timer(0.1, self.drive)

    def on_bump(self, msg: Range) -> None:
        if msg.range == float("-inf"):
            self.turn_until = self.now() + self.turn_s


if __name__ == "__main__":
    main()
