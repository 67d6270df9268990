"""The Create's spec: every fact about the robot that more than one part of the project reads.

Where each sensor sits (the model measures from these points, the world node names its frames
after them, ``/tf_static`` and the URDF publish them, the Rerun views and the studio draw from
them), the cliff signals and when a cliff counts as seen, the publication rates, the virtual
walls' halo and fields, and the names and colours of the map's markers. Poses are on
``base_link`` (REP-103: x forward, y left, z up), in metres and radians.

>>> SENSOR_MOUNTS["laser"].x_m
0.16
>>> sorted(name for name in SENSOR_MOUNTS if name.startswith("sonar_"))
['sonar_back', 'sonar_front', 'sonar_left', 'sonar_right']
"""

from __future__ import annotations

import math
from typing import NamedTuple

import numpy as np

# ------------------------------------------------------------------------------ body and sensor mounts
RADIUS_M = 0.16
"""Body radius: the Create is a disc."""
BODY_HEIGHT_M = 0.07
"""Height of the body's top above the floor (the originals are 2-D; used for the 3-D frames only)."""
WHEEL_BASE_M = 0.258
"""Distance between the wheels."""
MAX_WHEEL_SPEED_MPS = 0.5
"""Each wheel's speed limit (m/s): the model clamps each wheel to it on its own."""
MAX_TURN_RATE_RADPS = 2.0 * MAX_WHEEL_SPEED_MPS / WHEEL_BASE_M
"""Fastest turn (rad/s): spinning in place, the wheels at full speed in opposite directions."""
LIDAR_BEAMS = 681
"""Ranges in one LIDAR scan, from -120 degrees (index 0) counter-clockwise to +120 degrees."""
CAMERA_OFFSET_M = 0.13
"""The camera sits this far ahead of the centre, looking forward."""
IR_MOUNT_ANGLE_RAD = -0.225 * math.pi
"""Bearing of the IR wall sensor on the perimeter (-40.5 degrees); it looks straight right."""
BUMP_FRONT_HALF_RAD = 0.135 * math.pi
"""Contacts within this bearing of straight ahead press both bumpers."""
CLIFF_WINDOWS_RAD = (
    (0.295 * math.pi, 0.37 * math.pi),
    (0.04 * math.pi, 0.105 * math.pi),
    (-0.105 * math.pi, -0.04 * math.pi),
    (-0.37 * math.pi, -0.295 * math.pi),
)
"""Arcs of the perimeter each cliff sensor watches, order left, front-left, front-right, right."""
CLIFF_NAMES = ("left", "front_left", "front_right", "right")
"""The cliff sensors, in the order of the model's readings (topics ``cliff/<name>``)."""
SONAR_NAMES = ("front", "left", "back", "right")
"""The sonars, in the order of the model's readings (topics ``sonar/<name>``)."""
SONAR_BEARINGS_RAD = (0.0, 0.5 * math.pi, math.pi, -0.5 * math.pi)
"""Sonars look outward from the body's edge, so their ranges start there."""


def sonar_field_of_view(max_range_m: float, exact_m: float) -> float:
    """``Range.field_of_view`` of a one-ray sonar (rad): the model casts one ray per sonar, as the
    original; a wall square to the axis seen ``a`` off it reads ``d / cos(a)``, so within this cone
    a cone's reading and the ray's agree to ``exact_m`` out to ``max_range_m``."""
    return 2.0 * math.acos(max_range_m / (max_range_m + exact_m))


WHEEL_RADIUS_M = 0.036
"""Drive wheel radius (the original's encoder model: 508.8 counts per turn of a 72 mm wheel)."""
FOOTPRINT_FRAME = "base_footprint"
"""REP-120's ground projection of ``base_link``; ``base_link`` is already on the floor at the disc's
centre, so it is ``base_link`` itself (a fixed identity transform below it, as Nav2 expects it)."""
WHEEL_JOINTS = ("left_wheel_joint", "right_wheel_joint")
"""``joint_states`` names (with the robot's prefix) of the drive wheels' continuous joints."""
ODOMETRY_RESOLUTION = (1e-3, math.radians(1.0), 1e-3)
"""What the Create itself resolves (its Open Interface's units): distance 1 mm, angle 1 degree,
wheel speed 1 mm/s. The model's noise-free odometry is exact, but the robot it stands for counts
in these steps, so the odometry's covariances never go below their rounding variance (step²/12)."""


class Mount(NamedTuple):
    """A sensor frame's pose on ``base_link``."""

    x_m: float
    y_m: float
    z_m: float
    yaw_rad: float


def _on_edge(bearing_rad: float, z_m: float, yaw_rad: float | None = None) -> Mount:
    """A frame on the perimeter at ``bearing_rad``, looking outward unless ``yaw_rad`` says otherwise."""
    yaw = bearing_rad if yaw_rad is None else yaw_rad
    return Mount(RADIUS_M * math.cos(bearing_rad), RADIUS_M * math.sin(bearing_rad), z_m, yaw)


def _sensor_mounts() -> dict[str, Mount]:
    mounts = {
        "laser": Mount(RADIUS_M, 0.0, BODY_HEIGHT_M + 0.03, 0.0),
        "camera": Mount(CAMERA_OFFSET_M, 0.0, BODY_HEIGHT_M + 0.03, 0.0),
        "wall_ir": _on_edge(IR_MOUNT_ANGLE_RAD, 0.03, -0.5 * math.pi),
        # The virtual-wall receiver is omnidirectional, on top of the body at its front edge: where
        # the model tests the halo and the fields.
        "virtual_wall_ir": Mount(RADIUS_M, 0.0, BODY_HEIGHT_M, 0.0),
        "bump_left": _on_edge(0.25 * math.pi, 0.03),
        "bump_right": _on_edge(-0.25 * math.pi, 0.03),
    }
    for name, bearing in zip(SONAR_NAMES, SONAR_BEARINGS_RAD, strict=True):
        mounts[f"sonar_{name}"] = _on_edge(bearing, 0.05)
    for name, (lo, hi) in zip(CLIFF_NAMES, CLIFF_WINDOWS_RAD, strict=True):
        mounts[f"cliff_{name}"] = _on_edge(0.5 * (lo + hi), 0.01)
    return mounts


SENSOR_MOUNTS: dict[str, Mount] = _sensor_mounts()
"""Sensor frame name (without the robot's prefix) → its mount on ``base_link``."""


# ------------------------------------------------------------------------------ topics
# Relative names: each resolves under the robot's namespace (``/<robot>/odom``); the world node
# publishes them, the client, studio, learning envs and bridges subscribe to them.
CMD_VEL_TOPIC = "cmd_vel"
"""Velocity command (Twist, or TwistStamped with ``cmd_vel_stamped``)."""
ODOM_TOPIC = "odom"
"""Odometry (nav_msgs/Odometry); also the name of the odometry frame."""
OVERHEAD_POSE_TOPIC = "overhead_pose"
"""The true pose in the map (the original's overhead localisation), PoseStamped."""
SCAN_TOPIC = "scan"
"""LIDAR scan (LaserScan, ``LIDAR_BEAMS`` ranges)."""
WALL_TOPIC = "wall"
"""IR wall sensor (Range, -inf = wall seen)."""
VIRTUAL_WALL_TOPIC = "virtual_wall"
"""Virtual-wall receiver (Range, -inf = inside a halo or field)."""
CAMERA_BEACONS_TOPIC = "camera/beacons"
"""The camera's beacon sightings (MarkerArray)."""
BUTTONS_TOPIC = "buttons"
"""The Play and Advance buttons (Joy)."""
BATTERY_TOPIC = "battery_state"
"""Battery state (BatteryState)."""
JOINT_STATES_TOPIC = "joint_states"
"""The wheels' joint states (JointState)."""
MAP_MARKERS_TOPIC = "map_markers"
"""The map's latched MarkerArray (namespaces ``MAP_NAMESPACES``)."""
MAP_TOPIC = "map"
"""The map's walls as a latched OccupancyGrid."""
SET_POSE_TOPIC = "set_pose"
"""Moves the robot to a pose in the map (PoseStamped)."""
SET_POSE_SERVICE = "set_pose"
"""The same move as a service (robot_sims_interfaces/SetPose) that answers whether it was done and why not."""
BUMP_SIDES = ("left", "right")
"""The bumpers (topics ``bump/<side>``)."""


def bump_topic(side: str) -> str:
    """Topic of one bumper (Range, -inf = pressed)."""
    return f"bump/{side}"


def cliff_topic(name: str) -> str:
    """Topic of one cliff sensor of ``CLIFF_NAMES`` (Illuminance, the signal in %)."""
    return f"cliff/{name}"


def sonar_topic(name: str) -> str:
    """Topic of one sonar of ``SONAR_NAMES`` (Range from the body's edge)."""
    return f"sonar/{name}"


# ------------------------------------------------------------------------------ rates
PHYSICS_RATE = 100.0
"""Fixed physics rate (Hz) of ``create_world``, independent of ``real_time_factor``."""
DEFAULT_RATES: dict[str, float] = {
    "bump": 50.0,
    "cliff": 50.0,
    "wall": 50.0,
    "virtual_wall": 50.0,
    "odom": 50.0,
    "overhead_pose": 50.0,
    "sonar": 20.0,
    "scan": 10.0,
    "camera": 10.0,
    "buttons": 10.0,
    "battery": 1.0,
}
"""Default publication rate (Hz) per ``rate.<name>`` parameter."""

# ------------------------------------------------------------------------------ cliff sensors
CLIFF_FLOOR_SIGNAL = 21.5
"""Cliff signal strength (%) over bare floor, before noise (the original's 20·1 + 1.5)."""
CLIFF_LINE_SIGNAL = 1.5
"""Cliff signal strength (%) over a painted line, before noise."""
CLIFF_ACTIVE_AT_OR_BELOW = 5.4
"""A cliff signal (%) at or below this means the sensor sees a line: the original's GUI marks the
sensor then. It lies between the line's 1.5 and the floor's 21.5, nearer the line, so a noisy
floor reading is rarely shown as a line (with the example config's cliff noise, 3 ± 6.9, a floor
reads 24.5 ± 6.9: at or below 5.4 in about 3 readings in 1000)."""


def cliff_active(signal: float) -> bool:
    """Whether a cliff signal (%) means a line under the sensor, as the original's GUI shows it."""
    return signal <= CLIFF_ACTIVE_AT_OR_BELOW


# ------------------------------------------------------------------------------ virtual walls
VWALL_HALO_M = 0.45
"""Radius of the halo around each virtual-wall emitter."""
VWALL_FIELDS: dict[int, tuple[float, float]] = {1: (2.13, 0.33), 2: (5.56, 0.49), 3: (8.08, 0.61)}
"""Virtual-wall field per setting 1, 2, 3: (range m, full opening angle rad)."""


def virtual_wall_field(x: float, y: float, theta: float, setting: float) -> np.ndarray:
    """Triangle (3, 2) of a virtual wall's main field: emitter, then the two far corners (left,
    then right of the emitter's axis)."""
    length, angle = VWALL_FIELDS[int(setting)]  # the map parser admits only 1, 2, 3
    corners = [
        (x + length * math.cos(theta + s * angle / 2), y + length * math.sin(theta + s * angle / 2)) for s in (1, -1)
    ]
    return np.array([(x, y), *corners])


def virtual_wall_setting(field_length_m: float) -> int:
    """The setting whose field is nearest ``field_length_m`` long (a field drawn back to its setting)."""
    return min(VWALL_FIELDS, key=lambda s: abs(VWALL_FIELDS[s][0] - field_length_m))


# ------------------------------------------------------------------------------ map markers
WALLS_NS = "walls"
"""``map_markers`` namespace of the walls (one LINE_LIST)."""
LINES_NS = "lines"
"""``map_markers`` namespace of the painted lines (one LINE_LIST)."""
BEACONS_NS = "beacons"
"""Namespace of a beacon's SPHERE, in ``map_markers`` and in ``camera/beacons``."""
BEACON_IDS_NS = "beacon_ids"
"""``map_markers`` namespace of the beacons' labels (TEXT_VIEW_FACING, text = id)."""
VIRTUAL_WALL_HALOS_NS = "virtual_wall_halos"
"""``map_markers`` namespace of the virtual walls' halos (a LINE_STRIP circle each)."""
VIRTUAL_WALL_FIELDS_NS = "virtual_wall_fields"
"""``map_markers`` namespace of the virtual walls' fields (a closed LINE_STRIP triangle each)."""
MAP_NAMESPACES = (WALLS_NS, LINES_NS, BEACONS_NS, BEACON_IDS_NS, VIRTUAL_WALL_HALOS_NS, VIRTUAL_WALL_FIELDS_NS)
"""Every namespace of a map's own ``map_markers``; markers of other namespaces (a learning env's
goal region) are drawn beside the map."""
WALL_RGB = (0.1, 0.1, 0.1)
"""Colour (rgb 0..1) of the walls' markers."""
LINE_RGB = (0.2, 0.2, 0.9)
"""Colour (rgb 0..1) of the painted lines' markers."""
VIRTUAL_WALL_RGBA = (0.0, 0.7, 0.0, 0.8)
"""Colour (rgba 0..1) of the virtual walls' halo and field markers."""


def hex_colour(rgb: tuple[float, ...]) -> str:
    """``#rrggbb`` of a colour above (alpha dropped), for the studio's SVG: it draws the map in
    the same colours as the ROS markers and Rerun."""
    return "#" + "".join(f"{round(min(max(c, 0.0), 1.0) * 255):02x}" for c in rgb[:3])
