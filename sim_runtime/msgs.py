"""numpy ↔ ROS message conversion shared by every node.

Array fields are filled through ``array.array`` built from the numpy buffer: rclpy accepts it
without a per-element check, which is ~50x faster than assigning a numpy array or a list.
"""

from __future__ import annotations

import array
import math

import numpy as np
from builtin_interfaces.msg import Time
from geometry_msgs.msg import Point, Pose, Quaternion
from nav_msgs.msg import OccupancyGrid
from numpy.typing import ArrayLike
from std_msgs.msg import ColorRGBA


def time_msg(t: float) -> Time:
    """Seconds (sim time) → ``builtin_interfaces/Time``; rounds to the nearest nanosecond."""
    ns = int(round(t * 1e9))
    return Time(sec=ns // 1_000_000_000, nanosec=ns % 1_000_000_000)


def time_from_msg(stamp: Time) -> float:
    """``builtin_interfaces/Time`` → seconds."""
    seconds: float = stamp.sec + stamp.nanosec * 1e-9  # Time is untyped (a ROS message)
    return seconds


def quaternion_from_yaw(yaw: float) -> Quaternion:
    """Rotation about +z by ``yaw`` radians."""
    half = 0.5 * yaw
    return Quaternion(x=0.0, y=0.0, z=math.sin(half), w=math.cos(half))


def yaw_from_quaternion(q: Quaternion) -> float:
    """Heading (rotation about +z) of a quaternion, in (-pi, pi]."""
    return math.atan2(2.0 * (q.w * q.z + q.x * q.y), 1.0 - 2.0 * (q.y * q.y + q.z * q.z))


def quaternion_from_matrix(rotation: np.ndarray) -> Quaternion:
    """3x3 rotation matrix → unit quaternion (Shepperd's method, stable for every angle)."""
    # Imported here: the kernel needs numba, which nodes that never convert matrices skip loading.
    from sim_runtime.rotations import quaternions_xyzw

    x, y, z, w = quaternions_xyzw(np.ascontiguousarray(rotation, dtype=np.float64)[None, :3, :3])[0]
    return Quaternion(x=float(x), y=float(y), z=float(z), w=float(w))


def matrix_from_quaternion(q: Quaternion) -> np.ndarray:
    """Quaternion (need not be unit: it is normalised) → 3x3 rotation matrix."""
    v = np.array([q.w, q.x, q.y, q.z], dtype=float)
    w, x, y, z = v / np.linalg.norm(v)
    return np.array(
        [
            [1 - 2 * (y * y + z * z), 2 * (x * y - w * z), 2 * (x * z + w * y)],
            [2 * (x * y + w * z), 1 - 2 * (x * x + z * z), 2 * (y * z - w * x)],
            [2 * (x * z - w * y), 2 * (y * z + w * x), 1 - 2 * (x * x + y * y)],
        ]
    )


def float32_array(values: ArrayLike) -> array.array[float]:
    """Fast fill for ``float32[]`` fields: ``msg.ranges = float32_array(ranges)``."""
    return array.array("f", np.ascontiguousarray(values, dtype=np.float32).tobytes())


def float64_array(values: ArrayLike) -> array.array[float]:
    """Fast fill for ``float64[]`` fields (JointState positions, …)."""
    return array.array("d", np.ascontiguousarray(values, dtype=np.float64).tobytes())


def occupancy_grid_msg(
    occupied: np.ndarray, resolution: float, origin_xy: tuple[float, float], stamp: Time
) -> OccupancyGrid:
    """A map as ``nav_msgs/OccupancyGrid`` in frame ``map`` (map_server's conventions): 100 where
    ``occupied[row, column]`` is true, else 0; row 0 is the lowest y; ``origin_xy`` is the
    lower-left corner of cell (0, 0)."""
    msg = OccupancyGrid()
    msg.header.frame_id = "map"
    msg.header.stamp = stamp
    msg.info.map_load_time = stamp
    msg.info.resolution = float(resolution)
    msg.info.height, msg.info.width = (int(n) for n in occupied.shape)
    msg.info.origin = pose_msg(origin_xy[0], origin_xy[1], 0.0)
    msg.data = array.array("b", np.where(occupied, 100, 0).astype(np.int8).tobytes())
    return msg


def pose_msg(x: float, y: float, yaw: float, z: float = 0.0) -> Pose:
    """Planar pose (REP-103: yaw about +z) as ``geometry_msgs/Pose``."""
    return Pose(position=Point(x=float(x), y=float(y), z=float(z)), orientation=quaternion_from_yaw(yaw))


def set_planar_pose(pose: Pose, x: float, y: float, yaw: float) -> None:
    """Move a planar ``geometry_msgs/Pose`` in place: a reused message needs no new Point and
    Quaternion objects per publication (their constructors cost more than the publish)."""
    p, q = pose.position, pose.orientation
    p.x, p.y = x, y
    q.z, q.w = math.sin(0.5 * yaw), math.cos(0.5 * yaw)


def color_msg(r: float, g: float, b: float, a: float = 1.0) -> ColorRGBA:
    """RGBA in 0–1 as ``std_msgs/ColorRGBA``."""
    return ColorRGBA(r=float(r), g=float(g), b=float(b), a=float(a))


def all_finite(*values: float) -> bool:
    """True when no value is NaN or ±inf."""
    return all(math.isfinite(v) for v in values)


#: Largest magnitude a velocity command component may have (m/s, rad/s). Anything bigger is a
#: units bug, not a request: it would overflow the kinematics into inf.
ABSURD_COMMAND = 1000.0


def command_ok(*values: float) -> bool:
    """True when every command component is finite and at most :data:`ABSURD_COMMAND` in size;
    a command failing this is rejected (with a throttled warning) before it touches state."""
    return all(math.isfinite(v) and abs(v) <= ABSURD_COMMAND for v in values)
