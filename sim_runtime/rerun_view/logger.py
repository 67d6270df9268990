"""Draw ROS messages as Rerun archetypes: one mapping shared by ``bag_to_rerun`` and the live view.

Rerun's own MCAP import draws no LaserScan, Odometry or Marker, so :class:`RerunLogger` turns each
message of the worlds' topics (design.md §4–6) into archetypes on the ``sim_time`` timeline:

=====================================  ==========================================================
entity                                 what
=====================================  ==========================================================
``world``                              map frame (z up)
``world/map_markers/<ns>/<id>``        each Marker of the Create's ``map_markers``, static
``world/markers/<topic>/<ns>/<id>``    each Marker of other MarkerArrays (``/robots``,
                                       ``robot_markers``…) in its header frame; meshes are logged
                                       once (static Asset3D), later only their transforms
``world/map``                          OccupancyGrid: the obstacle cells bordering free space
``world/robots/<robot>``               ground-truth pose (``overhead_pose``, ``pose``; ``odom`` if
                                       there is none) as a transform; ``body`` = outline + heading
``world/robots/<robot>/<sensor>``      sensor frames: ``scan`` points and rays, sonar rays to the
                                       hit, binary detectors (bump, wall, cliff) lit when active
``world/tracks/<robot>/{truth,odom}``  tracks (line strips in segments, so a long run stays cheap)
``plots/…``                            scalars: odometry error, sonar, cliff, joints, commands
``events/<robot>``                     text log of bump/cliff/wall/virtual-wall/crash events
=====================================  ==========================================================

Robots are named by their namespace (``robot`` for the root namespace); sensor frames
``<ns>/<sensor>`` belong to robot ``<ns>``. The worlds publish no tf, so the Create's sensor mounts
come from :data:`CREATE_SENSOR_MOUNTS`; other sensor frames sit at the robot's centre.
"""

from __future__ import annotations

import math
import warnings
from collections import deque
from collections.abc import Iterable
from dataclasses import dataclass, field
from pathlib import Path
from urllib.parse import unquote, urlparse

import numpy as np
import rerun as rr
import rerun.blueprint as rrb

from sim_runtime.angles import wrap_angle
from sim_runtime.msgs import quaternion_from_yaw, yaw_from_quaternion

TIMELINE = "sim_time"
CREATE_RADIUS = 0.16
DEFAULT_HEADING_LENGTH = 0.2
TRUTH_HISTORY = 64
"""Ground-truth poses kept to pair with odometry of the same instant (and odometry kept waiting)."""
TRACK_MIN_STEP = 0.005
"""A track gets a new point once the robot moved this far (m): no 50 Hz duplicates when parked."""
TRACK_SEGMENT_POINTS = 256
"""Tracks are logged as growing strips of at most this many points, then a new strip starts, so a
long run costs O(n) instead of re-logging the whole track every pose."""
CLIFF_THRESHOLD = 5.4
"""Cliff signal (percent) at or below which the seed's GUI marks a cliff/line."""
EPOCH_NS = 10**17
"""Times above this (1973) are wall-clock epochs, below it sim time since the world started."""

_deg = math.radians


def _edge(angle_deg: float, yaw_deg: float | None = None) -> tuple[float, float, float]:
    a = _deg(angle_deg)
    return (CREATE_RADIUS * math.cos(a), CREATE_RADIUS * math.sin(a), _deg(angle_deg if yaw_deg is None else yaw_deg))


CREATE_SENSOR_MOUNTS: dict[str, tuple[float, float, float]] = {
    "laser": (CREATE_RADIUS, 0.0, 0.0),
    "camera": (0.13, 0.0, 0.0),
    "sonar_front": _edge(0),
    "sonar_left": _edge(90),
    "sonar_back": _edge(180),
    "sonar_right": _edge(-90),
    "wall_ir": _edge(-40.5, -90.0),
    "virtual_wall_ir": _edge(0),
    "bump_left": _edge(45),
    "bump_right": _edge(-45),
    "cliff_left": _edge(60),
    "cliff_front_left": _edge(18),
    "cliff_front_right": _edge(-18),
    "cliff_right": _edge(-60),
}
"""Create sensor frame → mount (x, y, yaw) on ``base_link``, from seed-facts/create.md (the Create
world publishes no tf); sonar ranges are measured from the body's edge, so sonar frames sit there."""

TRUTH_POSE_TOPICS = ("overhead_pose", "pose")
STATIC_MARKER_TOPICS = ("map_markers", "scene_markers")
ROBOT_COLORS = [
    (31, 119, 180),
    (214, 39, 40),
    (44, 160, 44),
    (148, 103, 189),
    (255, 127, 14),
    (23, 190, 207),
    (227, 119, 194),
    (140, 86, 75),
]
EVENT_COLOR = (230, 30, 30)

# visualization_msgs/Marker type and action constants (avoid importing the message at module load)
ARROW, CUBE, SPHERE, CYLINDER, LINE_STRIP, LINE_LIST, CUBE_LIST, SPHERE_LIST, POINTS, TEXT, MESH, TRIANGLES = (
    0,
    1,
    2,
    3,
    4,
    5,
    6,
    7,
    8,
    9,
    10,
    11,
)
DELETE, DELETEALL = 2, 3


def type_name(msg: object) -> str:
    """``pkg/msg/Type`` of an rclpy message instance or class."""
    cls = msg if isinstance(msg, type) else type(msg)
    return f"{cls.__module__.split('.')[0]}/msg/{cls.__name__}"


def stamp_ns(stamp) -> int:
    """A builtin_interfaces/Time as integer nanoseconds."""
    return int(stamp.sec) * 1_000_000_000 + int(stamp.nanosec)


def _namespace(topic: str) -> str:
    return topic.strip("/").rpartition("/")[0]


def _basename(topic: str) -> str:
    return topic.rstrip("/").rpartition("/")[2]


def _path_part(name: str) -> str:
    return rr.escape_entity_path_part(name) if name else "_"


def _topic_path(topic: str) -> str:
    return "/".join(_path_part(p) for p in topic.strip("/").split("/"))


def _rgba(c) -> tuple[int, int, int, int]:
    return tuple(int(round(255 * min(max(v, 0.0), 1.0))) for v in (c.r, c.g, c.b, c.a))  # type: ignore[return-value]


def _pose_transform(pose) -> rr.Transform3D:
    p, q = pose.position, pose.orientation
    quat = [q.x, q.y, q.z, q.w] if (q.x, q.y, q.z, q.w) != (0.0, 0.0, 0.0, 0.0) else [0.0, 0.0, 0.0, 1.0]
    return rr.Transform3D(translation=[p.x, p.y, p.z], quaternion=rr.Quaternion(xyzw=quat))


def _yaw_transform(x: float, y: float, yaw: float) -> rr.Transform3D:
    q = quaternion_from_yaw(yaw)
    return rr.Transform3D(translation=[x, y, 0.0], quaternion=rr.Quaternion(xyzw=[q.x, q.y, q.z, q.w]))


def _points(points) -> np.ndarray:
    return np.array([(p.x, p.y, p.z) for p in points], dtype=np.float32).reshape(-1, 3)


def robots_in_topics(topics: Iterable[str]) -> list[str]:
    """Robot names (namespaces, ``robot`` for the root) that have a pose or odometry topic."""
    names = {_namespace(t) or "robot" for t in topics if _basename(t) in (*TRUTH_POSE_TOPICS, "odom")}
    return sorted(names)


PLOT_ORDER = ("odom_error", "joint_states/position", "range", "cliff", "cmd_vel", "joint_states")


def _plot_order(group: str) -> tuple[int, str]:
    # The plots a user looks at first come first; battery and buttons last.
    rank = next(
        (i for i, key in enumerate(PLOT_ORDER) if f"/{key}" in f"/{group.removeprefix('plots/')}"), len(PLOT_ORDER)
    )
    return rank, group


def robot_color(name: str, names: list[str]) -> tuple[int, int, int]:
    """A robot's colour (rgb 0–255): by its place in the sorted robot names, so views agree."""
    index = names.index(name) if name in names else len(names)
    return ROBOT_COLORS[index % len(ROBOT_COLORS)]


@dataclass
class _Track:
    """A growing track, logged in segments of at most TRACK_SEGMENT_POINTS points."""

    entity: str
    color: tuple[int, int, int]
    radius: float
    points: list[tuple[float, float]] = field(default_factory=list)
    segment: int = 0

    def add(self, rec: rr.RecordingStream, x: float, y: float) -> None:
        if self.points and math.hypot(x - self.points[-1][0], y - self.points[-1][1]) < TRACK_MIN_STEP:
            return
        if len(self.points) >= TRACK_SEGMENT_POINTS:
            self.points = self.points[-1:]  # the next segment starts where this one ended
            self.segment += 1
        self.points.append((x, y))
        strip = np.zeros((len(self.points), 3), dtype=np.float32)
        strip[:, :2] = self.points
        rec.log(f"{self.entity}/{self.segment}", rr.LineStrips3D([strip], radii=self.radius, colors=[self.color]))


@dataclass
class _Robot:
    name: str
    color: tuple[int, int, int]
    is_create: bool
    truth: _Track
    odom: _Track
    expects_truth: bool = False  # the robot has a ground-truth pose topic
    # recent ground-truth poses and odometry waiting for the truth of its instant: (t_ns, x, y, yaw)
    truths: deque[tuple[int, float, float, float]] = field(default_factory=lambda: deque(maxlen=TRUTH_HISTORY))
    pending_odom: deque[tuple[int, float, float, float]] = field(default_factory=lambda: deque(maxlen=TRUTH_HISTORY))
    odom_to_map: tuple[float, float, float] | None = None  # (dx, dy, dyaw) aligning odom with map
    mounted: set[str] = field(default_factory=set)


class RerunLogger:
    """Logs ROS messages (topic, message, time) to a Rerun recording as archetypes.

    With ``batch_scalars`` (bag conversion) plotted values are sent by :meth:`flush`.

    ``topics`` (name → ``pkg/msg/Type``) tells which robots exist and which are Creates (a robot with
    an ``overhead_pose`` topic); more can be added later with :meth:`add_topics`.
    """

    def __init__(
        self, recording: rr.RecordingStream, topics: dict[str, str] | None = None, *, batch_scalars: bool = False
    ) -> None:
        self.rec = recording
        self._t_ns = 0
        # Converting a bag, scalars are kept and sent as columns by flush(): a log call per sample
        # costs ~0.5 ms, a column of thousands about the same. Live, they are logged at once.
        self._scalar_columns: dict[str, tuple[list[int], list[float]]] | None = {} if batch_scalars else None
        self.topics: dict[str, str] = {}
        self._topic_robots: list[str] = []  # sorted robot names of self.topics
        self._topic_names: set[str] = set()  # self.topics without leading slashes
        self._robots: dict[str, _Robot] = {}
        self._create_namespaces: set[str] = set()
        self._marker_entities: dict[str, set[str]] = {}
        self._static_meshes: dict[str, str] = {}
        self._binary_state: dict[str, bool] = {}
        self._epoch: bool | None = None
        #: origins of the time-series views; layout_version grows when a view or robot is added
        self.plot_groups: set[str] = set()
        self._map_lo = np.full(2, np.inf)
        self._map_hi = np.full(2, -np.inf)
        self.layout_version = 0
        self.rec.log("world", rr.ViewCoordinates.RIGHT_HAND_Z_UP, static=True)
        self.add_topics(topics or {})

    # ---------------------------------------------------------------- public API
    def add_topics(self, topics: dict[str, str]) -> None:
        """Register topics (name → type); robots with ``overhead_pose`` are drawn as Creates."""
        self.topics.update(topics)
        self._topic_robots = robots_in_topics(self.topics)
        self._topic_names = {t.strip("/") for t in self.topics}
        for topic in topics:
            if _basename(topic) == "overhead_pose":
                self._create_namespaces.add(_namespace(topic))

    def log(self, topic: str, msg: object, time_ns: int | None = None) -> bool:
        """Draw one message received on ``topic`` at ``time_ns`` (header stamp wins if set).

        Returns False (and draws nothing) if the message type is not supported.
        """
        kind = type_name(msg)
        handler = HANDLERS.get(kind)
        if handler is None:
            return kind == "rosgraph_msgs/msg/Clock"
        header = getattr(msg, "header", None)
        t = stamp_ns(header.stamp) if header is not None else 0
        if t == 0 and time_ns is not None:
            t = time_ns
        self._set_time(t)
        getattr(self, handler)(topic, msg)
        return True

    def blueprint(self) -> rrb.Blueprint:
        """Global 3D view (top-down), one robot-centred tab per robot, a plot per group, event log.

        The time cursor follows the newest data: the end of a converted bag, "now" in a live view.
        """
        robots = sorted(set(self._topic_robots) | set(self._robots))
        background = rrb.Background(kind="SolidColor", color=[255, 255, 255])
        tabs = [
            rrb.Spatial3DView(origin="/world", name="Global", background=background, eye_controls=self._top_down_eye())
        ]
        tabs += [
            rrb.Spatial3DView(
                origin=f"/world/robots/{r}", contents="/world/**", name=f"{r} (robot-centred)", background=background
            )
            for r in robots
        ]
        plots = [
            rrb.TimeSeriesView(origin=f"/{g}", name=g.removeprefix("plots/"))
            for g in sorted(self.plot_groups, key=_plot_order)
        ]
        events = rrb.TextLogView(origin="/events", name="Events")
        side = rrb.Vertical(rrb.Tabs(*plots, name="Plots"), events, row_shares=[2, 1]) if plots else events
        return rrb.Blueprint(
            rrb.Horizontal(rrb.Tabs(*tabs, active_tab=0), side, column_shares=[3, 2]),
            rrb.TimePanel(timeline=TIMELINE, play_state="following", state="collapsed"),
            collapse_panels=True,
        )

    def _top_down_eye(self) -> rrb.EyeControls3D | None:
        """Look straight down on the map from high enough to see it all; None (the viewer frames
        the scene itself, in perspective) when there is no map, e.g. for arms."""
        if not np.all(np.isfinite(self._map_lo)):
            return None
        centre, extent = (self._map_lo + self._map_hi) / 2, float(np.max(self._map_hi - self._map_lo))
        height = 1.1 * max(extent, 1.0)
        # Slightly south of the target, so +y is up on screen; the viewer flips a near-vertical
        # eye (offset 1 % of the height showed the map upside down, 5 % is right).
        return rrb.EyeControls3D(
            kind="Orbital",
            position=[centre[0], centre[1] - 0.05 * height, height],
            look_target=[centre[0], centre[1], 0.0],
            eye_up=[0.0, 0.0, 1.0],
        )

    def _grow_map(self, xy: np.ndarray) -> None:
        if len(xy):
            self._map_lo = np.minimum(self._map_lo, xy.min(axis=0))
            self._map_hi = np.maximum(self._map_hi, xy.max(axis=0))

    # ---------------------------------------------------------------- time
    def _set_time(self, t_ns: int) -> None:
        self._t_ns = t_ns
        if self._epoch is None:
            self._epoch = t_ns > EPOCH_NS
        if self._epoch:
            self.rec.set_time(TIMELINE, timestamp=np.datetime64(t_ns, "ns"))
        else:
            self.rec.set_time(TIMELINE, duration=np.timedelta64(t_ns, "ns"))

    # ---------------------------------------------------------------- robots and frames
    def _robot(self, name: str) -> _Robot:
        key = name or "robot"
        robot = self._robots.get(key)
        if robot is None:
            known = self._topic_robots
            color = robot_color(key, known) if key in known else ROBOT_COLORS[len(self._robots) % len(ROBOT_COLORS)]
            is_create = name in self._create_namespaces
            robot = _Robot(
                key,
                color,
                is_create,
                _Track(f"world/tracks/{key}/truth", color, 0.01),
                _Track(f"world/tracks/{key}/odom", tuple(c // 2 + 100 for c in color), 0.006),
                expects_truth=self._has_truth_topic(key),
            )
            self._robots[key] = robot
            self.layout_version += 1
            self._log_body(robot)
        return robot

    def _log_body(self, robot: _Robot) -> None:
        entity = f"world/robots/{robot.name}/body"
        if robot.is_create:
            a = np.linspace(0.0, 2 * math.pi, 49)
            circle = np.column_stack([CREATE_RADIUS * np.cos(a), CREATE_RADIUS * np.sin(a), np.zeros_like(a)])
            heading = np.array([[0.0, 0.0, 0.0], [CREATE_RADIUS, 0.0, 0.0]])
            self.rec.log(entity, rr.LineStrips3D([circle, heading], radii=0.008, colors=[robot.color]), static=True)
        else:  # the outline comes from the world's /robots markers; draw the heading
            heading = np.array([[0.0, 0.0, 0.0], [DEFAULT_HEADING_LENGTH, 0.0, 0.0]])
            self.rec.log(entity, rr.LineStrips3D([heading], radii=0.008, colors=[robot.color]), static=True)

    def _frame_entity(self, frame_id: str) -> str:
        """The entity of a frame: the map, a robot, or a sensor mounted on a robot."""
        frame = frame_id.strip("/")
        prefix, _, leaf = frame.rpartition("/")
        if frame in ("", "map", "world") or leaf == "odom":  # odometry frames start at the map origin
            return "world"
        key = prefix or "robot"
        known = key in self._robots or key in self._topic_robots
        if not known:
            return "world"
        robot = self._robot(prefix)
        if leaf == "base_link":
            return f"world/robots/{robot.name}"
        entity = f"world/robots/{robot.name}/{_path_part(leaf)}"
        if leaf not in robot.mounted:
            robot.mounted.add(leaf)
            mount = CREATE_SENSOR_MOUNTS.get(leaf) if robot.is_create else None
            self.rec.log(entity, _yaw_transform(*(mount or (0.0, 0.0, 0.0))), static=True)
        return entity

    def _scalar(self, group: str, name: str, value: float) -> None:
        """Plot ``value`` as series ``name`` of plot ``group`` (one time-series view per group)."""
        view = group if group != "plots" else f"plots/{name}"
        if view not in self.plot_groups:
            self.plot_groups.add(view)
            self.layout_version += 1
        entity = f"{group}/{name}"
        if self._scalar_columns is None:
            self.rec.log(entity, rr.Scalars(value))
            return
        times, values = self._scalar_columns.setdefault(entity, ([], []))
        times.append(self._t_ns)
        values.append(value)

    def flush(self) -> None:
        """Send the plotted values kept so far (``batch_scalars``); a no-op otherwise."""
        if not self._scalar_columns:
            return
        for entity, (times, values) in self._scalar_columns.items():
            if self._epoch:
                index = rr.TimeColumn(TIMELINE, timestamp=np.array(times, dtype="datetime64[ns]"))
            else:
                index = rr.TimeColumn(TIMELINE, duration=np.array(times, dtype="timedelta64[ns]"))
            self.rec.send_columns(entity, indexes=[index], columns=rr.Scalars.columns(scalars=values))
        self._scalar_columns.clear()

    def _event(self, robot: str, text: str) -> None:
        self.rec.log(f"events/{robot}", rr.TextLog(text, level=rr.TextLogLevel.WARN))

    # ---------------------------------------------------------------- poses
    def _pose_stamped(self, topic: str, msg) -> None:
        if _basename(topic) not in TRUTH_POSE_TOPICS:
            entity = f"world/poses/{_topic_path(topic)}"
            self.rec.log(entity, _pose_transform(msg.pose), rr.TransformAxes3D(0.1))
            return
        robot = self._robot(_namespace(topic))
        x, y, yaw = msg.pose.position.x, msg.pose.position.y, yaw_from_quaternion(msg.pose.orientation)
        robot.expects_truth = True
        robot.truths.append((self._t_ns, x, y, yaw))
        self.rec.log(f"world/robots/{robot.name}", _yaw_transform(x, y, yaw))
        robot.truth.add(self.rec, x, y)
        self._compare_odometry(robot)

    def _odometry(self, topic: str, msg) -> None:
        child = msg.child_frame_id.strip("/")
        robot = self._robot(child.rpartition("/")[0] if child else _namespace(topic))
        p = msg.pose.pose
        robot.pending_odom.append((self._t_ns, p.position.x, p.position.y, yaw_from_quaternion(p.orientation)))
        self._compare_odometry(robot)

    def _has_truth_topic(self, robot: str) -> bool:
        ns = "" if robot == "robot" else robot
        return any(f"{ns}/{name}".strip("/") in self._topic_names for name in TRUTH_POSE_TOPICS)

    def _compare_odometry(self, robot: _Robot) -> None:
        """Draw odometry in the map frame, next to the ground truth of the same instant.

        The odom frame starts wherever the world put it, so it is aligned with the truth at the
        first odometry message; each odometry pose waits until the truth of its instant (which may
        be logged just after it) is known, then is compared with it.
        """
        if robot.expects_truth and not robot.truths:
            return
        now = self._t_ns
        while robot.pending_odom:
            t, ox, oy, oyaw = robot.pending_odom[0]
            truth = None
            if robot.expects_truth:
                if robot.truths[-1][0] < t:
                    break  # the truth of this instant has not arrived yet
                truth = min(robot.truths, key=lambda tr: abs(tr[0] - t))[1:]
            robot.pending_odom.popleft()
            if robot.odom_to_map is None:
                if truth is None:
                    robot.odom_to_map = (0.0, 0.0, 0.0)
                else:
                    dyaw = truth[2] - oyaw
                    c, s = math.cos(dyaw), math.sin(dyaw)
                    robot.odom_to_map = (truth[0] - (c * ox - s * oy), truth[1] - (s * ox + c * oy), dyaw)
            dx, dy, dyaw = robot.odom_to_map
            c, s = math.cos(dyaw), math.sin(dyaw)
            x, y, yaw = dx + c * ox - s * oy, dy + s * ox + c * oy, oyaw + dyaw
            self._set_time(t)
            robot.odom.add(self.rec, x, y)
            if truth is None:  # odometry is all we know of this robot's pose
                self.rec.log(f"world/robots/{robot.name}", _yaw_transform(x, y, yaw))
            else:
                group = f"plots/{robot.name}/odom_error"
                self._scalar(group, "position_m", math.hypot(x - truth[0], y - truth[1]))
                self._scalar(group, "heading_rad", wrap_angle(yaw - truth[2]))
        self._set_time(now)

    # ---------------------------------------------------------------- sensors
    def _laser_scan(self, topic: str, msg) -> None:
        entity = self._frame_entity(msg.header.frame_id)
        ranges = np.asarray(msg.ranges, dtype=np.float64)
        angles = msg.angle_min + msg.angle_increment * np.arange(ranges.size)
        hit = np.isfinite(ranges) & (ranges > 0.0)
        r, a = ranges[hit], angles[hit]
        pts = np.column_stack([r * np.cos(a), r * np.sin(a), np.zeros_like(r)]).astype(np.float32)
        colors = [(230, 40, 40)]
        if len(msg.intensities) == ranges.size:
            # SIMROBOT: intensity = obstacle number, 1 wall, 2–255 a robot (drawn blue)
            obstacle = np.asarray(msg.intensities)[hit]
            colors = np.where((obstacle > 1)[:, None], [40, 40, 230], [230, 40, 40]).astype(np.uint8)
        name = _path_part(_basename(topic))
        self.rec.log(f"{entity}/{name}", rr.Points3D(pts, radii=0.012, colors=colors))
        # The seed's GUI draws five beams across the field of view: rays for those.
        idx = np.linspace(0, ranges.size - 1, 5).round().astype(int) if ranges.size else np.zeros(0, int)
        reach = np.where(np.isfinite(ranges[idx]) & (ranges[idx] > 0), ranges[idx], msg.range_max)
        rays = [
            np.array([[0.0, 0.0, 0.0], [d * math.cos(t), d * math.sin(t), 0.0]])
            for d, t in zip(reach, angles[idx], strict=True)
        ]
        self.rec.log(f"{entity}/{name}_rays", rr.LineStrips3D(rays, radii=0.004, colors=[(230, 120, 120)]))

    def _range(self, topic: str, msg) -> None:
        entity = self._frame_entity(msg.header.frame_id)
        robot = entity.split("/")[2] if entity.startswith("world/robots/") else "world"
        name = _basename(msg.header.frame_id) or _basename(topic)
        if msg.min_range == msg.max_range:  # REP-117 fixed-distance detector: -inf = detection
            self._binary(topic, f"{entity}/detection", robot, name, msg.range == -math.inf)
            return
        r = msg.range
        if math.isfinite(r):
            self.rec.log(
                f"{entity}/ray", rr.LineStrips3D([[[0, 0, 0], [r, 0, 0]]], radii=0.006, colors=[(255, 140, 0)])
            )
            self._scalar(f"plots/{robot}/range", _path_part(name), r)
        else:  # +inf: no echo within max_range (drawn faint to max_range); -inf: too close
            reach = msg.max_range if r > 0 else msg.min_range
            self.rec.log(
                f"{entity}/ray",
                rr.LineStrips3D([[[0, 0, 0], [reach, 0, 0]]], radii=0.003, colors=[(200, 200, 200, 120)]),
            )

    def _binary(self, topic: str, entity: str, robot: str, name: str, active: bool) -> None:
        if self._binary_state.get(topic) == active:
            return  # drawn on change only: detectors publish at 50 Hz and are mostly idle
        self._binary_state[topic] = active
        if active:
            self.rec.log(entity, rr.Points3D([[0.0, 0.0, 0.05]], radii=0.03, colors=[EVENT_COLOR]))
            self._event(robot, f"{name} on ({topic})")
        else:
            self.rec.log(entity, rr.Clear(recursive=False))

    def _illuminance(self, topic: str, msg) -> None:
        entity = self._frame_entity(msg.header.frame_id)
        robot = entity.split("/")[2] if entity.startswith("world/robots/") else "world"
        name = _basename(msg.header.frame_id) or _basename(topic)
        self._scalar(f"plots/{robot}/cliff", _path_part(name), msg.illuminance)
        self._binary(topic, f"{entity}/detection", robot, name, msg.illuminance <= CLIFF_THRESHOLD)

    def _bool(self, topic: str, msg) -> None:
        robot = _namespace(topic) or "robot"
        entity = (
            f"world/robots/{robot}/{_path_part(_basename(topic))}"
            if robot in self._robots
            else f"world/flags/{_topic_path(topic)}"
        )
        self._binary(topic, entity, robot, _basename(topic), bool(msg.data))

    def _scalar_data(self, topic: str, msg) -> None:
        self._scalar("plots", _topic_path(topic), float(msg.data))

    def _battery(self, topic: str, msg) -> None:
        base = f"plots/{_topic_path(topic)}"
        self._scalar(base, "voltage", msg.voltage)
        self._scalar(base, "percentage", msg.percentage)

    def _joy(self, topic: str, msg) -> None:
        base = f"plots/{_topic_path(topic)}"
        for i, value in enumerate(msg.buttons):
            self._scalar(base, f"button{i}", float(value))
        for i, value in enumerate(msg.axes):
            self._scalar(base, f"axis{i}", float(value))

    def _twist_stamped(self, topic: str, msg) -> None:
        self._twist(topic, msg.twist)

    def _twist(self, topic: str, twist) -> None:
        base = f"plots/{_topic_path(topic)}"
        self._scalar(base, "linear_x", twist.linear.x)
        self._scalar(base, "angular_z", twist.angular.z)

    def _joint_state(self, topic: str, msg) -> None:
        base = f"plots/{_topic_path(topic)}"
        names = list(msg.name) or [f"joint{i + 1}" for i in range(len(msg.position))]
        for field_name in ("position", "velocity", "effort"):
            values = getattr(msg, field_name)
            for joint, value in zip(names, values, strict=False):  # velocity/effort may be empty
                self._scalar(f"{base}/{field_name}", _path_part(joint), float(value))

    # ---------------------------------------------------------------- maps
    def _occupancy_grid(self, topic: str, msg) -> None:
        info = msg.info
        w, h = info.width, info.height
        if w * h == 0 or len(msg.data) != w * h:
            warnings.warn(f"{topic}: OccupancyGrid {w}x{h} with {len(msg.data)} cells; not drawn", stacklevel=2)
            return
        grid = np.asarray(msg.data, dtype=np.int8).reshape(h, w) >= 50
        # Only obstacle cells with a free 4-neighbour: a map's outline, not every cell of a thick wall.
        padded = np.pad(grid, 1, constant_values=False)
        interior = padded[:-2, 1:-1] & padded[2:, 1:-1] & padded[1:-1, :-2] & padded[1:-1, 2:]
        rows, cols = np.nonzero(grid & ~interior)
        res = info.resolution
        o = info.origin.position
        self._grow_map(np.array([[o.x, o.y], [o.x + w * res, o.y + h * res]]))
        local = np.column_stack([(cols + 0.5) * res, (rows + 0.5) * res, np.zeros(rows.size)])
        entity = f"world/{_topic_path(topic)}"
        self.rec.log(entity, _pose_transform(info.origin), static=True)
        self.rec.log(
            f"{entity}/obstacles",
            rr.Points3D(local.astype(np.float32), radii=res * 0.6, colors=[(40, 40, 40)]),
            static=True,
        )
        corners = np.array([[0, 0, 0], [w * res, 0, 0], [w * res, h * res, 0], [0, h * res, 0], [0, 0, 0]])
        self.rec.log(f"{entity}/bounds", rr.LineStrips3D([corners], radii=res, colors=[(150, 150, 150)]), static=True)

    # ---------------------------------------------------------------- markers
    def _marker_array(self, topic: str, msg) -> None:
        self._markers(topic, msg.markers)

    def _single_marker(self, topic: str, msg) -> None:
        self._markers(topic, [msg])

    def _markers(self, topic: str, markers) -> None:
        # Latched maps and scenes are static: visible at every time, even before they were published.
        static = _basename(topic) in STATIC_MARKER_TOPICS
        label = "map_markers" if _basename(topic) == "map_markers" else f"markers/{_topic_path(topic)}"
        seen: set[str] = set()
        for m in markers:
            if m.action == DELETEALL:
                for entity in self._marker_entities.pop(topic, set()):
                    self.rec.log(entity, rr.Clear(recursive=True))
                continue
            base = self._frame_entity(m.header.frame_id)
            entity = f"{base}/{label}/{_path_part(m.ns)}/{m.id}"
            if m.action == DELETE:
                self.rec.log(entity, rr.Clear(recursive=True))
                continue
            seen.add(entity)
            self._marker(entity, m, static)
        if not static:
            # Each message is the topic's full set (camera sightings come and go): clear the missing.
            for entity in self._marker_entities.get(topic, set()) - seen:
                self.rec.log(entity, rr.Clear(recursive=True))
            self._marker_entities[topic] = seen

    def _marker(self, entity: str, m, static: bool) -> None:
        color = _rgba(m.color)
        pts = _points(m.points)
        colors = [_rgba(c) for c in m.colors] if len(m.colors) == len(m.points) and m.colors else [color]
        width = max(m.scale.x, 1e-3)
        if m.type == MESH:
            self._mesh(entity, m, color)
            return
        transform = _pose_transform(m.pose)
        if static and entity.startswith("world/map_markers/"):
            p = m.pose.position
            self._grow_map(pts[:, :2] + [p.x, p.y] if len(pts) else np.array([[p.x, p.y]]))
        if m.type in (SPHERE, TEXT):
            label = [m.text] if m.text else None
            radius = m.scale.x / 2 if m.type == SPHERE else 0.01
            shape = rr.Points3D([[0.0, 0.0, 0.0]], radii=radius, colors=[color], labels=label, show_labels=bool(label))
        elif m.type == LINE_STRIP:
            shape = rr.LineStrips3D([pts], radii=width / 2, colors=[color])
        elif m.type == LINE_LIST:
            shape = rr.LineStrips3D(pts[: len(pts) // 2 * 2].reshape(-1, 2, 3), radii=width / 2, colors=[color])
        elif m.type in (POINTS, SPHERE_LIST, CUBE_LIST):
            shape = rr.Points3D(pts, radii=width / 2, colors=colors)
        elif m.type == CUBE:
            shape = rr.Boxes3D(
                half_sizes=[[m.scale.x / 2, m.scale.y / 2, m.scale.z / 2]], colors=[color], fill_mode="solid"
            )
        elif m.type == CYLINDER:
            shape = rr.Cylinders3D(lengths=[m.scale.z], radii=[m.scale.x / 2], colors=[color], fill_mode="solid")
        elif m.type == ARROW:
            if len(pts) >= 2:
                shape = rr.Arrows3D(origins=pts[:1], vectors=pts[1:2] - pts[:1], radii=m.scale.x / 2, colors=[color])
            else:
                shape = rr.Arrows3D(
                    origins=[[0, 0, 0]], vectors=[[m.scale.x, 0, 0]], radii=m.scale.y / 2, colors=[color]
                )
        elif m.type == TRIANGLES:
            shape = rr.Mesh3D(
                vertex_positions=pts, vertex_colors=colors if len(colors) == len(pts) else None, albedo_factor=color
            )
        else:
            return
        self.rec.log(entity, transform, shape, static=static)

    def _mesh(self, entity: str, m, color) -> None:
        uri = m.mesh_resource
        if self._static_meshes.get(entity) != uri:
            # The mesh is static: logged once per entity, later messages only move it.
            self._static_meshes[entity] = uri
            parsed = urlparse(uri)
            path = Path(unquote(parsed.path)) if parsed.scheme in ("file", "") else None
            if path is None or not path.is_file():
                warnings.warn(f"marker {entity}: mesh {uri!r} is not a local file; not drawn", stacklevel=2)
            else:
                albedo = None if m.mesh_use_embedded_materials else color
                self.rec.log(entity, rr.Asset3D(path=path, albedo_factor=albedo), static=True)
        p, q = m.pose.position, m.pose.orientation
        scale = [m.scale.x or 1.0, m.scale.y or 1.0, m.scale.z or 1.0]
        self.rec.log(
            entity,
            rr.Transform3D(
                translation=[p.x, p.y, p.z], quaternion=rr.Quaternion(xyzw=[q.x, q.y, q.z, q.w]), scale=scale
            ),
        )


HANDLERS: dict[str, str] = {
    "visualization_msgs/msg/MarkerArray": "_marker_array",
    "visualization_msgs/msg/Marker": "_single_marker",
    "nav_msgs/msg/OccupancyGrid": "_occupancy_grid",
    "nav_msgs/msg/Odometry": "_odometry",
    "geometry_msgs/msg/PoseStamped": "_pose_stamped",
    "sensor_msgs/msg/LaserScan": "_laser_scan",
    "sensor_msgs/msg/Range": "_range",
    "sensor_msgs/msg/Illuminance": "_illuminance",
    "sensor_msgs/msg/JointState": "_joint_state",
    "sensor_msgs/msg/BatteryState": "_battery",
    "sensor_msgs/msg/Joy": "_joy",
    "geometry_msgs/msg/Twist": "_twist",
    "geometry_msgs/msg/TwistStamped": "_twist_stamped",
    "std_msgs/msg/Bool": "_bool",
    "std_msgs/msg/UInt8": "_scalar_data",
    "std_msgs/msg/Float64": "_scalar_data",
    "std_msgs/msg/Float32": "_scalar_data",
}
"""Message type → RerunLogger method drawing it."""

SUPPORTED_TYPES = frozenset(HANDLERS) | {"rosgraph_msgs/msg/Clock"}
"""Message types :class:`RerunLogger` draws (``Clock`` is accepted and only drives time)."""
