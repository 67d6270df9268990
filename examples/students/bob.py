"""A student's controller written as a script with ``main()`` (``students.bob:main`` in the
sweep): turn right on the spot while the front sonar sees something nearer than ``clear_m``,
else drive forward. Run by hand with ``python examples/students/bob.py`` next to a world."""

import rclpy
from geometry_msgs.msg import Twist
from rclpy.node import Node
from sensor_msgs.msg import Range


class SonarDriver(Node):
    def __init__(self):
        super().__init__("sonar_driver")
        self.clear_m = float(self.declare_parameter("clear_m", 0.3).value)
        self.pub = self.create_publisher(Twist, "cmd_vel", 10)
        self.create_subscription(Range, "sonar/front", self.on_sonar, 10)

    def on_sonar(self, msg: Range) -> None:
        cmd = Twist()
        if msg.range < self.clear_m:
            cmd.angular.z = -1.0
        else:
            cmd.linear.x = 0.3
        self.pub.publish(cmd)


def main():
    rclpy.init()
    node = SonarDriver()
    try:
        rclpy.spin(node)
    finally:
        node.destroy_node()
        rclpy.shutdown()


if __name__ == "__main__":
    main()
