"""Publishing transforms on ``/tf`` and ``/tf_static`` as tf2's broadcasters do.

``tf2_msgs`` is not on PyPI: ``make`` builds it into the virtual environment from the interface
files in ``interfaces/tf2_msgs`` (a stock ROS install has it already). Where it is missing the
worlds log one line saying TF is off and why, and everything else works.
"""

from __future__ import annotations

import math
from collections.abc import Iterable
from typing import Any

from builtin_interfaces.msg import Time
from geometry_msgs.msg import Quaternion, Transform, TransformStamped, Vector3
from rclpy.node import Node
from rclpy.publisher import Publisher

from sim_runtime.qos import LATCHED_QOS, TF_QOS

try:
    from tf2_msgs.msg import TFMessage as TFMessage  # re-exported: synthetic runs build tf messages too
except ImportError:  # pip install without a compiler: see interfaces/tf2_msgs
    TFMessage = None

TF_OFF_REASON = (
    "tf2_msgs is not installed (it is built from interfaces/tf2_msgs by `make venv`, which needs a C/C++ "
    "compiler and the Python headers); /tf, /tf_static are not published"
)


def tf_available() -> bool:
    """Whether this Python can publish ``tf2_msgs/TFMessage``."""
    return TFMessage is not None


def transform_msg(
    parent: str,
    child: str,
    x: float,
    y: float,
    z: float = 0.0,
    yaw: float = 0.0,
    quaternion: Iterable[float] | None = None,
) -> TransformStamped:
    """``parent → child`` as a ``TransformStamped`` (stamp left zero): a planar ``yaw`` about +z, or a
    full rotation given as ``quaternion`` (x, y, z, w)."""
    if quaternion is None:
        quaternion = (0.0, 0.0, math.sin(0.5 * yaw), math.cos(0.5 * yaw))
    qx, qy, qz, qw = (float(v) for v in quaternion)
    msg = TransformStamped(
        child_frame_id=child,
        transform=Transform(
            translation=Vector3(x=float(x), y=float(y), z=float(z)), rotation=Quaternion(x=qx, y=qy, z=qz, w=qw)
        ),
    )
    msg.header.frame_id = parent
    return msg


def set_planar(t: TransformStamped, x: float, y: float, yaw: float) -> None:
    """Move a planar transform in place (messages reused: no new objects per publication)."""
    tr = t.transform
    tr.translation.x, tr.translation.y = x, y
    tr.rotation.z, tr.rotation.w = math.sin(0.5 * yaw), math.cos(0.5 * yaw)


class TfBroadcaster:
    """``/tf`` and ``/tf_static`` publishers of one node, or nothing (with one log line) without tf2_msgs."""

    def __init__(self, node: Node, enabled: bool = True) -> None:
        self.enabled = enabled and tf_available()
        self._static: dict[str, TransformStamped] = {}
        if enabled and not tf_available():
            node.get_logger().warning(f"TF is off: {TF_OFF_REASON}")
        self.publisher: Publisher | None = None
        self.publishers: list[Publisher] = []  # [the /tf publisher] when enabled: for "does anyone listen" checks
        if self.enabled:
            self.publisher = node.create_publisher(TFMessage, "/tf", TF_QOS)
            self.publishers = [self.publisher]
            self._static_pub = node.create_publisher(TFMessage, "/tf_static", LATCHED_QOS)

    def send_static(self, transforms: Iterable[TransformStamped], stamp: Time) -> None:
        """Add fixed transforms and publish the whole set in one latched message, as tf2's static
        broadcaster does (a late joiner gets every static frame of this node)."""
        if not self.enabled:
            return
        for t in transforms:
            t.header.stamp = stamp
            self._static[t.child_frame_id] = t
        self._static_pub.publish(TFMessage(transforms=list(self._static.values())))

    @staticmethod
    def message(transforms: list[TransformStamped]) -> Any:
        """A ``TFMessage`` of ``transforms`` (stamps already set by the caller), for :attr:`publisher`."""
        return TFMessage(transforms=transforms)

    def send(self, transforms: list[TransformStamped]) -> None:
        """Publish moving transforms on /tf (stamps already set by the caller)."""
        if self.enabled and self.publisher is not None:
            self.publisher.publish(TFMessage(transforms=transforms))

    def heard(self) -> bool:
        """Whether anyone subscribes to ``/tf`` (building the message can then be skipped)."""
        return self.enabled and self.publisher is not None and self.publisher.get_subscription_count() > 0
