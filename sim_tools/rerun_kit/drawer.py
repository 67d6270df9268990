"""One message → the family (or the simulator's drawing) that draws it."""

from __future__ import annotations

import functools
from collections.abc import Callable, Sequence

import rerun as rr

from sim_tools.rerun_kit.blueprint import Layout
from sim_tools.rerun_kit.contract import SimulatorDrawing
from sim_tools.rerun_kit.inputs import Inputs
from sim_tools.rerun_kit.markers import Markers
from sim_tools.rerun_kit.poses import Poses
from sim_tools.rerun_kit.ros import basename, stamp_ns, type_name
from sim_tools.rerun_kit.sensors import Sensors
from sim_tools.rerun_kit.tf import TF_MESSAGE_TYPE

CLOCK_TYPE = "rosgraph_msgs/msg/Clock"
"""Accepted, and only drives time."""

HANDLERS: dict[str, str] = {
    "visualization_msgs/msg/MarkerArray": "_marker_array",
    "visualization_msgs/msg/Marker": "_single_marker",
    "nav_msgs/msg/OccupancyGrid": "_occupancy_grid",
    "nav_msgs/msg/Odometry": "_odometry",
    "geometry_msgs/msg/PoseStamped": "_pose_stamped",
    "sensor_msgs/msg/LaserScan": "_laser_scan",
    "sensor_msgs/msg/Range": "_range",
    "sensor_msgs/msg/JointState": "_joint_state",
    "sensor_msgs/msg/BatteryState": "_battery",
    "sensor_msgs/msg/Joy": "_joy",
    "geometry_msgs/msg/Twist": "_twist",
    "geometry_msgs/msg/TwistStamped": "_twist_stamped",
    "std_msgs/msg/Bool": "bool_flag",
    "std_msgs/msg/UInt8": "_scalar_data",
    "std_msgs/msg/Float64": "_scalar_data",
    "std_msgs/msg/Float32": "_scalar_data",
    TF_MESSAGE_TYPE: "_tf_message",
}
"""Message type → the Drawer method (of its family) drawing it."""


def supported_types(drawings: Sequence[SimulatorDrawing]) -> frozenset[str]:
    """Message types drawn: the families' and those the simulators' drawings claim, and Clock."""
    return frozenset(HANDLERS) | {CLOCK_TYPE} | {kind for d in drawings for _, kind in d.handlers}


class Drawer(Poses, Sensors, Markers, Inputs, Layout):
    """Logs ROS messages (topic, message, time) to a Rerun recording as archetypes.

    With ``batch_scalars`` (bag conversion) plotted values are sent by :meth:`flush`, which leaves
    out series that never change. A topic a simulator's drawing claims is drawn by it.
    """

    def __init__(
        self,
        recording: rr.RecordingStream,
        topics: dict[str, str] | None = None,
        *,
        drawings: Sequence[SimulatorDrawing] = (),
        batch_scalars: bool = False,
    ) -> None:
        self._draw: dict[tuple[str, str], Callable[[str, object], None] | None] = {}
        super().__init__(recording, topics, drawings, batch_scalars)

    def log(self, topic: str, msg: object, time_ns: int | None = None, kind: str | None = None) -> bool:
        """Draw one message received on ``topic`` at ``time_ns`` (header stamp wins if set).

        ``kind`` (``pkg/msg/Type``) is needed only for messages that are not rclpy messages (a
        TFMessage decoded without tf2_msgs). Returns False (and draws nothing) if the message
        type is not supported.
        """
        kind = kind or type_name(msg)
        draw = self._drawing_of(topic, kind)
        if draw is None:
            return kind == CLOCK_TYPE
        header = getattr(msg, "header", None)
        t = stamp_ns(header.stamp) if header is not None else 0
        if t == 0 and time_ns is not None:
            t = time_ns
        self._set_time(t)
        self._start_planar()
        draw(topic, msg)
        return True

    def _drawing_of(self, topic: str, kind: str) -> Callable[[str, object], None] | None:
        """Who draws ``topic`` of type ``kind``: the first simulator claiming it by name, else the
        first claiming its type, else its family."""
        key = (topic, kind)
        if key not in self._draw:
            claims = ((basename(topic), kind), (None, kind))
            claimed = next((d.handlers[c] for c in claims for d in self.drawings if c in d.handlers), None)
            method = HANDLERS.get(kind)
            if claimed is not None:
                self._draw[key] = functools.partial(claimed, self)
            else:
                self._draw[key] = getattr(self, method) if method is not None else None
        return self._draw[key]
