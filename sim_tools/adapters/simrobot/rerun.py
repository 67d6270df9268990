"""SIMROBOT in the Rerun views (its adapter's ``rerun`` part; the contract is in
:mod:`sim_tools.rerun_view.logger`): robots coloured and numbered by the world's ``robots``
outlines, LIDAR hits on another robot, the obstacle each sonar sees, power and crashes, wheel
commands. Its robots have the default look (a dot inside the world's outline)."""

from __future__ import annotations

import math
from collections.abc import Iterable, Mapping
from typing import ClassVar

import numpy as np
import rerun as rr

from sim_runtime.msgs import yaw_from_quaternion
from sim_tools.rerun_kit.contract import Handler, Outline, PlotTab, SimulatorDrawing
from sim_tools.rerun_kit.drawer import Drawer
from sim_tools.rerun_kit.ros import basename, namespace, points, rgba
from sim_tools.rerun_kit.state import Robot
from sim_tools.rerun_kit.style import LIDAR_COLOR, LIDAR_ROBOT_COLOR
from simrobot_sim.spec import (
    CRASHED_TOPIC,
    OBSTACLE_SUFFIX,
    POSE_TOPIC,
    POWER_TOPIC,
    ROBOT_STATES_TOPIC,
    ROBOTS_TOPIC,
    WHEEL_CMD_TOPIC,
)

FIRST_NUMBER = 2
"""Outline i is robot i, whose obstacle number is i + 2 (1 is a wall)."""
MATCH_M = 0.3
"""An outline belongs to the robot whose pose is nearest its centre, within this."""


def robot_outlines(markers: Iterable) -> list[Outline]:
    """The outlines in a ``robots`` MarkerArray: each marker's points are on its pose (the robot's)."""
    outlines = []
    for m in markers:
        pts = points(m.points)[:, :2]
        if m.action != 0 or not len(pts):
            continue
        yaw = yaw_from_quaternion(m.pose.orientation)
        c, s = math.cos(yaw), math.sin(yaw)
        local = pts.mean(axis=0)
        centre = np.array(
            [m.pose.position.x + c * local[0] - s * local[1], m.pose.position.y + s * local[0] + c * local[1]]
        )
        size = float(np.max(np.linalg.norm(pts, axis=1)))
        outlines.append(Outline(centre, rgba(m.color)[:3], size, m.id + FIRST_NUMBER))
    return outlines


def draw_obstacle(view: Drawer, topic: str, msg) -> None:
    """``<robot>/<sensor>/obstacle``: the number of what the sensor sees, plotted."""
    robot, _, sensor = namespace(topic).partition("/")
    view.scalar("obstacle", robot or "robot", sensor or "obstacle", float(msg.data), 0)


def draw_power(view: Drawer, topic: str, msg) -> None:
    """A robot's power is a state (the world latches it): its label says "off"; a switch is an event."""
    if not view.is_robot(namespace(topic) or "robot"):
        view.bool_flag(topic, msg)
        return
    robot, on = view.robot(namespace(topic)), bool(msg.data)
    if robot.powered is not None and robot.powered != on:
        view.event(robot.name, f"power {'on' if on else 'off'}", rr.TextLogLevel.INFO)
    if robot.powered != on:
        robot.powered = on
        view.log_label(robot)


def draw_crashed(view: Drawer, topic: str, msg) -> None:
    """A crash is a state: an event when it starts (WARN) and clears, the label says it, a cross
    marks where it happened."""
    name, active = namespace(topic) or "robot", bool(msg.data)
    if view.is_robot(name):
        view.robot(namespace(topic))
    if not view.state_changed(topic, active):
        return
    view.event(name, "crashed" if active else "crash cleared", rr.TextLogLevel.WARN if active else rr.TextLogLevel.INFO)
    robot: Robot | None = view.known_robot(name)
    if robot is not None:
        robot.crashed = active
        view.log_label(robot)
        if active:
            view.mark(robot, "crashes", *(robot.pose or (0.0, 0.0))[:2])


def draw_wheel_cmd(view: Drawer, topic: str, msg) -> None:
    """Wheel speed commands (JointState velocities, [left, right] rad/s), plotted with the commands."""
    for shade, (side, value) in enumerate(zip(("left", "right"), msg.velocity, strict=False)):
        view.scalar(
            "commands", namespace(topic) or "robot", f"wheel_{side}", float(value), shade, f"wheel {side} (rad/s)"
        )


class SimrobotDrawing(SimulatorDrawing):
    """SIMROBOT's part of the views."""

    truth_pose_topics = (POSE_TOPIC,)
    outline_topics = (ROBOTS_TOPIC,)
    outline_match_m = MATCH_M
    quiet_topics = (ROBOT_STATES_TOPIC,)  # a compact summary of what the other topics carry
    plot_tabs = (PlotTab("obstacle", "Obstacle seen (number)", None, 70),)
    handlers: ClassVar[Mapping[tuple[str | None, str], Handler]] = {
        **{(OBSTACLE_SUFFIX, f"std_msgs/msg/{kind}"): draw_obstacle for kind in ("UInt8", "Float64", "Float32")},
        (POWER_TOPIC, "std_msgs/msg/Bool"): draw_power,
        (CRASHED_TOPIC, "std_msgs/msg/Bool"): draw_crashed,
        (WHEEL_CMD_TOPIC, "sensor_msgs/msg/JointState"): draw_wheel_cmd,
    }

    def outlines(self, markers: Iterable) -> list[Outline]:
        return robot_outlines(markers)

    def scan_colors(self, msg, hit: np.ndarray) -> np.ndarray | None:
        """Intensity = obstacle number: 1 a wall, 2–255 a robot (drawn blue)."""
        if len(msg.intensities) != hit.size:
            return None
        obstacle = np.asarray(msg.intensities)[hit]
        return np.where((obstacle > 1)[:, None], LIDAR_ROBOT_COLOR, LIDAR_COLOR).astype(np.uint8)

    def legend_notes(self, leaves: set[str]) -> list[str]:
        notes = ["#n: its obstacle number" if OBSTACLE_SUFFIX in leaves else ""]
        return [*notes, "*off*: powered off, *crashed*: stopped by a collision" if CRASHED_TOPIC in leaves else ""]

    def legend_lines(self, topics) -> list[tuple[int, str]]:
        leaves = {basename(t) for t in topics}
        lines = [
            (80, CRASHED_TOPIC in leaves, "- dark red x: where a robot crashed (time in Events)"),
            (90, OBSTACLE_SUFFIX in leaves, "- *Obstacle seen* plot: 0 nothing, 1 a wall, n the robot labelled #n"),
        ]
        return [(rank, line) for rank, shown, line in lines if shown]


DRAWING = SimrobotDrawing()
