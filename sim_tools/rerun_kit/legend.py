"""The Legend panel of the Rerun views: what each colour and mark means, for the world in the
recording (a line for LIDAR only if there is a scan, …), and which colour each robot has.
Simulators add their notes and lines (:class:`~sim_tools.rerun_kit.contract.SimulatorDrawing`)."""

from __future__ import annotations

from collections.abc import Sequence

from sim_tools.rerun_kit.contract import SimulatorDrawing

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


def color_name(color: tuple[int, int, int]) -> str:
    """The nearest of COLOR_NAMES."""
    return min(COLOR_NAMES, key=lambda n: sum((a - b) ** 2 for a, b in zip(COLOR_NAMES[n], color, strict=True)))


def robot_entry(name: str, color: tuple[int, int, int] | None, number: int | None) -> str:
    """``r1 yellow #2``: name, colour and obstacle number (if its world numbers its robots)."""
    return " ".join(part for part in (name, color_name(color) if color else "", f"#{number}" if number else "") if part)


def mobile(topics: dict[str, str], robots: list[str], drawings: Sequence[SimulatorDrawing]) -> str:
    """The legend of a world of mobile robots (markdown); ``topics`` name → type, ``robots`` from
    :func:`robot_entry`, ``drawings`` the simulators'."""
    kinds = set(topics.values())
    leaves = {t.rstrip("/").rpartition("/")[2] for t in topics}
    notes = ["label below each", *(note for d in drawings for note in d.legend_notes(leaves))]
    lines = [
        f"**Robots**: {', '.join(robots)} ({'; '.join(n for n in notes if n)})",
        "- tracks in the robot's colour: thick = ground truth, thin = odometry; dark arrow: heading",
        "- walls dark; a light grey line every metre",
    ]
    optional = [
        (40, "sensor_msgs/msg/LaserScan" in kinds, "- violet dots: LIDAR hits (blue: another robot); faint rays"),
        (50, "sensor_msgs/msg/Range" in kinds, "- grey fan: a sonar's cone; teal arc or ray: its echo"),
    ]
    ranked = [(rank, line) for rank, shown, line in optional if shown]
    ranked += [item for d in drawings for item in d.legend_lines(topics)]
    return "\n".join(lines + [line for _, line in sorted(ranked, key=lambda item: item[0])])
