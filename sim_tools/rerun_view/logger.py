"""Draw ROS messages as Rerun archetypes: one mapping shared by ``bag_to_rerun`` and the live view.

Rerun's own MCAP import draws no LaserScan, Odometry or Marker, so :class:`RerunLogger` turns each
message of the worlds' topics into archetypes on the ``sim_time`` timeline. Mobile robots live on a
flat map and are drawn in 2-D (a true top-down view, +y up); arms are drawn in 3-D:

======================================  =========================================================
entity                                  what
======================================  =========================================================
``top``                                 origin of the top-down views
``top/map``                             the ``map`` frame, mirrored in y so +y points up on screen
``top/map/grid``                        a line every metre, labelled at the edges
``top/map/occupancy``                   an OccupancyGrid as a grey image (walls dark)
``top/map/map_markers/<ns>/<id>``       the Create's map (walls, painted lines, beacons, virtual
                                        walls), static
``top/map/markers/<topic>/<ns>/<id>``   other MarkerArrays in 2-D (``/robots`` outlines…)
``top/map/robots/<robot>``              ground-truth pose (``overhead_pose``, ``pose``; ``odom``
                                        if there is none); ``body``: outline or dot, heading arrow
``top/map/robots/<robot>/follow``       a frame at the robot, north up: origin of its own view;
                                        ``label``: name, obstacle number, power and crash state
``top/map/robots/<robot>/<sensor>``     sensor frames at their mount (TF, else the known mounts):
                                        scan points, sonar beam cone and hit, lit detectors
``top/map/tracks/<robot>/{truth,odom}``  tracks in the robot's colour (strips of segments)
``top/map/marks/<robot>/{contacts,crashes}``  crosses where a bumper was pressed or the robot
                                        crashed, unlabelled (Events has the times), kept
``world``                               3-D frame of arms: meshes, axes, target pose,
                                        ``paths/<topic>`` end-effector path
``plots/<tab>/<robot>/<series>``        scalars, one time-series tab per quantity
``events/<robot>``                      text log: contacts (INFO), crashes (WARN), power switched
                                        (INFO), detectors (DEBUG), each on and off
``legend``                              a text panel saying what each colour and mark means
======================================  =========================================================

Robots are named by their namespace (``robot`` for the root namespace); sensor frames
``<ns>/<sensor>`` belong to robot ``<ns>``. A sensor's mount comes from the bag's ``/tf_static``
(``<ns>/base_link`` → sensor) when it has one, else from :data:`create_sim.spec.SENSOR_MOUNTS`
for a Create, else the robot's centre.
"""

from __future__ import annotations

import math
import warnings
from collections import deque
from collections.abc import Iterable
from dataclasses import dataclass, field
from typing import NamedTuple

import numpy as np
import rerun as rr
import rerun.blueprint as rrb

from create_sim import spec as create_mounts
from sim_runtime.angles import wrap_angle
from sim_runtime.msgs import quaternion_from_yaw, yaw_from_quaternion
from sim_runtime.paths import mesh_path
from sim_tools.rerun_view import legend as legend_text
from sim_tools.rerun_view import shapes
from sim_tools.rerun_view.tf import TF_MESSAGE_TYPE, FrameTree, Mount

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
CLIFF_THRESHOLD = 5.4
"""Cliff signal (percent) at or below which the original's GUI marks a cliff/line."""
EPOCH_NS = 10**17
"""Times above this (1973) are wall-clock epochs, below it sim time since the world started."""
CONSTANT_SPAN = 1e-9
"""A converted series whose values stay within this span is not plotted (rounding noise such as
an odometry error of 1e-16 m, or a button never pressed): it would be drawn as large zigzags."""
FOLLOW_HALF_WIDTH_M = {"create": 2.2, "simrobot": 0.6}
"""Half the width of a robot-centred view: the Create's LIDAR reaches 4 m, SIMROBOT's sonars 0.3 m."""
SIMROBOT_HEADING_M = 0.1
SIMROBOT_FIRST_NUMBER = 2
"""SIMROBOT's ``/robots`` marker i outlines robot i, whose obstacle number is i + 2 (1 is a wall)."""
LABEL_OFFSET_M = {"create": 0.2, "simrobot": 0.07}
"""A robot's label hangs from this far below its centre (on screen), clear of its body."""
SIMROBOT_MATCH_M = 0.3
"""A ``/robots`` outline belongs to the robot whose pose is nearest its centre, within this."""
AXES_LENGTH_M = 0.15
MARK_MERGE_NS = 500_000_000
MARK_MERGE_M = 0.3
"""Contacts this close in time and place make one mark (a frontal hit presses both bumpers)."""
KEEP_CONSTANT_TABS = frozenset({"commands"})
"""Plot tabs whose never-changing series are still plotted: a command is what a controller sent
(alg2's right wheel is always 0.5 rad/s)."""

TRUTH_POSE_TOPICS = ("overhead_pose", "pose")
STATIC_MARKER_TOPICS = ("map_markers", "scene_markers")
PATH_TOPICS = ("end_effector_pose",)
"""PoseStamped topics drawn with their path (the arm's flange)."""

# Colours (rgb 0-255). Robots without a colour of their own (the Create) take ROBOT_COLORS in turn;
# none of them is the walls' black, the painted lines' blue, the virtual walls' green, the LIDAR's
# violet or the contacts' red.
ROBOT_COLORS = [(235, 125, 0), (0, 150, 136), (140, 86, 75), (227, 119, 194), (188, 189, 34), (127, 127, 127)]
HEADING_COLOR = (25, 25, 25)
LIDAR_COLOR = (140, 60, 220)
LIDAR_ROBOT_COLOR = (40, 110, 230)
"""LIDAR returns from another robot (SIMROBOT's obstacle number ≥ 2)."""
BEAM_COLOR = (120, 120, 120, 140)
HIT_COLOR = (0, 150, 150)
DETECTOR_COLOR = (255, 140, 0)
CONTACT_COLOR = (220, 0, 0)
CRASH_COLOR = (120, 0, 0)
GRID_COLOR = (215, 215, 215)
OCCUPIED = 60
OCCUPIED_UNDER_LINES = 175
"""Grey of an OccupancyGrid's occupied cells; lighter when the world also draws its walls as lines
(the Create: the cells a planner sees, under the exact walls)."""
GRID_LABEL_COLOR = (110, 110, 110)
FADED_MARKERS = {"virtual_wall_fields": 0.3, "virtual_wall_halos": 0.45}
"""Map marker namespaces drawn faint and clipped to the walls' extent: the virtual walls' fields
are large triangles that walls block."""
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

PLOT_TABS: dict[str, tuple[str, tuple[float, float] | None]] = {
    "odom_error": ("Odometry error (m, rad)", None),
    "range": ("Range (m)", None),
    "cliff": ("Cliff signal (%)", (0.0, 25.0)),
    "commands": ("Commands (m/s, rad/s)", None),
    "joint_position": ("Joint positions (rad)", None),
    "joint_velocity": ("Joint velocities (rad/s)", None),
    "joint_effort": ("Joint efforts (N·m)", None),
    "obstacle": ("Obstacle seen (number)", None),
    "battery": ("Battery (V, %)", None),
    "buttons": ("Buttons and axes", (-1.05, 1.05)),
    "other": ("Other", None),
}
"""Plot tab key → (title with units, y range or None for the data's)."""

# visualization_msgs/Marker type and action constants (avoid importing the message at module load)
ARROW, CUBE, SPHERE, CYLINDER, LINE_STRIP, LINE_LIST, CUBE_LIST, SPHERE_LIST, POINTS, TEXT, MESH, TRIANGLES = range(12)
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


def _follow_transform(yaw: float) -> rr.Transform3D:
    """Under a robot's pose: undo its rotation (north stays up) and mirror y like the map."""
    c, s = math.cos(-yaw), math.sin(-yaw)
    return rr.Transform3D(mat3x3=np.array([[c, -s, 0.0], [s, c, 0.0], [0.0, 0.0, 1.0]]) @ MIRROR_Y)


def _points(points) -> np.ndarray:
    return np.array([(p.x, p.y, p.z) for p in points], dtype=np.float32).reshape(-1, 3)


def robots_in_topics(topics: Iterable[str]) -> list[str]:
    """Robot names (namespaces, ``robot`` for the root) that have a pose or odometry topic."""
    names = {_namespace(t) or "robot" for t in topics if _basename(t) in (*TRUTH_POSE_TOPICS, "odom")}
    return sorted(names)


class Outline(NamedTuple):
    """A robot's outline drawn by its world (SIMROBOT's ``/robots``): where and in which colour."""

    centre: np.ndarray
    color: tuple[int, int, int]
    size_m: float
    number: int
    """The robot's obstacle number (what others' sensors report seeing it as)."""


def robot_outlines(markers) -> list[Outline]:
    """The outlines in a ``/robots`` MarkerArray: each marker's points are on its pose (the robot's)."""
    outlines = []
    for m in markers:
        pts = _points(m.points)[:, :2]
        if m.action != 0 or not len(pts):
            continue
        yaw = yaw_from_quaternion(m.pose.orientation)
        c, s = math.cos(yaw), math.sin(yaw)
        local = pts.mean(axis=0)
        centre = np.array(
            [m.pose.position.x + c * local[0] - s * local[1], m.pose.position.y + s * local[0] + c * local[1]]
        )
        size = float(np.max(np.linalg.norm(pts, axis=1)))
        outlines.append(Outline(centre, _rgba(m.color)[:3], size, m.id + SIMROBOT_FIRST_NUMBER))
    return outlines


def outline_at(outlines: list[Outline], x: float, y: float) -> Outline | None:
    """The outline whose centre is nearest (x, y), if within SIMROBOT_MATCH_M."""
    if not outlines:
        return None
    dist = [math.hypot(o.centre[0] - x, o.centre[1] - y) for o in outlines]
    best = int(np.argmin(dist))
    return outlines[best] if dist[best] <= SIMROBOT_MATCH_M else None


def robot_color(name: str, names: list[str]) -> tuple[int, int, int]:
    """The colour of a robot the world gives none (rgb 0–255): by its place in the sorted names."""
    index = names.index(name) if name in names else len(names)
    return ROBOT_COLORS[index % len(ROBOT_COLORS)]


@dataclass
class _Track:
    """A growing track, logged in segments of at most TRACK_SEGMENT_POINTS points; nothing is
    logged until the track has a colour (SIMROBOT robots get theirs from the world's outlines)."""

    entity: str
    color: tuple[int, int, int] | None
    width_ui: float
    dims: int = 2
    points: list[tuple[float, ...]] = field(default_factory=list)
    segment: int = 0

    def add(self, rec: rr.RecordingStream, *xyz: float) -> None:
        if self.points and math.dist(xyz, self.points[-1]) < TRACK_MIN_STEP:
            return
        if len(self.points) >= TRACK_SEGMENT_POINTS:
            self.points = self.points[-1:]  # the next segment starts where this one ended
            self.segment += 1
        self.points.append(xyz)
        self.log(rec)

    def log(self, rec: rr.RecordingStream) -> None:
        if self.color is None or not self.points:
            return
        strip = np.array(self.points, dtype=np.float32)
        kind = rr.LineStrips2D if self.dims == 2 else rr.LineStrips3D
        radius = rr.Radius.ui_points(self.width_ui)
        rec.log(f"{self.entity}/{self.segment}", kind([strip], radii=radius, colors=[self.color]))


@dataclass
class _Robot:
    name: str
    color: tuple[int, int, int] | None
    is_create: bool
    truth: _Track
    odom: _Track
    expects_truth: bool = False  # the robot has a ground-truth pose topic
    # recent ground-truth poses and odometry waiting for the truth of its instant: (t_ns, x, y, yaw)
    truths: deque[tuple[int, float, float, float]] = field(default_factory=lambda: deque(maxlen=TRUTH_HISTORY))
    pending_odom: deque[tuple[int, float, float, float]] = field(default_factory=lambda: deque(maxlen=TRUTH_HISTORY))
    odom_to_map: tuple[float, float, float] | None = None  # (dx, dy, dyaw) aligning odom with map
    pose: tuple[float, float, float] | None = None  # latest drawn pose in map
    mounts: dict[str, Mount] = field(default_factory=dict)  # sensor leaf → mount drawn
    heading_m: float = SIMROBOT_HEADING_M
    marks: dict[str, list[tuple[float, float]]] = field(default_factory=dict)
    last_mark: dict[str, tuple[int, float, float]] = field(default_factory=dict)
    number: int | None = None  # SIMROBOT's obstacle number
    powered: bool | None = None  # None: the world does not say
    crashed: bool = False
    label: str = ""  # as last logged


@dataclass
class _Series:
    tab: str
    name: str
    color: tuple[int, int, int]
    robot: str
    shade: int | None = None  # None: ``color``; 0: the robot's world colour, 1: darker
    times: list[int] = field(default_factory=list)
    values: list[float] = field(default_factory=list)


class RerunLogger:
    """Logs ROS messages (topic, message, time) to a Rerun recording as archetypes.

    With ``batch_scalars`` (bag conversion) plotted values are sent by :meth:`flush`, which leaves
    out series that never change.

    ``topics`` (name → ``pkg/msg/Type``) tells which robots exist and which are Creates (a robot with
    an ``overhead_pose`` topic); more can be added later with :meth:`add_topics`.
    """

    def __init__(
        self, recording: rr.RecordingStream, topics: dict[str, str] | None = None, *, batch_scalars: bool = False
    ) -> None:
        self.rec = recording
        self._t_ns = 0
        self._t_range: list[int] = []  # first and last time seen
        # Converting a bag, scalars are kept and sent as columns by flush(): a log call per sample
        # costs ~0.5 ms, a column of thousands about the same. Live, they are logged at once.
        self._batch = batch_scalars
        self._series: dict[str, _Series] = {}
        self._tab_ranges: dict[str, list[float]] = {}
        self.topics: dict[str, str] = {}
        self._topic_robots: list[str] = []  # sorted robot names of self.topics
        self._topic_names: set[str] = set()  # self.topics without leading slashes
        self._robots: dict[str, _Robot] = {}
        self._create_namespaces: set[str] = set()
        self._outlined = False  # the world draws its robots' outlines in colour (SIMROBOT's /robots)
        self._outlines: list[Outline] = []
        self._arena: tuple[np.ndarray, np.ndarray] | None = None  # the extent of the map's walls
        self._marker_entities: dict[str, set[str]] = {}
        self._static_meshes: dict[str, str] = {}
        self._binary_state: dict[str, bool] = {}
        self._epoch: bool | None = None
        self.frames = FrameTree()
        #: plot tabs in use; layout_version grows when a view, robot or the event log is added
        self.plot_tabs: set[str] = set()
        self.has_events = False
        self._map_lo = np.full(2, np.inf)
        self._map_hi = np.full(2, -np.inf)
        self._world_lo = np.full(3, np.inf)
        self._world_hi = np.full(3, -np.inf)
        self._planar_started = False
        self._paths: dict[str, _Track] = {}
        self.layout_version = 0
        self.rec.log(WORLD, rr.ViewCoordinates.RIGHT_HAND_Z_UP, static=True)
        self.add_topics(topics or {})

    # ---------------------------------------------------------------- public API
    @property
    def plot_groups(self) -> set[str]:
        """Entity paths of the plot tabs (``plots/<tab>``)."""
        return {f"plots/{tab}" for tab in self.plot_tabs}

    def add_topics(self, topics: dict[str, str]) -> None:
        """Register topics (name → type); robots with ``overhead_pose`` are drawn as Creates."""
        self.topics.update(topics)
        self._topic_robots = robots_in_topics(self.topics)
        self._topic_names = {t.strip("/") for t in self.topics}
        for topic in topics:
            if _basename(topic) == "overhead_pose":
                self._create_namespaces.add(_namespace(topic))
            if _basename(topic) == "robots":
                self._outlined = True

    @property
    def planar(self) -> bool:
        """True for worlds of mobile robots (drawn top-down), False for arms (3-D)."""
        return bool(self._topic_robots or self._robots)

    def log(self, topic: str, msg: object, time_ns: int | None = None, kind: str | None = None) -> bool:
        """Draw one message received on ``topic`` at ``time_ns`` (header stamp wins if set).

        ``kind`` (``pkg/msg/Type``) is needed only for messages that are not rclpy messages (a
        TFMessage decoded without tf2_msgs). Returns False (and draws nothing) if the message
        type is not supported.
        """
        kind = kind or type_name(msg)
        handler = HANDLERS.get(kind)
        if handler is None:
            return kind == "rosgraph_msgs/msg/Clock"
        header = getattr(msg, "header", None)
        t = stamp_ns(header.stamp) if header is not None else 0
        if t == 0 and time_ns is not None:
            t = time_ns
        self._set_time(t)
        self._start_planar()
        getattr(self, handler)(topic, msg)
        return True

    def blueprint(self) -> rrb.Blueprint:
        """The layout: maps (top-down, then one view following each robot) or the arm's 3-D view;
        plots in a few tabs; the event log; the legend (logged here: it lists what is known now).

        The time cursor follows the newest data: the end of a converted bag, "now" in a live view.
        """
        white = rrb.Background(kind="SolidColor", color=[255, 255, 255])
        robots = sorted(set(self._topic_robots) | set(self._robots))
        tabs: list[rrb.View]
        if self.planar:
            tabs = [
                rrb.Spatial2DView(
                    origin=f"/{TOP}", name="Map (top-down)", background=white, visual_bounds=self._map_bounds()
                )
            ]
            for r in robots:
                half = FOLLOW_HALF_WIDTH_M["create" if self._is_create(r) else "simrobot"]
                tabs.append(
                    rrb.Spatial2DView(
                        origin=f"/{MAP}/robots/{r}/follow",
                        contents=f"/{TOP}/**",
                        name=f"{r} (follows)",
                        background=white,
                        visual_bounds=rrb.VisualBounds2D(x_range=[-half, half], y_range=[-half, half]),
                    )
                )
        else:
            tabs = [rrb.Spatial3DView(origin=f"/{WORLD}", name="3-D", background=white, eye_controls=self._arm_eye())]
        plots = [self._plot_view(tab) for tab in PLOT_TABS if tab in self.plot_tabs]
        side: list[tuple[rrb.View | rrb.Container, int]] = []
        if plots:
            side.append((rrb.Tabs(*plots, name="Plots"), 4))
        if self.has_events:
            columns = rrb.TextLogColumns(
                timeline_columns=[rrb.encodings.TimelineColumn(TIMELINE, visible=False)],
                text_log_columns=[rrb.encodings.TextLogColumn("LogLevel"), rrb.encodings.TextLogColumn("Body")],
            )
            side.append((rrb.TextLogView(origin="/events", name="Events", columns=columns), 2))
        self.rec.log("legend", rr.TextDocument(self.legend(), media_type=rr.MediaType.MARKDOWN), static=True)
        side.append((rrb.TextDocumentView(origin="/legend", name="Legend"), 3))
        main: rrb.Container = rrb.Tabs(*tabs, active_tab=0)
        column = rrb.Vertical(*(v for v, _ in side), row_shares=[share for _, share in side])
        main = rrb.Horizontal(main, column, column_shares=[3, 2])
        return rrb.Blueprint(
            main,
            rrb.TimePanel(timeline=TIMELINE, play_state="following", state="collapsed"),
            collapse_panels=True,
        )

    def legend(self) -> str:
        """What each colour and mark of the views means, for what this world has (markdown)."""
        if not self.planar:
            return legend_text.ARM
        entries = []
        for name in sorted(set(self._topic_robots) | set(self._robots)):
            robot = self._robots.get(name)
            entries.append(legend_text.robot_entry(name, robot.color, robot.number) if robot else name)
        return legend_text.mobile(self.topics, entries)

    def _plot_view(self, tab: str) -> rrb.TimeSeriesView:
        title, y_range = PLOT_TABS[tab]
        if y_range is None and tab in self._tab_ranges:
            lo, hi = self._tab_ranges[tab]
            pad = 0.05 * max(hi - lo, 1e-6)
            y_range = (min(lo - pad, 0.0) if lo >= 0 else lo - pad, hi + pad)
        axis_x = None
        if len(self._t_range) == 2 and self._t_range[1] > self._t_range[0] and not self._epoch:
            lo_t, hi_t = self._t_range
            axis_x = rrb.TimeAxis(
                view_range=rrb.TimeRange(
                    start=rrb.TimeRangeBoundary.absolute(nanos=lo_t), end=rrb.TimeRangeBoundary.absolute(nanos=hi_t)
                )
            )
        return rrb.TimeSeriesView(
            origin=f"/plots/{tab}",
            name=title,
            axis_y=rrb.ScalarAxis(range=y_range) if y_range is not None else None,
            axis_x=axis_x,
            plot_legend=rrb.PlotLegend(corner="LeftTop", visible=True),
        )

    def _map_bounds(self) -> rrb.VisualBounds2D | None:
        """The map and everything drawn on it, with a margin; in view coordinates (y mirrored)."""
        if not np.all(np.isfinite(self._map_lo)):
            return None
        # room for the grid's labels left and below, and for a robot's label at the right wall
        lo, hi = self._map_lo - [0.7, 0.4], self._map_hi + np.array([0.4, 0.2])
        return rrb.VisualBounds2D(x_range=[lo[0], hi[0]], y_range=[-hi[1], -lo[1]])

    def _arm_eye(self) -> rrb.EyeControls3D | None:
        """Look at the arm's workspace from the front right and above, far enough to see all of it."""
        if not np.all(np.isfinite(self._world_lo)):
            return None
        lo, hi = self._world_lo, self._world_hi
        centre = (lo + hi) / 2
        extent = float(max(np.max(hi - lo), 0.3))
        direction = np.array([1.0, -1.3, 0.8]) / np.linalg.norm([1.0, -1.3, 0.8])
        return rrb.EyeControls3D(
            kind="Orbital",
            position=(centre + 1.9 * extent * direction).tolist(),
            look_target=centre.tolist(),
            eye_up=[0.0, 0.0, 1.0],
        )

    def _grow_map(self, xy: np.ndarray) -> None:
        if len(xy):
            self._map_lo = np.minimum(self._map_lo, xy.min(axis=0))
            self._map_hi = np.maximum(self._map_hi, xy.max(axis=0))

    def _grow_world(self, xyz: np.ndarray) -> None:
        if len(xyz):
            self._world_lo = np.minimum(self._world_lo, xyz.min(axis=0))
            self._world_hi = np.maximum(self._world_hi, xyz.max(axis=0))

    def _is_create(self, robot: str) -> bool:
        return ("" if robot == "robot" else robot) in self._create_namespaces

    # ---------------------------------------------------------------- time
    def _set_time(self, t_ns: int) -> None:
        self._t_ns = t_ns
        if self._epoch is None:
            self._epoch = t_ns > EPOCH_NS
        if not self._t_range:
            self._t_range = [t_ns, t_ns]
        else:
            self._t_range = [min(self._t_range[0], t_ns), max(self._t_range[1], t_ns)]
        if self._epoch:
            self.rec.set_time(TIMELINE, timestamp=np.datetime64(t_ns, "ns"))
        else:
            self.rec.set_time(TIMELINE, duration=np.timedelta64(t_ns, "ns"))

    def _start_planar(self) -> None:
        """The top-down frame (mirrored) and its metre grid, once the world is known to be planar."""
        if self._planar_started or not self.planar:
            return
        self._planar_started = True
        self.rec.log(MAP, rr.Transform3D(mat3x3=MIRROR_Y), static=True)

    def _log_grid(self) -> None:
        """A line every metre across the map's extent, labelled along the bottom and left edges
        (inside the view's bounds however the extent falls between whole metres)."""
        if not np.all(np.isfinite(self._map_lo)):
            return
        lo, hi = self._map_lo, self._map_hi
        # a millimetre of slack: 500 cells of a float32 0.01 m end at 4.9999999 m, not before 5 m
        xs, ys = (np.arange(np.ceil(lo[i] - 1e-3) + 0.0, hi[i] + 1e-3) for i in (0, 1))  # + 0.0: no "-0 m"
        lines = [np.array([[x, lo[1]], [x, hi[1]]]) for x in xs] + [np.array([[lo[0], y], [hi[0], y]]) for y in ys]
        self.rec.log(
            f"{MAP}/grid",
            rr.LineStrips2D(lines, radii=rr.Radius.ui_points(0.8), colors=[GRID_COLOR], draw_order=-20),
            static=True,
        )
        pos = [(x, lo[1] - 0.12) for x in xs] + [(lo[0] - 0.25, y) for y in ys]
        labels = [f"{x:g} m" for x in xs] + [f"{y:g} m" for y in ys]
        self.rec.log(
            f"{MAP}/grid/labels",
            rr.Points2D(
                pos, radii=rr.Radius.ui_points(0.1), colors=[GRID_LABEL_COLOR], labels=labels, show_labels=True
            ),
            static=True,
        )

    # ---------------------------------------------------------------- robots and frames
    def _robot(self, name: str) -> _Robot:
        key = name or "robot"
        robot = self._robots.get(key)
        if robot is None:
            is_create = self._is_create(key)
            color = None
            if not self._outlined:  # SIMROBOT robots wait for their outline's colour
                known = self._topic_robots
                color = robot_color(key, known) if key in known else ROBOT_COLORS[len(self._robots) % len(ROBOT_COLORS)]
            robot = _Robot(
                key,
                color,
                is_create,
                _Track(f"{MAP}/tracks/{key}/truth", color, 2.5),
                _Track(f"{MAP}/tracks/{key}/odom", color, 1.0),
                expects_truth=self._has_truth_topic(key),
                heading_m=create_mounts.RADIUS_M if is_create else SIMROBOT_HEADING_M,
            )
            self._robots[key] = robot
            self.layout_version += 1
            self._start_planar()
            self._log_body(robot)
        return robot

    def _log_body(self, robot: _Robot) -> None:
        entity = f"{MAP}/robots/{robot.name}/body"
        color = robot.color or HEADING_COLOR
        if robot.is_create:
            a = np.linspace(0.0, 2 * math.pi, 49)
            circle = np.column_stack([create_mounts.RADIUS_M * np.cos(a), create_mounts.RADIUS_M * np.sin(a)])
            shape: rr.AsComponents = rr.LineStrips2D(
                [circle], radii=rr.Radius.ui_points(3.0), colors=[color], draw_order=30
            )
        else:  # the world's outline is a few pixels across at map zoom: a dot in its colour too
            shape = rr.Points2D([[0.0, 0.0]], radii=rr.Radius.ui_points(5.0), colors=[color], draw_order=38)
        self.rec.log(entity, shape, static=True)
        # The heading is dark on every robot colour, drawn above the sensor beams.
        self.rec.log(
            f"{entity}/heading",
            rr.Arrows2D(
                origins=[[0.0, 0.0]],
                vectors=[[robot.heading_m, 0.0]],
                radii=rr.Radius.ui_points(2.5 if robot.is_create else 1.5),  # not hiding a small robot's dot
                colors=[HEADING_COLOR],
                draw_order=40,
            ),
            static=True,
        )
        self._log_label(robot)

    def _log_label(self, robot: _Robot) -> None:
        """The robot's one label, below it on screen (the follow frame is the view's own: +y down;
        a label hangs from its point), saying its name, obstacle number and state; logged again
        when they change."""
        text = robot.name if robot.number is None else f"{robot.name} (#{robot.number})"
        text += " crashed" if robot.crashed else ""
        text += " off" if robot.powered is False else ""
        if text == robot.label:
            return
        robot.label = text
        d = LABEL_OFFSET_M["create" if robot.is_create else "simrobot"]
        label = rr.Points2D([[0.0, d]], radii=0.0, colors=[HEADING_COLOR], labels=[text], show_labels=True)
        self.rec.log(f"{MAP}/robots/{robot.name}/follow/label", label)

    def _set_color(self, robot: _Robot, outline: Outline) -> None:
        robot.color, robot.number = outline.color, outline.number
        self.layout_version += 1  # a live view sends the legend again, with the colour's name
        robot.heading_m = max(3.0 * outline.size_m, 0.12)  # reaches well out of the outline and its dot
        for track in (robot.truth, robot.odom):
            track.color = outline.color
            track.log(self.rec)
        self._log_body(robot)
        if not self._batch:  # its plotted series were given the palette's colours until now
            for entity, series in self._series.items():
                if series.robot == robot.name and series.shade is not None:
                    self._log_series_style(entity, series)

    def _match_outlines(self) -> None:
        """Give each SIMROBOT robot the colour of the ``/robots`` outline around its pose."""
        for robot in self._robots.values():
            if robot.color is None and robot.pose is not None:
                outline = outline_at(self._outlines, *robot.pose[:2])
                if outline is not None:
                    self._set_color(robot, outline)

    def _frame_entity(self, frame_id: str) -> str:
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
        robot = self._robot(prefix)
        if leaf == "base_link":
            return f"{MAP}/robots/{robot.name}"
        entity = f"{MAP}/robots/{robot.name}/{_path_part(leaf)}"
        if leaf not in robot.mounts:
            self._mount(robot, leaf, self._known_mount(robot, frame, leaf))
        return entity

    def _known_mount(self, robot: _Robot, frame: str, leaf: str) -> Mount:
        from_tf = self.frames.mount_on(frame)
        if from_tf is not None:
            return from_tf
        if robot.is_create and leaf in create_mounts.SENSOR_MOUNTS:
            m = create_mounts.SENSOR_MOUNTS[leaf]
            return Mount(m.x_m, m.y_m, m.yaw_rad)
        return Mount(0.0, 0.0, 0.0)

    def _mount(self, robot: _Robot, leaf: str, mount: Mount) -> None:
        robot.mounts[leaf] = mount
        self.rec.log(f"{MAP}/robots/{robot.name}/{_path_part(leaf)}", _yaw_transform(*mount), static=True)

    def _at_mount(self, robot: _Robot, leaf: str) -> tuple[float, float]:
        """Where a sensor of the robot is on the map now."""
        x, y, yaw = robot.pose or (0.0, 0.0, 0.0)
        m = robot.mounts.get(leaf, Mount(0.0, 0.0, 0.0))
        c, s = math.cos(yaw), math.sin(yaw)
        return x + c * m.x_m - s * m.y_m, y + s * m.x_m + c * m.y_m

    # ---------------------------------------------------------------- TF
    def _tf_message(self, topic: str, msg) -> None:
        static = _basename(topic) == "tf_static"
        for _parent, child, mount in self.frames.add(msg, static):
            if not static:
                continue  # moving frames: poses come from the pose and odometry topics
            prefix, _, leaf = child.rpartition("/")
            robot = self._robots.get(prefix or "robot")
            if robot is not None and leaf in robot.mounts and self.frames.mount_on(child) is not None:
                self._mount(robot, leaf, mount)  # a sensor drawn before its mount arrived

    # ---------------------------------------------------------------- plots and events
    def _scalar(
        self,
        tab: str,
        robot: str,
        key: str,
        value: float,
        shade: int | None = None,
        name: str | None = None,
    ) -> None:
        """Plot ``value`` as series ``key`` (legend: ``name``, default the key) of ``robot`` in tab
        ``tab``; with a ``shade``, in the robot's world colour (0) or a darker one (1) once known."""
        entity = f"plots/{tab}/{_path_part(robot)}/{_path_part(key)}"
        name = name or key
        series = self._series.get(entity)
        if series is None:
            index = sum(1 for s in self._series.values() if s.tab == tab)
            color = SERIES_COLORS[index % len(SERIES_COLORS)]
            label = name if len({*self._topic_robots, robot}) <= 1 else f"{robot} {name}"
            series = self._series[entity] = _Series(tab, label, color, robot, shade)
            if not self._batch:
                self._use_tab(tab)
                self._log_series_style(entity, series)
        if not self._batch:
            self._grow_tab(tab, value, value)
            self.rec.log(entity, rr.Scalars(value))
            return
        series.times.append(self._t_ns)
        series.values.append(value)

    def _log_series_style(self, entity: str, series: _Series) -> None:
        robot = self._robots.get(series.robot)
        color = series.color
        if series.shade is not None and self._outlined and robot is not None and robot.color is not None:
            color = robot.color if series.shade == 0 else _darker(robot.color)  # type: ignore[assignment]
        self.rec.log(entity, rr.SeriesLines(colors=[color], names=[series.name], widths=[1.5]), static=True)

    def _use_tab(self, tab: str) -> None:
        if tab not in self.plot_tabs:
            self.plot_tabs.add(tab)
            self.layout_version += 1

    def _grow_tab(self, tab: str, lo: float, hi: float) -> None:
        r = self._tab_ranges.setdefault(tab, [lo, hi])
        r[0], r[1] = min(r[0], lo), max(r[1], hi)

    def flush(self) -> None:
        """Send the plotted values kept so far (``batch_scalars``), leaving out series that never
        change; a no-op otherwise."""
        if not self._batch:
            return
        for entity, s in self._series.items():
            if not s.values:
                continue
            values = np.asarray(s.values, dtype=float)
            finite = values[np.isfinite(values)]
            spread = np.abs(finite - np.median(finite)) if finite.size else finite
            # An odometry error is noise-only when nearly all of it is (a republished step can
            # pair one odometry message with the truth of the step before).
            noise = s.tab == "odom_error" and spread.size and float(np.percentile(spread, 99)) <= CONSTANT_SPAN
            constant = float(finite.max() - finite.min()) <= CONSTANT_SPAN if finite.size else True
            if finite.size == 0 or (constant and s.tab not in KEEP_CONSTANT_TABS) or noise:
                s.times.clear()
                s.values.clear()
                continue
            self._use_tab(s.tab)
            self._grow_tab(s.tab, float(finite.min()), float(finite.max()))
            self._log_series_style(entity, s)
            if self._epoch:
                index = rr.TimeColumn(TIMELINE, timestamp=np.array(s.times, dtype="datetime64[ns]"))
            else:
                index = rr.TimeColumn(TIMELINE, duration=np.array(s.times, dtype="timedelta64[ns]"))
            self.rec.send_columns(entity, indexes=[index], columns=rr.Scalars.columns(scalars=values))
            s.times.clear()
            s.values.clear()

    def _event(self, robot: str, text: str, level: rr.TextLogLevel) -> None:
        if not self.has_events:
            self.has_events = True
            self.layout_version += 1
        # The time is in the text too: the viewer's time column is too narrow to read.
        line = f"{self._t_ns / 1e9:8.2f} s  {robot}: {text}"
        self.rec.log(f"events/{_path_part(robot)}", rr.TextLog(line, level=level))

    def _mark(self, robot: _Robot, kind: str, x: float, y: float) -> None:
        """A cross that stays on the map where it happened. Unlabelled: where a robot keeps bumping
        labels would pile up; Events has the times."""
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

    # ---------------------------------------------------------------- poses
    def _pose_stamped(self, topic: str, msg) -> None:
        base = _basename(topic)
        if base not in TRUTH_POSE_TOPICS or not self.planar:
            self._other_pose(topic, msg)
            return
        robot = self._robot(_namespace(topic))
        x, y, yaw = msg.pose.position.x, msg.pose.position.y, yaw_from_quaternion(msg.pose.orientation)
        robot.expects_truth = True
        robot.truths.append((self._t_ns, x, y, yaw))
        self._robot_pose(robot, x, y, yaw)
        robot.truth.add(self.rec, x, y)
        self._compare_odometry(robot)

    def _robot_pose(self, robot: _Robot, x: float, y: float, yaw: float) -> None:
        robot.pose = (x, y, yaw)
        self.rec.log(f"{MAP}/robots/{robot.name}", _yaw_transform(x, y, yaw))
        self.rec.log(f"{MAP}/robots/{robot.name}/follow", _follow_transform(yaw))
        if robot.color is None:
            self._match_outlines()

    def _other_pose(self, topic: str, msg) -> None:
        """A pose that is no robot's: axes at it (a target pose) and, for the arm's flange, its path."""
        base = self._frame_entity(msg.header.frame_id)
        entity = f"{base}/poses/{_topic_path(topic)}"
        p = msg.pose.position
        if base == WORLD:
            self._grow_world(np.array([[p.x, p.y, p.z]]))
            if _basename(topic) not in PATH_TOPICS:  # a target: axes and its name
                label = rr.Points3D([[0, 0, 0]], radii=0.006, colors=[HEADING_COLOR], labels=[_basename(topic)])
                self.rec.log(entity, _pose_transform(msg.pose), rr.TransformAxes3D(AXES_LENGTH_M), label)
            else:  # the flange: small axes and the path it followed
                self.rec.log(entity, _pose_transform(msg.pose), rr.TransformAxes3D(0.6 * AXES_LENGTH_M))
                path = self._paths.setdefault(
                    topic, _Track(f"{WORLD}/paths/{_topic_path(topic)}", (230, 120, 0), 2.0, dims=3)
                )
                path.add(self.rec, p.x, p.y, p.z)
        else:
            yaw = yaw_from_quaternion(msg.pose.orientation)
            self.rec.log(
                entity,
                _yaw_transform(p.x, p.y, yaw),
                rr.Arrows2D(origins=[[0, 0]], vectors=[[0.2, 0]], colors=[HEADING_COLOR], labels=[_basename(topic)]),
            )

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
                self._robot_pose(robot, x, y, yaw)
            else:
                error = math.hypot(x - truth[0], y - truth[1])
                self._scalar("odom_error", robot.name, "position_m", error, 0, "position (m)")
                error = wrap_angle(yaw - truth[2])
                self._scalar("odom_error", robot.name, "heading_rad", error, 1, "heading (rad)")
        self._set_time(now)

    # ---------------------------------------------------------------- sensors
    def _sensor_robot(self, entity: str) -> _Robot | None:
        parts = entity.split("/")
        if len(parts) >= 4 and entity.startswith(f"{MAP}/robots/"):
            return self._robots.get(parts[3])
        return None

    def _laser_scan(self, topic: str, msg) -> None:
        entity = self._frame_entity(msg.header.frame_id)
        ranges = np.asarray(msg.ranges, dtype=np.float64)
        angles = msg.angle_min + msg.angle_increment * np.arange(ranges.size)
        hit = np.isfinite(ranges) & (ranges > 0.0)
        r, a = ranges[hit], angles[hit]
        pts = np.column_stack([r * np.cos(a), r * np.sin(a)]).astype(np.float32)
        colors: list[tuple[int, int, int]] | np.ndarray = [LIDAR_COLOR]
        if len(msg.intensities) == ranges.size:
            # SIMROBOT: intensity = obstacle number, 1 wall, 2–255 a robot
            obstacle = np.asarray(msg.intensities)[hit]
            colors = np.where((obstacle > 1)[:, None], LIDAR_ROBOT_COLOR, LIDAR_COLOR).astype(np.uint8)
        name = _path_part(_basename(topic))
        if entity == WORLD:
            pts3 = np.column_stack([pts, np.zeros(len(pts), np.float32)])
            self.rec.log(f"{entity}/{name}", rr.Points3D(pts3, radii=0.01, colors=colors))
            return
        self.rec.log(f"{entity}/{name}", rr.Points2D(pts, radii=rr.Radius.ui_points(2.0), colors=colors, draw_order=20))
        # The seed's GUI draws five beams across the field of view: faint rays for those.
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
        entity = self._frame_entity(msg.header.frame_id)
        robot = self._sensor_robot(entity)
        robot_name = robot.name if robot is not None else (_namespace(topic) or "robot")
        name = _basename(msg.header.frame_id) or _basename(topic)
        if msg.min_range == msg.max_range:  # REP-117 fixed-distance detector: -inf = detection
            self._binary(topic, entity, robot_name, name, msg.range == -math.inf, msg)
            return
        fov, r = float(msg.field_of_view), float(msg.range)
        if entity != WORLD:
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
        if math.isfinite(r):
            self._grow_tab("range", 0.0, float(msg.max_range))
            self._scalar("range", robot_name, name, r, 0)

    def _binary(self, topic: str, entity: str, robot_name: str, name: str, active: bool, msg=None) -> None:
        previous = self._binary_state.get(topic)
        if previous == active:
            return  # drawn on change only: detectors publish at 50 Hz and are mostly idle
        self._binary_state[topic] = active
        robot = self._robots.get(robot_name)
        contact = "bump" in name
        crash = name == "crashed"
        level = (
            rr.TextLogLevel.WARN
            if crash
            else rr.TextLogLevel.INFO
            if contact or "cliff" in name
            else rr.TextLogLevel.DEBUG
        )
        if previous is None and not active:
            return  # the initial state, not an event
        if crash:
            self._event(robot_name, "crashed" if active else "crash cleared", level if active else rr.TextLogLevel.INFO)
        else:
            self._event(robot_name, f"{name} {'on' if active else 'off'}", level)
        if crash and robot is not None:  # a state: the label says it, a cross marks where
            robot.crashed = active
            self._log_label(robot)
            if active:
                self._mark(robot, "crashes", *(robot.pose or (0.0, 0.0))[:2])
            return
        if entity == WORLD:
            return
        lit = f"{entity}/detection" if entity.startswith(f"{MAP}/robots/") else entity
        if active:
            reach = float(msg.max_range) if msg is not None and math.isfinite(msg.max_range) else 0.0
            color = CONTACT_COLOR if contact else DETECTOR_COLOR
            shapes: list[rr.AsComponents] = [
                rr.Points2D([[0.0, 0.0]], radii=rr.Radius.ui_points(6.0), colors=[color], draw_order=45)
            ]
            if reach > 0:  # the IR wall sensor sees along a line
                shapes.append(
                    rr.LineStrips2D(
                        [[[0.0, 0.0], [reach, 0.0]]], radii=rr.Radius.ui_points(3), colors=[color], draw_order=45
                    )
                )
            self.rec.log(lit, *shapes)
            if robot is not None and contact:
                self._mark(robot, "contacts", *self._at_mount(robot, entity.rpartition("/")[2]))
        else:
            self.rec.log(lit, rr.Clear(recursive=False))

    def _illuminance(self, topic: str, msg) -> None:
        entity = self._frame_entity(msg.header.frame_id)
        robot = self._sensor_robot(entity)
        robot_name = robot.name if robot is not None else (_namespace(topic) or "robot")
        name = _basename(msg.header.frame_id) or _basename(topic)
        self._scalar("cliff", robot_name, name, msg.illuminance)
        self._binary(topic, entity, robot_name, name, msg.illuminance <= CLIFF_THRESHOLD)

    def _bool(self, topic: str, msg) -> None:
        robot = _namespace(topic) or "robot"
        if robot in self._robots or robot in self._topic_robots:
            if _basename(topic) == "power":
                self._power(self._robot(_namespace(topic)), bool(msg.data))
                return
            entity = f"{MAP}/robots/{self._robot(_namespace(topic)).name}/{_path_part(_basename(topic))}"
        else:
            entity = f"{MAP if self.planar else WORLD}/flags/{_topic_path(topic)}"
        self._binary(topic, entity, robot, _basename(topic), bool(msg.data))

    def _power(self, robot: _Robot, on: bool) -> None:
        """A robot's power is a state (SIMROBOT latches it): its label says "off"; a switch is an event."""
        if robot.powered is not None and robot.powered != on:
            self._event(robot.name, f"power {'on' if on else 'off'}", rr.TextLogLevel.INFO)
        if robot.powered != on:
            robot.powered = on
            self._log_label(robot)

    def _scalar_data(self, topic: str, msg) -> None:
        robot = _namespace(topic).partition("/")[0] or "robot"
        if _basename(topic) == "obstacle":
            self._scalar("obstacle", robot, _namespace(topic).partition("/")[2] or "obstacle", float(msg.data), 0)
            return
        self._scalar("other", robot, _topic_path(topic), float(msg.data))

    def _battery(self, topic: str, msg) -> None:
        robot = _namespace(topic) or "robot"
        self._scalar("battery", robot, "voltage_v", msg.voltage, name="voltage (V)")
        self._scalar("battery", robot, "charge_percent", 100.0 * msg.percentage, name="charge (%)")

    def _joy(self, topic: str, msg) -> None:
        robot = _namespace(topic) or "robot"
        base = _basename(topic)
        for i, value in enumerate(msg.buttons):
            self._scalar("buttons", robot, f"{base}_button{i}", float(value), name=f"{base} button {i}")
        for i, value in enumerate(msg.axes):
            self._scalar("buttons", robot, f"{base}_axis{i}", float(value), name=f"{base} axis {i}")

    def _twist_stamped(self, topic: str, msg) -> None:
        self._twist(topic, msg.twist)

    def _twist(self, topic: str, twist) -> None:
        robot = _namespace(topic) or "robot"
        base = _basename(topic)
        self._scalar("commands", robot, f"{base}_linear_x", twist.linear.x, 0, f"{base} linear (m/s)")
        self._scalar("commands", robot, f"{base}_angular_z", twist.angular.z, 1, f"{base} angular (rad/s)")

    def _joint_state(self, topic: str, msg) -> None:
        names = list(msg.name) or [f"joint{i + 1}" for i in range(len(msg.position))]
        ns = _namespace(topic)
        if _basename(topic) == "wheel_cmd":  # SIMROBOT wheel speed commands: [left, right] rad/s
            for shade, (side, value) in enumerate(zip(("left", "right"), msg.velocity, strict=False)):
                self._scalar("commands", ns or "robot", f"wheel_{side}", float(value), shade, f"wheel {side} (rad/s)")
            return
        for field_name in ("position", "velocity", "effort"):
            values = getattr(msg, field_name)
            for joint, value in zip(names, values, strict=False):  # velocity/effort may be empty
                self._scalar(f"joint_{field_name}", ns or "arm", joint, float(value))

    # ---------------------------------------------------------------- maps
    def _occupancy_grid(self, topic: str, msg) -> None:
        info = msg.info
        w, h = info.width, info.height
        if w * h == 0 or len(msg.data) != w * h:
            warnings.warn(f"{topic}: OccupancyGrid {w}x{h} with {len(msg.data)} cells; not drawn", stacklevel=2)
            return
        cells = np.asarray(msg.data, dtype=np.int8).reshape(h, w)
        # Row 0 is the lowest y, drawn at the bottom (the map frame is mirrored): walls dark,
        # free cells white, unknown light grey.
        wall = OCCUPIED_UNDER_LINES if any(_basename(t) == "map_markers" for t in self.topics) else OCCUPIED
        image = np.where(cells >= 50, wall, np.where(cells < 0, 225, 255)).astype(np.uint8)
        res = info.resolution
        o = info.origin.position
        self._grow_map(np.array([[o.x, o.y], [o.x + w * res, o.y + h * res]]))
        entity = f"{MAP}/{_topic_path(topic)}"
        q = info.origin.orientation
        quat = [q.x, q.y, q.z, q.w] if (q.x, q.y, q.z, q.w) != (0.0, 0.0, 0.0, 0.0) else [0.0, 0.0, 0.0, 1.0]
        self.rec.log(
            entity,
            rr.Transform3D(translation=[o.x, o.y, 0.0], quaternion=rr.Quaternion(xyzw=quat), scale=[res, res, 1.0]),
            rr.Image(image, color_model="L", draw_order=-30),
            static=True,
        )
        self._log_grid()

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
        grew = False
        if label == "map_markers":
            walls = [
                _points(m.points)[:, :2] + [m.pose.position.x, m.pose.position.y] for m in markers if m.ns == "walls"
            ]
            self._arena = shapes.extent(walls)
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
            if base == WORLD:
                self._marker_3d(entity, m, static)
            else:
                grew |= self._marker_2d(entity, m, static, base == MAP and label == "map_markers")
        if _basename(topic) == "robots":
            self._outlines_from(markers)
        if grew:
            self._log_grid()
        if not static:
            # Each message is the topic's full set (camera sightings come and go): clear the missing.
            for entity in self._marker_entities.get(topic, set()) - seen:
                self.rec.log(entity, rr.Clear(recursive=True))
            self._marker_entities[topic] = seen

    def _outlines_from(self, markers) -> None:
        self._outlines = robot_outlines(markers)
        self._match_outlines()

    def _marker_2d(self, entity: str, m, static: bool, is_map: bool) -> bool:
        """A Marker seen from above; returns True if it grew the map's extent."""
        color = _rgba(m.color)
        alpha = FADED_MARKERS.get(m.ns)
        if alpha is not None:  # blended towards the white background: 2-D lines are opaque
            r, g, b = (int(round(255 - alpha * (255 - c))) for c in color[:3])
            color = (r, g, b, 255)
        pts = _points(m.points)[:, :2]
        colors = [_rgba(c) for c in m.colors] if len(m.colors) == len(m.points) and m.colors else [color]
        width = rr.Radius.ui_points(1.5) if alpha is not None else max(m.scale.x, 1e-3) / 2
        p = m.pose.position
        yaw = yaw_from_quaternion(m.pose.orientation)
        transform = _yaw_transform(p.x, p.y, yaw)
        if alpha is not None and self._arena is not None and yaw == 0.0:  # walls block the field
            pts = shapes.clip_outline(pts, self._arena[0] - [p.x, p.y], self._arena[1] - [p.x, p.y])
        grew = False
        shape: rr.AsComponents
        if is_map and static:
            before = (self._map_lo.copy(), self._map_hi.copy())
            self._grow_map(pts + np.array([p.x, p.y]) if len(pts) else np.array([[p.x, p.y]]))
            grew = not (np.array_equal(before[0], self._map_lo) and np.array_equal(before[1], self._map_hi))
        if m.type == TEXT:
            shape = rr.Points2D([[0.0, 0.0]], radii=0.0, colors=[color], labels=[m.text], show_labels=True)
        elif m.type in (SPHERE, CYLINDER):
            shape = rr.Points2D([[0.0, 0.0]], radii=max(m.scale.x, 1e-3) / 2, colors=[color], draw_order=25)
        elif m.type == LINE_STRIP:
            shape = rr.LineStrips2D([pts], radii=width, colors=[color])
        elif m.type == LINE_LIST:
            segments = pts[: len(pts) // 2 * 2].reshape(-1, 2, 2)
            seg_colors = colors[::2] if len(colors) == len(pts) else colors
            shape = rr.LineStrips2D(segments, radii=width, colors=seg_colors)
        elif m.type in (POINTS, SPHERE_LIST, CUBE_LIST):
            shape = rr.Points2D(pts, radii=max(m.scale.x, 1e-3) / 2, colors=colors)
        elif m.type == CUBE:
            shape = rr.Boxes2D(half_sizes=[[m.scale.x / 2, m.scale.y / 2]], colors=[color])
        elif m.type == ARROW:
            if len(pts) >= 2:
                shape = rr.Arrows2D(origins=pts[:1], vectors=pts[1:2] - pts[:1], colors=[color])
            else:
                shape = rr.Arrows2D(origins=[[0, 0]], vectors=[[m.scale.x, 0]], colors=[color])
        else:  # meshes and triangles have no top-down drawing here
            return grew
        self.rec.log(entity, transform, shape, static=static)
        return grew

    def _marker_3d(self, entity: str, m, static: bool) -> None:
        color = _rgba(m.color)
        pts = _points(m.points)
        colors = [_rgba(c) for c in m.colors] if len(m.colors) == len(m.points) and m.colors else [color]
        width = max(m.scale.x, 1e-3)
        p = m.pose.position
        self._grow_world(np.array([[p.x, p.y, p.z]]))
        if m.type == MESH:
            self._mesh(entity, m, color)
            return
        transform = _pose_transform(m.pose)
        shape: rr.AsComponents
        if m.type in (SPHERE, TEXT):
            label = [m.text] if m.text and m.type == TEXT else None
            radius = m.scale.x / 2 if m.type == SPHERE else 0.01
            shape = rr.Points3D([[0.0, 0.0, 0.0]], radii=radius, colors=[color], labels=label, show_labels=bool(label))
        elif m.type == LINE_STRIP:
            shape = rr.LineStrips3D([pts], radii=width / 2, colors=[color])
        elif m.type == LINE_LIST:
            # per-vertex colours (an axes marker: x red, y green, z blue) colour each segment
            seg_colors = colors[::2] if len(colors) == len(pts) else colors
            shape = rr.LineStrips3D(pts[: len(pts) // 2 * 2].reshape(-1, 2, 3), radii=width / 2, colors=seg_colors)
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
            path = mesh_path(uri)  # file:// or package:// (an installed robot_sims publishes those)
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


def _darker(color: tuple[int, int, int] | None) -> tuple[int, int, int] | None:
    return None if color is None else tuple(int(c * 0.55) for c in color)  # type: ignore[return-value]


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
    TF_MESSAGE_TYPE: "_tf_message",
}
"""Message type → RerunLogger method drawing it."""

SUPPORTED_TYPES = frozenset(HANDLERS) | {"rosgraph_msgs/msg/Clock"}
"""Message types :class:`RerunLogger` draws (``Clock`` is accepted and only drives time)."""
