"""The sensors family: LIDAR scans (LaserScan), sonars and fixed-distance detectors (Range),
on/off flags (Bool); a detector is drawn lit while active and its switching is an event."""

from __future__ import annotations

import math

import numpy as np
import rerun as rr

from sim_tools.rerun_kit import shapes
from sim_tools.rerun_kit.contract import DetectorStyle
from sim_tools.rerun_kit.robots import Robots
from sim_tools.rerun_kit.ros import basename, namespace, path_part, topic_path
from sim_tools.rerun_kit.style import BEAM_COLOR, CONTACT_COLOR, DETECTOR_COLOR, HIT_COLOR, LIDAR_COLOR, MAP, WORLD

PLAIN_DETECTOR = DetectorStyle(rr.TextLogLevel.DEBUG, contact=False)
"""A detector no simulator says more of: its events are DEBUG, it lights orange."""


class Sensors(Robots):
    """Draws sensor_msgs/LaserScan, sensor_msgs/Range and std_msgs/Bool."""

    def _laser_scan(self, topic: str, msg) -> None:
        entity = self.frame_entity(msg.header.frame_id)
        ranges = np.asarray(msg.ranges, dtype=np.float64)
        angles = msg.angle_min + msg.angle_increment * np.arange(ranges.size)
        hit = np.isfinite(ranges) & (ranges > 0.0)
        r, a = ranges[hit], angles[hit]
        pts = np.column_stack([r * np.cos(a), r * np.sin(a)]).astype(np.float32)
        colors = next((c for d in self.drawings if (c := d.scan_colors(msg, hit)) is not None), [LIDAR_COLOR])
        name = path_part(basename(topic))
        if entity == WORLD:
            pts3 = np.column_stack([pts, np.zeros(len(pts), np.float32)])
            self.rec.log(f"{entity}/{name}", rr.Points3D(pts3, radii=0.01, colors=colors))
            return
        self.rec.log(f"{entity}/{name}", rr.Points2D(pts, radii=rr.Radius.ui_points(2.0), colors=colors, draw_order=20))
        # The original's GUI draws five beams across the field of view: faint rays for those.
        idx = np.linspace(0, ranges.size - 1, 5).round().astype(int) if ranges.size else np.zeros(0, int)
        reach = np.where(np.isfinite(ranges[idx]) & (ranges[idx] > 0), ranges[idx], msg.range_max)
        rays = [
            np.array([[0.0, 0.0], [d * math.cos(t), d * math.sin(t)]]) for d, t in zip(reach, angles[idx], strict=True)
        ]
        self.rec.log(
            f"{entity}/{name}_rays",
            rr.LineStrips2D(rays, radii=rr.Radius.ui_points(0.8), colors=[(*LIDAR_COLOR, 110)], draw_order=19),
        )

    def _range(self, topic: str, msg) -> None:
        entity = self.frame_entity(msg.header.frame_id)
        robot = self.sensor_robot(entity)
        robot_name = robot.name if robot is not None else (namespace(topic) or "robot")
        name = basename(msg.header.frame_id) or basename(topic)
        if msg.min_range == msg.max_range:  # REP-117 fixed-distance detector: -inf = detection
            self.binary(topic, entity, robot_name, name, msg.range == -math.inf, msg)
            return
        r = float(msg.range)
        if entity != WORLD:
            self._sonar(entity, msg)
        if math.isfinite(r):
            self._grow_tab("range", 0.0, float(msg.max_range))
            self.scalar("range", robot_name, name, r, 0)

    def _sonar(self, entity: str, msg) -> None:
        """A sonar's cone (once) and the arc of its echo."""
        fov, r = float(msg.field_of_view), float(msg.range)
        key = f"{entity}/beam"
        if key not in self._marker_entities and fov > 0:
            # The beam's real cone is fixed (a single-ray sensor has none: only its hit is drawn).
            self._marker_entities[key] = set()
            outline = shapes.fan(fov, msg.max_range)
            self.rec.log(
                key,
                rr.LineStrips2D([outline], radii=rr.Radius.ui_points(1.0), colors=[BEAM_COLOR], draw_order=10),
                static=True,
            )
        if math.isfinite(r) and r > 0:
            # A sonar reports the nearest echo somewhere in its cone: the arc at that range.
            shape = shapes.arc(fov, r) if fov > 0 else np.array([[0, 0], [r, 0]], dtype=np.float32)
            self.rec.log(
                f"{entity}/hit",
                rr.LineStrips2D(
                    [shape], radii=rr.Radius.ui_points(3.0 if fov > 0 else 1.2), colors=[HIT_COLOR], draw_order=35
                ),
                rr.Points2D([[r, 0.0]], radii=rr.Radius.ui_points(4.0), colors=[HIT_COLOR], draw_order=36),
            )
        else:
            self.rec.log(f"{entity}/hit", rr.Clear(recursive=False))

    def bool_flag(self, topic: str, msg) -> None:
        """A Bool: a robot's detector when in a robot's namespace, else a flag of the world."""
        robot = namespace(topic) or "robot"
        if self.is_robot(robot):
            entity = f"{MAP}/robots/{self.robot(namespace(topic)).name}/{path_part(basename(topic))}"
        else:
            entity = f"{MAP if self.planar else WORLD}/flags/{topic_path(topic)}"
        self.binary(topic, entity, robot, basename(topic), bool(msg.data))

    def state_changed(self, topic: str, active: bool) -> bool:
        """Whether ``topic``'s on/off state switched (detectors publish at 50 Hz and are mostly
        idle: drawn on change only); the first state, off, is no switch."""
        previous = self._binary_state.get(topic)
        if previous == active:
            return False
        self._binary_state[topic] = active
        return not (previous is None and not active)

    def binary(self, topic: str, entity: str, robot_name: str, name: str, active: bool, msg=None) -> None:
        """A detector ``name`` of ``robot_name`` at ``entity`` switched on or off: an event, and a
        dot (and its line of sight, if ``msg`` is a Range with a reach) while on."""
        if not self.state_changed(topic, active):
            return
        style = next((s for d in self.drawings if (s := d.detector_style(name)) is not None), PLAIN_DETECTOR)
        self.event(robot_name, f"{name} {'on' if active else 'off'}", style.level)
        if entity == WORLD:
            return
        lit = f"{entity}/detection" if entity.startswith(f"{MAP}/robots/") else entity
        if not active:
            self.rec.log(lit, rr.Clear(recursive=False))
            return
        reach = float(msg.max_range) if msg is not None and math.isfinite(msg.max_range) else 0.0
        color = CONTACT_COLOR if style.contact else DETECTOR_COLOR
        drawn: list[rr.AsComponents] = [
            rr.Points2D([[0.0, 0.0]], radii=rr.Radius.ui_points(6.0), colors=[color], draw_order=45)
        ]
        if reach > 0:  # a detector that sees along a line (the IR wall sensor)
            drawn.append(
                rr.LineStrips2D(
                    [[[0.0, 0.0], [reach, 0.0]]], radii=rr.Radius.ui_points(3), colors=[color], draw_order=45
                )
            )
        self.rec.log(lit, *drawn)
        robot = self._robots.get(robot_name)
        if robot is not None and style.contact:
            self.mark(robot, "contacts", *self._at_mount(robot, entity.rpartition("/")[2]))
