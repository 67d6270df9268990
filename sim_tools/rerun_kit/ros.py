"""ROS message fields as Rerun values: type names, stamps, topic names as entity paths, colours,
points and poses."""

from __future__ import annotations

import math

import numpy as np
import rerun as rr

from sim_runtime.msgs import quaternion_from_yaw
from sim_tools.rerun_kit.style import MIRROR_Y


def type_name(msg: object) -> str:
    """``pkg/msg/Type`` of an rclpy message instance or class."""
    cls = msg if isinstance(msg, type) else type(msg)
    return f"{cls.__module__.split('.')[0]}/msg/{cls.__name__}"


def stamp_ns(stamp) -> int:
    """A builtin_interfaces/Time as integer nanoseconds."""
    return int(stamp.sec) * 1_000_000_000 + int(stamp.nanosec)


def namespace(topic: str) -> str:
    """``/r1/sonar/front`` → ``r1/sonar``; ``/odom`` → ``""``."""
    return topic.strip("/").rpartition("/")[0]


def basename(topic: str) -> str:
    """The last segment of a topic or frame name."""
    return topic.rstrip("/").rpartition("/")[2]


def path_part(name: str) -> str:
    """``name`` as one segment of an entity path."""
    return rr.escape_entity_path_part(name) if name else "_"


def topic_path(topic: str) -> str:
    """A topic name as an entity path (each segment escaped)."""
    return "/".join(path_part(p) for p in topic.strip("/").split("/"))


def rgba(c) -> tuple[int, int, int, int]:
    """A std_msgs/ColorRGBA (0–1) as rgba 0–255."""
    return tuple(int(round(255 * min(max(v, 0.0), 1.0))) for v in (c.r, c.g, c.b, c.a))  # type: ignore[return-value]


def pose_transform(pose) -> rr.Transform3D:
    """A geometry_msgs/Pose as a 3-D transform (a zero quaternion as none)."""
    p, q = pose.position, pose.orientation
    quat = [q.x, q.y, q.z, q.w] if (q.x, q.y, q.z, q.w) != (0.0, 0.0, 0.0, 0.0) else [0.0, 0.0, 0.0, 1.0]
    return rr.Transform3D(translation=[p.x, p.y, p.z], quaternion=rr.Quaternion(xyzw=quat))


def yaw_transform(x: float, y: float, yaw: float) -> rr.Transform3D:
    """A planar pose (m, rad) as a transform."""
    q = quaternion_from_yaw(yaw)
    return rr.Transform3D(translation=[x, y, 0.0], quaternion=rr.Quaternion(xyzw=[q.x, q.y, q.z, q.w]))


def follow_transform(yaw: float) -> rr.Transform3D:
    """Under a robot's pose: undo its rotation (north stays up) and mirror y like the map."""
    c, s = math.cos(-yaw), math.sin(-yaw)
    return rr.Transform3D(mat3x3=np.array([[c, -s, 0.0], [s, c, 0.0], [0.0, 0.0, 1.0]]) @ MIRROR_Y)


def points(pts) -> np.ndarray:
    """geometry_msgs/Point list as an (N, 3) float32 array."""
    return np.array([(p.x, p.y, p.z) for p in pts], dtype=np.float32).reshape(-1, 3)
