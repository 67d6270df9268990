"""Mobile robots on the map: each one's body, heading, label and colour; the frames of its sensors
and where they are mounted (``/tf_static``, else its simulator's known mounts); marks left where
something happened."""

from __future__ import annotations

import math

import rerun as rr

from sim_tools.rerun_kit import shapes
from sim_tools.rerun_kit.contract import DEFAULT_LOOK, Outline, RobotLook, outline_at
from sim_tools.rerun_kit.plots import Plots
from sim_tools.rerun_kit.ros import basename, path_part, yaw_transform
from sim_tools.rerun_kit.state import Robot, Track
from sim_tools.rerun_kit.style import (
    CONTACT_COLOR,
    CRASH_COLOR,
    HEADING_COLOR,
    MAP,
    MARK_MERGE_M,
    MARK_MERGE_NS,
    OUTLINED_HEADING_PER_SIZE,
    OUTLINED_MIN_HEADING_M,
    ROBOT_COLORS,
    WORLD,
    robot_color,
)
from sim_tools.rerun_kit.tf import Mount


class Robots(Plots):
    """The robots of a planar world, found by name (their namespace; ``robot`` for the root)."""

    def look_of(self, name: str) -> RobotLook:
        """How robot ``name`` is drawn: its simulator's look, else the default one."""
        ns = "" if name == "robot" else name
        for drawing in self.drawings:
            if drawing.look is not None and drawing.owns_robot(ns, self.topics):
                return drawing.look
        return DEFAULT_LOOK

    def is_robot(self, name: str) -> bool:
        """Whether ``name`` (``robot``: the root namespace) is a robot of this world."""
        return name in self._robots or name in self._topic_robots

    def known_robot(self, name: str) -> Robot | None:
        """Robot ``name`` if it has been drawn."""
        return self._robots.get(name)

    def robot(self, name: str) -> Robot:
        """The robot in namespace ``name`` (``""``: the root), drawn on first use."""
        key = name or "robot"
        robot = self._robots.get(key)
        if robot is None:
            look = self.look_of(key)
            color = None
            if not self._outlined:  # robots outlined by their world wait for their outline's colour
                known = self._topic_robots
                color = robot_color(key, known) if key in known else ROBOT_COLORS[len(self._robots) % len(ROBOT_COLORS)]
            robot = Robot(
                key,
                color,
                look,
                Track(f"{MAP}/tracks/{key}/truth", color, 2.5),
                Track(f"{MAP}/tracks/{key}/odom", color, 1.0),
                expects_truth=self._has_truth_topic(key),
                heading_m=look.heading_m,
            )
            self._robots[key] = robot
            self.layout_version += 1
            self._start_planar()
            self._log_body(robot)
        return robot

    def _has_truth_topic(self, robot: str) -> bool:
        ns = "" if robot == "robot" else robot
        return any(f"{ns}/{name}".strip("/") in self._topic_names for name in self.truth_pose_topics)

    def _log_body(self, robot: Robot) -> None:
        entity = f"{MAP}/robots/{robot.name}/body"
        color = robot.color or HEADING_COLOR
        self.rec.log(entity, robot.look.body(color), static=True)
        # The heading is dark on every robot colour, drawn above the sensor beams.
        self.rec.log(
            f"{entity}/heading",
            rr.Arrows2D(
                origins=[[0.0, 0.0]],
                vectors=[[robot.heading_m, 0.0]],
                radii=rr.Radius.ui_points(robot.look.heading_width_ui),
                colors=[HEADING_COLOR],
                draw_order=40,
            ),
            static=True,
        )
        self.log_label(robot)

    def log_label(self, robot: Robot) -> None:
        """The robot's one label, below it on screen (the follow frame is the view's own: +y down;
        a label hangs from its point), saying its name, obstacle number and state; logged again
        when they change."""
        text = robot.name if robot.number is None else f"{robot.name} (#{robot.number})"
        text += " crashed" if robot.crashed else ""
        text += " off" if robot.powered is False else ""
        if text == robot.label:
            return
        robot.label = text
        d = robot.look.label_offset_m
        label = rr.Points2D([[0.0, d]], radii=0.0, colors=[HEADING_COLOR], labels=[text], show_labels=True)
        self.rec.log(f"{MAP}/robots/{robot.name}/follow/label", label)

    def _set_color(self, robot: Robot, outline: Outline) -> None:
        robot.color, robot.number = outline.color, outline.number
        self.layout_version += 1  # a live view sends the legend again, with the colour's name
        robot.heading_m = max(OUTLINED_HEADING_PER_SIZE * outline.size_m, OUTLINED_MIN_HEADING_M)
        for track in (robot.truth, robot.odom):
            track.color = outline.color
            track.log(self.rec)
        self._log_body(robot)
        if not self._batch:  # its plotted series were given the palette's colours until now
            for entity, series in self._series.items():
                if series.robot == robot.name and series.shade is not None:
                    self._log_series_style(entity, series)

    def use_outlines(self, outlines: list[Outline], within_m: float) -> None:
        """The world's outlines of its robots now: each robot still without a colour takes that of
        the outline around it (within ``within_m`` of its pose)."""
        self._outlines, self._outline_match_m = outlines, within_m
        self._match_outlines()

    def _match_outlines(self) -> None:
        for robot in self._robots.values():
            if robot.color is None and robot.pose is not None:
                outline = outline_at(self._outlines, *robot.pose[:2], self._outline_match_m)
                if outline is not None:
                    self._set_color(robot, outline)

    def frame_entity(self, frame_id: str) -> str:
        """The entity of a frame: the map, the 3-D world, a robot, or a sensor mounted on a robot."""
        frame = frame_id.strip("/")
        prefix, _, leaf = frame.rpartition("/")
        if frame == WORLD or not self.planar:
            return WORLD
        if frame in ("", "map") or leaf == "odom":  # odometry frames start at the map origin
            return MAP
        key = prefix or "robot"
        if key not in self._robots and key not in self._topic_robots:
            return MAP
        robot = self.robot(prefix)
        if leaf == "base_link":
            return f"{MAP}/robots/{robot.name}"
        entity = f"{MAP}/robots/{robot.name}/{path_part(leaf)}"
        if leaf not in robot.mounts:
            self._mount(robot, leaf, self._known_mount(robot, frame, leaf))
        return entity

    def _known_mount(self, robot: Robot, frame: str, leaf: str) -> Mount:
        from_tf = self.frames.mount_on(frame)
        if from_tf is not None:
            return from_tf
        return robot.look.mounts.get(leaf, Mount(0.0, 0.0, 0.0))

    def _mount(self, robot: Robot, leaf: str, mount: Mount) -> None:
        robot.mounts[leaf] = mount
        self.rec.log(f"{MAP}/robots/{robot.name}/{path_part(leaf)}", yaw_transform(*mount), static=True)

    def _at_mount(self, robot: Robot, leaf: str) -> tuple[float, float]:
        """Where a sensor of the robot is on the map now."""
        x, y, yaw = robot.pose or (0.0, 0.0, 0.0)
        m = robot.mounts.get(leaf, Mount(0.0, 0.0, 0.0))
        c, s = math.cos(yaw), math.sin(yaw)
        return x + c * m.x_m - s * m.y_m, y + s * m.x_m + c * m.y_m

    def sensor_robot(self, entity: str) -> Robot | None:
        """The robot a sensor's entity is mounted on, if any."""
        parts = entity.split("/")
        if len(parts) >= 4 and entity.startswith(f"{MAP}/robots/"):
            return self._robots.get(parts[3])
        return None

    def _tf_message(self, topic: str, msg) -> None:
        static = basename(topic) == "tf_static"
        for _parent, child, mount in self.frames.add(msg, static):
            if not static:
                continue  # moving frames: poses come from the pose and odometry topics
            prefix, _, leaf = child.rpartition("/")
            robot = self._robots.get(prefix or "robot")
            if robot is not None and leaf in robot.mounts and self.frames.mount_on(child) is not None:
                self._mount(robot, leaf, mount)  # a sensor drawn before its mount arrived

    def mark(self, robot: Robot, kind: str, x: float, y: float) -> None:
        """A cross that stays on the map where it happened (``kind``: ``contacts`` or ``crashes``).
        Unlabelled: where a robot keeps bumping labels would pile up; Events has the times."""
        marks = robot.marks.setdefault(kind, [])
        if robot.last_mark.get(kind) is not None:
            t, mx, my = robot.last_mark[kind]
            if self._t_ns - t < MARK_MERGE_NS and math.hypot(x - mx, y - my) < MARK_MERGE_M:
                return  # both bumpers of one frontal hit: one mark
        robot.last_mark[kind] = (self._t_ns, x, y)
        marks.append((x, y))
        color, half = (CRASH_COLOR, 0.05) if kind == "crashes" else (CONTACT_COLOR, 0.035)
        strips = [s for mx, my in marks for s in shapes.cross(mx, my, half)]
        self.rec.log(
            f"{MAP}/marks/{robot.name}/{kind}",
            rr.LineStrips2D(strips, radii=rr.Radius.ui_points(2.5), colors=[color], draw_order=50),
        )
