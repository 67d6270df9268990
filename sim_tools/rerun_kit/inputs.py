"""The plotted families: commands (Twist, TwistStamped), joint states (JointState), battery
(BatteryState), gamepads (Joy) and plain numbers (Float32, Float64, UInt8)."""

from __future__ import annotations

from sim_tools.rerun_kit.robots import Robots
from sim_tools.rerun_kit.ros import basename, namespace, topic_path


class Inputs(Robots):
    """Plots what robots are commanded and report about themselves."""

    def _scalar_data(self, topic: str, msg) -> None:
        robot = namespace(topic).partition("/")[0] or "robot"
        self.scalar("other", robot, topic_path(topic), float(msg.data))

    def _battery(self, topic: str, msg) -> None:
        robot = namespace(topic) or "robot"
        self.scalar("battery", robot, "voltage_v", msg.voltage, name="voltage (V)")
        self.scalar("battery", robot, "charge_percent", 100.0 * msg.percentage, name="charge (%)")

    def _joy(self, topic: str, msg) -> None:
        robot = namespace(topic) or "robot"
        base = basename(topic)
        for i, value in enumerate(msg.buttons):
            self.scalar("buttons", robot, f"{base}_button{i}", float(value), name=f"{base} button {i}")
        for i, value in enumerate(msg.axes):
            self.scalar("buttons", robot, f"{base}_axis{i}", float(value), name=f"{base} axis {i}")

    def _twist_stamped(self, topic: str, msg) -> None:
        self._twist(topic, msg.twist)

    def _twist(self, topic: str, twist) -> None:
        robot = namespace(topic) or "robot"
        base = basename(topic)
        self.scalar("commands", robot, f"{base}_linear_x", twist.linear.x, 0, f"{base} linear (m/s)")
        self.scalar("commands", robot, f"{base}_angular_z", twist.angular.z, 1, f"{base} angular (rad/s)")

    def _joint_state(self, topic: str, msg) -> None:
        self.joints(topic, msg, "robot")

    def joints(self, topic: str, msg, root_name: str) -> None:
        """Plot a JointState's positions, velocities and efforts (one tab each), as joints of the
        robot in the topic's namespace (``root_name`` for the root)."""
        names = list(msg.name) or [f"joint{i + 1}" for i in range(len(msg.position))]
        owner = namespace(topic) or root_name
        for field_name in ("position", "velocity", "effort"):
            values = getattr(msg, field_name)
            for joint, value in zip(names, values, strict=False):  # velocity/effort may be empty
                self.scalar(f"joint_{field_name}", owner, joint, float(value))
