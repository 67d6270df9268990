"""A student's controller as a node class (``students.alice:Wanderer`` in the sweep): drive
forward; on a bump back up for 0.4 s, then turn left for ``turn_s`` seconds. Sim time comes from
the bumper messages' stamps, so it behaves the same at any speed."""

from geometry_msgs.msg import Twist
from rclpy.node import Node
from sensor_msgs.msg import Range


class Wanderer(Node):
    def __init__(self, **kwargs):
        super().__init__("wanderer", **kwargs)
        self.turn_s = float(self.declare_parameter("turn_s", 1.0).value)
        self.pub = self.create_publisher(Twist, "cmd_vel", 10)
        self.create_subscription(Range, "bump/left", self.on_bump, 10)
        self.create_subscription(Range, "bump/right", self.on_bump, 10)
        self.mode, self.until = "forward", 0.0

    def on_bump(self, msg: Range) -> None:
        now = msg.header.stamp.sec + 1e-9 * msg.header.stamp.nanosec
        if self.mode == "forward" and msg.range == float("-inf"):
            self.mode, self.until = "back", now + 0.4
        elif self.mode == "back" and now >= self.until:
            self.mode, self.until = "turn", now + self.turn_s
        elif self.mode == "turn" and now >= self.until:
            self.mode = "forward"
        cmd = Twist()
        cmd.linear.x = {"forward": 0.25, "back": -0.15, "turn": 0.0}[self.mode]
        cmd.angular.z = 1.2 if self.mode == "turn" else 0.0
        self.pub.publish(cmd)
