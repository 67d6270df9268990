"""The Legend panel of the Rerun views: what each colour and mark means, for the world in the
recording (a line for LIDAR only if there is a scan, …), and which colour each robot has."""

from __future__ import annotations

COLOR_NAMES = {
    "yellow": (255, 255, 0),
    "red": (255, 0, 0),
    "blue": (0, 100, 255),
    "green": (0, 170, 0),
    "orange": (235, 125, 0),
    "pink": (255, 50, 150),
    "teal": (0, 150, 136),
    "brown": (140, 86, 75),
    "violet": (140, 60, 220),
    "grey": (127, 127, 127),
    "black": (0, 0, 0),
}
"""Names the legend gives robot colours (the nearest)."""

ARM = (
    "**Arm**: meshes in their colours; axes x red, y green, z blue.\n\n"
    "- orange line: the flange's path (small axes: the flange now)\n"
    "- large axes with a name: a commanded target pose"
)


def color_name(color: tuple[int, int, int]) -> str:
    """The nearest of COLOR_NAMES."""
    return min(COLOR_NAMES, key=lambda n: sum((a - b) ** 2 for a, b in zip(COLOR_NAMES[n], color, strict=True)))


def robot_entry(name: str, color: tuple[int, int, int] | None, number: int | None) -> str:
    """``r1 yellow #2``: name, colour and (SIMROBOT) obstacle number."""
    return " ".join(part for part in (name, color_name(color) if color else "", f"#{number}" if number else "") if part)


def mobile(topics: dict[str, str], robots: list[str]) -> str:
    """The legend of a world of mobile robots (markdown); ``topics`` name → type, ``robots`` from
    :func:`robot_entry`."""
    kinds = set(topics.values())
    leaves = {t.rstrip("/").rpartition("/")[2] for t in topics}
    bumpers = any("/bump/" in f"/{t.strip('/')}/" for t in topics)
    grid_under_lines = "nav_msgs/msg/OccupancyGrid" in kinds and "map_markers" in leaves
    notes = ["label below each", "#n: its obstacle number" if "obstacle" in leaves else ""]
    notes.append("*off*: powered off, *crashed*: stopped by a collision" if "crashed" in leaves else "")
    lines = [
        f"**Robots**: {', '.join(robots)} ({'; '.join(n for n in notes if n)})",
        "- tracks in the robot's colour: thick = ground truth, thin = odometry; dark arrow: heading",
        "- walls dark; a light grey line every metre",
    ]
    optional = [
        ("map_markers" in leaves, "- blue lines: painted lines; coloured dots: beacons with their id"),
        ("map_markers" in leaves, "- pale green: virtual walls (halo and field, cut at the outer walls)"),
        (grid_under_lines, "- light grey cells under the walls: the grid map (`map`) a planner sees"),
        ("sensor_msgs/msg/LaserScan" in kinds, "- violet dots: LIDAR hits (blue: another robot); faint rays"),
        ("sensor_msgs/msg/Range" in kinds, "- grey fan: a sonar's cone; teal arc or ray: its echo"),
        (bumpers, "- red dot: bumper pressed; orange dot: cliff, IR wall seen"),
        (bumpers, "- red x: where a bumper was pressed (times in Events)"),
        ("crashed" in leaves, "- dark red x: where a robot crashed (time in Events)"),
        ("obstacle" in leaves, "- *Obstacle seen* plot: 0 nothing, 1 a wall, n the robot labelled #n"),
    ]
    return "\n".join(lines + [line for shown, line in optional if shown])
