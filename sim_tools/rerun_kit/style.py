"""Where things are drawn (entity roots, the timeline) and how (colours, sizes, merge distances)."""

from __future__ import annotations

import numpy as np

TIMELINE = "sim_time"
TOP = "top"
"""Origin of the top-down views."""
MAP = "top/map"
"""The ``map`` frame in the top-down views."""
WORLD = "world"
"""The 3-D frame (arms)."""
MIRROR_Y = np.diag([1.0, -1.0, 1.0])
"""2-D views draw +y downwards (image convention); the map frame is mirrored so +y is up."""

TRUTH_HISTORY = 64
"""Ground-truth poses kept to pair with odometry of the same instant (and odometry kept waiting)."""
TRACK_MIN_STEP = 0.005
"""A track gets a new point once the robot moved this far (m): no 50 Hz duplicates when parked."""
TRACK_SEGMENT_POINTS = 256
"""Tracks are logged as growing strips of at most this many points, then a new strip starts, so a
long run costs O(n) instead of re-logging the whole track every pose."""
EPOCH_NS = 10**17
"""Times above this (1973) are wall-clock epochs, below it sim time since the world started."""
CONSTANT_SPAN = 1e-9
"""A converted series whose values stay within this span is not plotted (rounding noise such as
an odometry error of 1e-16 m, or a button never pressed): it would be drawn as large zigzags."""
AXES_LENGTH_M = 0.15
MARK_MERGE_NS = 500_000_000
MARK_MERGE_M = 0.3
"""Contacts this close in time and place make one mark (a frontal hit presses both bumpers)."""
KEEP_CONSTANT_TABS = frozenset({"commands"})
"""Plot tabs whose never-changing series are still plotted: a command is what a controller sent
(alg2's right wheel is always 0.5 rad/s)."""
OUTLINED_MIN_HEADING_M = 0.12
OUTLINED_HEADING_PER_SIZE = 3.0
"""The heading arrow of a robot its world outlines reaches this many outline sizes (at least the
minimum, m): well out of the outline and its dot."""

# Colours (rgb 0-255). Robots without a colour of their own (the Create) take ROBOT_COLORS in turn;
# none of them is the walls' black, the painted lines' blue, the virtual walls' green, the LIDAR's
# violet or the contacts' red.
ROBOT_COLORS = [(235, 125, 0), (0, 150, 136), (140, 86, 75), (227, 119, 194), (188, 189, 34), (127, 127, 127)]
HEADING_COLOR = (25, 25, 25)
LIDAR_COLOR = (140, 60, 220)
LIDAR_ROBOT_COLOR = (40, 110, 230)
"""LIDAR returns from another robot."""
BEAM_COLOR = (120, 120, 120, 140)
HIT_COLOR = (0, 150, 150)
DETECTOR_COLOR = (255, 140, 0)
CONTACT_COLOR = (220, 0, 0)
CRASH_COLOR = (120, 0, 0)
GRID_COLOR = (215, 215, 215)
GRID_LABEL_COLOR = (110, 110, 110)
PATH_COLOR = (230, 120, 0)
"""An end effector's path (the arm's flange)."""
OCCUPIED = 60
"""Grey of an OccupancyGrid's occupied cells (a simulator's drawing may ask for another)."""
SERIES_COLORS = [
    (31, 119, 180),
    (255, 127, 14),
    (44, 160, 44),
    (214, 39, 40),
    (148, 103, 189),
    (140, 86, 75),
    (227, 119, 194),
    (23, 190, 207),
]
"""Distinct colours for the series of one plot (tab10's, without grey and olive)."""

# visualization_msgs/Marker type and action constants (avoid importing the message at module load)
ARROW, CUBE, SPHERE, CYLINDER, LINE_STRIP, LINE_LIST, CUBE_LIST, SPHERE_LIST, POINTS, TEXT, MESH, TRIANGLES = range(12)
DELETE, DELETEALL = 2, 3


def robot_color(name: str, names: list[str]) -> tuple[int, int, int]:
    """The colour of a robot the world gives none (rgb 0–255): by its place in the sorted names."""
    index = names.index(name) if name in names else len(names)
    return ROBOT_COLORS[index % len(ROBOT_COLORS)]


def darker(color: tuple[int, int, int] | None) -> tuple[int, int, int] | None:
    """The same hue, darker (a robot's second plotted series)."""
    return None if color is None else tuple(int(c * 0.55) for c in color)  # type: ignore[return-value]
