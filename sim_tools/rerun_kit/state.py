"""What the views remember between messages: growing tracks, each robot's state, plotted series."""

from __future__ import annotations

import math
from collections import deque
from dataclasses import dataclass, field

import numpy as np
import rerun as rr

from sim_tools.rerun_kit.contract import RobotLook
from sim_tools.rerun_kit.style import TRACK_MIN_STEP, TRACK_SEGMENT_POINTS, TRUTH_HISTORY
from sim_tools.rerun_kit.tf import Mount


@dataclass
class Track:
    """A growing track, logged in segments of at most TRACK_SEGMENT_POINTS points; nothing is
    logged until the track has a colour (robots outlined by their world get theirs from it)."""

    entity: str
    color: tuple[int, int, int] | None
    width_ui: float
    dims: int = 2
    points: list[tuple[float, ...]] = field(default_factory=list)
    segment: int = 0

    def add(self, rec: rr.RecordingStream, *xyz: float) -> None:
        """Extend the track to ``xyz`` if it moved TRACK_MIN_STEP."""
        if self.points and math.dist(xyz, self.points[-1]) < TRACK_MIN_STEP:
            return
        if len(self.points) >= TRACK_SEGMENT_POINTS:
            self.points = self.points[-1:]  # the next segment starts where this one ended
            self.segment += 1
        self.points.append(xyz)
        self.log(rec)

    def log(self, rec: rr.RecordingStream) -> None:
        """Log the current segment (once the track has a colour)."""
        if self.color is None or not self.points:
            return
        strip = np.array(self.points, dtype=np.float32)
        kind = rr.LineStrips2D if self.dims == 2 else rr.LineStrips3D
        radius = rr.Radius.ui_points(self.width_ui)
        rec.log(f"{self.entity}/{self.segment}", kind([strip], radii=radius, colors=[self.color]))


@dataclass
class Robot:
    """A mobile robot of the top-down views."""

    name: str
    color: tuple[int, int, int] | None
    look: RobotLook
    truth: Track
    odom: Track
    expects_truth: bool = False  # the robot has a ground-truth pose topic
    # recent ground-truth poses and odometry waiting for the truth of its instant: (t_ns, x, y, yaw)
    truths: deque[tuple[int, float, float, float]] = field(default_factory=lambda: deque(maxlen=TRUTH_HISTORY))
    pending_odom: deque[tuple[int, float, float, float]] = field(default_factory=lambda: deque(maxlen=TRUTH_HISTORY))
    odom_to_map: tuple[float, float, float] | None = None  # (dx, dy, dyaw) aligning odom with map
    pose: tuple[float, float, float] | None = None  # latest drawn pose in map
    mounts: dict[str, Mount] = field(default_factory=dict)  # sensor leaf → mount drawn
    heading_m: float = 0.0
    marks: dict[str, list[tuple[float, float]]] = field(default_factory=dict)
    last_mark: dict[str, tuple[int, float, float]] = field(default_factory=dict)
    number: int | None = None  # its obstacle number, if its world gives one
    powered: bool | None = None  # None: the world does not say
    crashed: bool = False
    label: str = ""  # as last logged


@dataclass
class Series:
    """A plotted quantity: kept until flushed when converting a bag."""

    tab: str
    name: str
    color: tuple[int, int, int]
    robot: str
    shade: int | None = None  # None: ``color``; 0: the robot's world colour, 1: darker
    times: list[int] = field(default_factory=list)
    values: list[float] = field(default_factory=list)
