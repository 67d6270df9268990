"""Students' controllers that go wrong the ways real ones do (``students.misbehaving:Quits`` in a
sweep; see ``04_misbehaving_students.yaml``). Each drives forward like a good controller, then,
once the sim time reaches ``fail_at`` (s), does its one bad thing in a bumper callback:

- ``Raises``: raises an exception;
- ``Quits``: calls ``sys.exit(3)``; ``Exits``: calls ``os._exit(7)`` (no clean-up at all);
- ``Crashes``: reads memory at address 0 (a segmentation fault, as a bad C extension would);
- ``Hangs``: loops forever; ``Hogs``: allocates 50 MB more at every message, without end.

``robot_sims batch`` turns each into its episode's error row and goes on with the sweep.
"""

import ctypes
import os
import sys

import numpy as np
from geometry_msgs.msg import Twist
from rclpy.node import Node
from sensor_msgs.msg import Range


class Driver(Node):
    """Drives forward at 0.2 m/s; after ``fail_at`` s of sim time calls :meth:`fail`."""

    def __init__(self, **kwargs):
        super().__init__("misbehaving", **kwargs)
        self.fail_at = float(self.declare_parameter("fail_at", 0.5).value)
        self.pub = self.create_publisher(Twist, "cmd_vel", 10)
        self.create_subscription(Range, "bump/left", self.on_bump, 10)

    def on_bump(self, msg: Range) -> None:
        if msg.header.stamp.sec + 1e-9 * msg.header.stamp.nanosec >= self.fail_at:
            self.fail()
        cmd = Twist()
        cmd.linear.x = 0.2
        self.pub.publish(cmd)

    def fail(self) -> None:
        """A good student's controller does nothing wrong."""


class Raises(Driver):
    def fail(self) -> None:
        raise ValueError("the student's bug")


class Quits(Driver):
    def fail(self) -> None:
        print("giving up", flush=True)
        sys.exit(3)


class Exits(Driver):
    def fail(self) -> None:
        os._exit(7)


class Crashes(Driver):
    def fail(self) -> None:
        ctypes.string_at(0)


class Hangs(Driver):
    def fail(self) -> None:
        while True:
            pass


class Hogs(Driver):
    def fail(self) -> None:
        hoard = []
        while True:
            hoard.append(np.ones(50_000_000 // 8))
