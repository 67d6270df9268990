"""The Create in the Rerun views (its adapter's ``rerun`` part; the contract is in
:mod:`sim_tools.rerun_view.logger`): a disc robot owning the namespaces with an ``overhead_pose``,
its map's markers (walls, painted lines, beacons, faint virtual walls cut at the walls), its
bumpers as contacts and its cliff sensors as a plot and a detector."""

from __future__ import annotations

import math
from collections.abc import Mapping
from typing import ClassVar

import numpy as np
import rerun as rr

from create_sim import spec
from sim_tools.rerun_kit.contract import DetectorStyle, Handler, PlotTab, RobotLook, SimulatorDrawing
from sim_tools.rerun_kit.drawer import Drawer
from sim_tools.rerun_kit.ros import basename, namespace
from sim_tools.rerun_kit.tf import Mount

TRUTH_TOPIC = spec.OVERHEAD_POSE_TOPIC
"""The overhead camera's pose: ground truth, and what marks a namespace as a Create's."""
MAP_TOPIC = spec.MAP_MARKERS_TOPIC
OCCUPIED_UNDER_LINES = 175
"""Grey of the grid map's occupied cells under the map's exact walls: the cells a planner sees."""


def body(color: tuple[int, int, int]) -> rr.AsComponents:
    """The Create's disc, outlined in its colour."""
    a = np.linspace(0.0, 2 * math.pi, 49)
    circle = np.column_stack([spec.RADIUS_M * np.cos(a), spec.RADIUS_M * np.sin(a)])
    return rr.LineStrips2D([circle], radii=rr.Radius.ui_points(3.0), colors=[color], draw_order=30)


LOOK = RobotLook(
    body=body,
    heading_m=spec.RADIUS_M,
    heading_width_ui=2.5,
    label_offset_m=0.2,
    follow_half_width_m=2.2,  # the LIDAR reaches 4 m
    mounts={name: Mount(m.x_m, m.y_m, m.yaw_rad) for name, m in spec.SENSOR_MOUNTS.items()},
)


def draw_cliff(view: Drawer, topic: str, msg) -> None:
    """A cliff sensor's signal (Illuminance, %): plotted, and lit while it sees a line."""
    entity = view.frame_entity(msg.header.frame_id)
    robot = view.sensor_robot(entity)
    robot_name = robot.name if robot is not None else (namespace(topic) or "robot")
    name = basename(msg.header.frame_id) or basename(topic)
    view.scalar("cliff", robot_name, name, msg.illuminance)
    view.binary(topic, entity, robot_name, name, spec.cliff_active(msg.illuminance))


class CreateDrawing(SimulatorDrawing):
    """The Create's part of the views."""

    look = LOOK
    truth_pose_topics = (TRUTH_TOPIC,)
    map_marker_topics = (MAP_TOPIC,)
    wall_namespaces = (spec.WALLS_NS,)
    faded_markers: ClassVar[Mapping[str, float]] = {spec.VIRTUAL_WALL_FIELDS_NS: 0.3, spec.VIRTUAL_WALL_HALOS_NS: 0.45}
    plot_tabs = (PlotTab("cliff", "Cliff signal (%)", (0.0, 25.0), 20),)
    handlers: ClassVar[Mapping[tuple[str | None, str], Handler]] = {(None, "sensor_msgs/msg/Illuminance"): draw_cliff}

    def owns_robot(self, namespace_: str, topics: Mapping[str, str]) -> bool:
        return any(basename(t) == TRUTH_TOPIC and namespace(t) == namespace_ for t in topics)

    def detector_style(self, name: str) -> DetectorStyle | None:
        if "bump" in name:
            return DetectorStyle(rr.TextLogLevel.INFO, contact=True)
        return DetectorStyle(rr.TextLogLevel.INFO, contact=False) if "cliff" in name else None

    def grid_shade(self, topics: Mapping[str, str]) -> int | None:
        return OCCUPIED_UNDER_LINES if any(basename(t) == MAP_TOPIC for t in topics) else None

    def legend_lines(self, topics: Mapping[str, str]) -> list[tuple[int, str]]:
        leaves = {basename(t) for t in topics}
        has_map = MAP_TOPIC in leaves
        bumpers = any(f"/{spec.bump_topic(side)}" in t for t in topics for side in spec.BUMP_SIDES)
        grid_under_lines = has_map and "nav_msgs/msg/OccupancyGrid" in set(topics.values())
        lines = [
            (10, has_map, "- blue lines: painted lines; coloured dots: beacons with their id"),
            (20, has_map, "- pale green: virtual walls (halo and field, cut at the outer walls)"),
            (30, grid_under_lines, "- light grey cells under the walls: the grid map (`map`) a planner sees"),
            (60, bumpers, "- red dot: bumper pressed; orange dot: cliff, IR wall seen"),
            (70, bumpers, "- red x: where a bumper was pressed (times in Events)"),
        ]
        return [(rank, line) for rank, shown, line in lines if shown]


DRAWING = CreateDrawing()
