"""Keyboard teleoperation for the Create, like the original simulator's manual control.

Keys (in the terminal that runs ``create_teleop``):

====================  =========================================
``w`` / Up            forward velocity +0.1 m/s
``s`` / Down          forward velocity −0.1 m/s
``a`` / Left          angular velocity +0.5 rad/s (counter-clockwise)
``d`` / Right         angular velocity −0.5 rad/s
Space, Return, Esc    zero all velocities
``q`` / Ctrl-C        stop the robot and quit
====================  =========================================

Velocities are capped at the toolbox's documented ranges (±0.5 m/s, ±2.5 rad/s); the world
additionally limits each wheel to ±0.5 m/s. Every key press publishes ``cmd_vel`` at once, and the
current command is repeated whenever no key came for 1/``repeat_rate`` s (default 5 Hz, 0 = only
on key presses) so a world with ``cmd_vel_timeout`` keeps moving. Parameter ``cmd_vel_stamped`` publishes TwistStamped.
"""

from __future__ import annotations

import os
import select
import sys
import termios
import time
import tty
from typing import Any, TextIO

import rclpy
from geometry_msgs.msg import Twist, TwistStamped

from create_sim import spec
from sim_runtime.params import CheckedNode
from sim_runtime.qos import COMMAND_PUBLISHER_QOS

LINEAR_STEP = 0.1  # m/s per key press, as the original
ANGULAR_STEP = 0.5  # rad/s per key press, as the original
MAX_LINEAR_STEPS = 5  # ±0.5 m/s
MAX_ANGULAR_STEPS = 5  # ±2.5 rad/s
STOP_SENDS = 5  # the stop on quitting, sent this many times ...
STOP_GAP_S = 0.05  # ... this far apart (0.2 s in all)

# key token -> (linear steps, angular steps) change; None = stop
KEY_ACTIONS: dict[bytes, tuple[int, int] | None] = {
    b"w": (1, 0),
    b"\x1b[A": (1, 0),
    b"\x1bOA": (1, 0),
    b"s": (-1, 0),
    b"\x1b[B": (-1, 0),
    b"\x1bOB": (-1, 0),
    b"a": (0, 1),
    b"\x1b[D": (0, 1),
    b"\x1bOD": (0, 1),
    b"d": (0, -1),
    b"\x1b[C": (0, -1),
    b"\x1bOC": (0, -1),
    b" ": None,
    b"\r": None,
    b"\n": None,
    b"\x1b": None,
}
QUIT_KEYS = (b"q", b"Q", b"\x03")

HELP = (
    "Create teleop: w/Up +0.1 m/s, s/Down -0.1 m/s, a/Left +0.5 rad/s, d/Right -0.5 rad/s, "
    "space/Return/Esc stop, q quit\r\n"
)


def split_keys(data: bytes) -> list[bytes]:
    """Split raw terminal input into key tokens (arrow keys arrive as 3-byte escape sequences)."""
    keys = []
    i = 0
    while i < len(data):
        if data[i : i + 1] == b"\x1b" and data[i + 1 : i + 2] in (b"[", b"O") and i + 2 < len(data):
            keys.append(data[i : i + 3])
            i += 3
        else:
            keys.append(data[i : i + 1])
            i += 1
    return keys


class TeleopNode(CheckedNode):
    """Publishes ``cmd_vel`` from key presses read from a terminal file descriptor."""

    def __init__(self, node_name: str = "create_teleop", **node_kwargs: Any) -> None:
        super().__init__(node_name, **node_kwargs)
        self.stamped = self.declare_checked(
            "cmd_vel_stamped", False, None, "publish geometry_msgs/TwistStamped instead of Twist"
        )
        self.repeat_rate = self.declare_checked(
            "repeat_rate",
            5.0,
            None,
            "re-send the current command this often (Hz) while no key comes, so a world's cmd_vel_timeout "
            "does not stop the robot (0 = only on key presses)",
            bounds=(0.0, 1000.0),
        )
        msg_type = TwistStamped if self.stamped else Twist
        self.publisher = self.create_publisher(msg_type, spec.CMD_VEL_TOPIC, COMMAND_PUBLISHER_QOS)
        self.linear_steps = 0
        self.angular_steps = 0

    @property
    def velocity(self) -> tuple[float, float]:
        """Current command (v m/s, ω rad/s)."""
        return self.linear_steps * LINEAR_STEP, self.angular_steps * ANGULAR_STEP

    def press(self, key: bytes) -> bool:
        """Apply one key; returns False when the key asks to quit. Unknown keys are ignored."""
        if key in QUIT_KEYS:
            self.linear_steps = self.angular_steps = 0
            return False
        if key not in KEY_ACTIONS:
            return True
        action = KEY_ACTIONS[key]
        if action is None:
            self.linear_steps = self.angular_steps = 0
        else:
            self.linear_steps = max(-MAX_LINEAR_STEPS, min(MAX_LINEAR_STEPS, self.linear_steps + action[0]))
            self.angular_steps = max(-MAX_ANGULAR_STEPS, min(MAX_ANGULAR_STEPS, self.angular_steps + action[1]))
        return True

    def publish(self) -> None:
        """Publish the current command."""
        v, w = self.velocity
        twist = Twist()
        twist.linear.x = v
        twist.angular.z = w
        if self.stamped:
            msg = TwistStamped(twist=twist)
            msg.header.stamp = self.get_clock().now().to_msg()
            self.publisher.publish(msg)
        else:
            self.publisher.publish(twist)

    def run(self, fd: int, out: TextIO = sys.stdout) -> None:
        """Read keys from terminal ``fd`` (switched to cbreak mode, restored on exit) until quit."""
        saved = termios.tcgetattr(fd)
        tty.setcbreak(fd)
        try:
            out.write(HELP)
            self._show(out)
            idle_timeout = 1.0 / self.repeat_rate if self.repeat_rate > 0 else None
            running = True
            while running:
                ready, _, _ = select.select([fd], [], [], idle_timeout)
                if ready:
                    data = os.read(fd, 64)
                    if not data:  # terminal closed
                        break
                    for key in split_keys(data):
                        running = self.press(key)
                        if not running:
                            break
                    self._show(out)
                self.publish()
        finally:
            self.stop()  # never leave the robot driving when the teleop goes away
            termios.tcsetattr(fd, termios.TCSADRAIN, saved)
            out.write("\r\n")
            out.flush()

    def stop(self) -> None:
        """Zero velocity, sent so that it arrives before the node goes away: the world listens best
        effort (nothing is acknowledged) and a sample written just before the process ends can be
        lost, so the stop goes out STOP_SENDS times, STOP_GAP_S apart."""
        self.linear_steps = self.angular_steps = 0
        for k in range(STOP_SENDS):
            if k:
                time.sleep(STOP_GAP_S)
            self.publish()

    def _show(self, out: TextIO) -> None:
        v, w = self.velocity
        out.write(f"\rv = {v:+.1f} m/s   w = {w:+.1f} rad/s   ")
        out.flush()


def main(args: list[str] | None = None) -> None:
    """Entry point ``create_teleop``: keyboard teleop on this terminal."""
    if not sys.stdin.isatty():
        sys.exit("create_teleop reads keys from a terminal: run it in an interactive terminal")
    rclpy.init(args=args)
    node = TeleopNode()
    try:
        node.run(sys.stdin.fileno())
    except KeyboardInterrupt:
        pass
    finally:
        node.destroy_node()
        rclpy.try_shutdown()


if __name__ == "__main__":
    main()
