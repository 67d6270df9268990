"""Where each of the Create's sensors sits on the robot: the one table every user imports.

The model measures from these points, the world node names its frames after them, ``/tf_static``
and the URDF publish them, and the Rerun views draw beams from them. Poses are on ``base_link``
(REP-103: x forward, y left, z up), in metres and radians.

>>> SENSOR_MOUNTS["laser"].x_m
0.16
>>> sorted(name for name in SENSOR_MOUNTS if name.startswith("sonar_"))
['sonar_back', 'sonar_front', 'sonar_left', 'sonar_right']
"""

from __future__ import annotations

import math
from typing import NamedTuple

RADIUS_M = 0.16
"""Body radius: the Create is a disc."""
BODY_HEIGHT_M = 0.07
"""Height of the body's top above the floor (the originals are 2-D; used for the 3-D frames only)."""
WHEEL_BASE_M = 0.258
"""Distance between the wheels."""
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
SONAR_NAMES = ("front", "left", "back", "right")
SONAR_BEARINGS_RAD = (0.0, 0.5 * math.pi, math.pi, -0.5 * math.pi)
"""Sonars look outward from the body's edge, so their ranges start there."""


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
        # The virtual-wall receiver is omnidirectional, on top of the body.
        "virtual_wall_ir": Mount(0.0, 0.0, BODY_HEIGHT_M, 0.0),
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
