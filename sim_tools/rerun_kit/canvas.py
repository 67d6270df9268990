"""The state every message family draws on: the recording and its time, the topics and the
simulators' drawings, the map's and the 3-D world's extent, and the metre grid."""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np
import rerun as rr

from sim_tools.rerun_kit.contract import Outline, PlotTab, SimulatorDrawing
from sim_tools.rerun_kit.ros import basename, namespace
from sim_tools.rerun_kit.state import Robot, Series, Track
from sim_tools.rerun_kit.style import EPOCH_NS, GRID_COLOR, GRID_LABEL_COLOR, MAP, MIRROR_Y, TIMELINE, WORLD
from sim_tools.rerun_kit.tf import FrameTree

PLOT_TABS = (
    PlotTab("odom_error", "Odometry error (m, rad)", None, 0),
    PlotTab("range", "Range (m)", None, 10),
    PlotTab("commands", "Commands (m/s, rad/s)", None, 30),
    PlotTab("joint_position", "Joint positions (rad)", None, 40),
    PlotTab("joint_velocity", "Joint velocities (rad/s)", None, 41),
    PlotTab("joint_effort", "Joint efforts (N·m)", None, 42),
    PlotTab("battery", "Battery (V, %)", None, 80),
    PlotTab("buttons", "Buttons and axes", (-1.05, 1.05), 90),
    PlotTab("other", "Other", None, 100),
)
"""The message families' plot tabs; simulators add theirs (:attr:`SimulatorDrawing.plot_tabs`)."""


class Canvas:
    """The recording, its time and what is known of the world; the base of the message families.

    ``topics`` (name → ``pkg/msg/Type``) tells which robots exist; more can be added later with
    :meth:`add_topics`. ``drawings`` are the simulators' (see :mod:`sim_tools.rerun_view.logger`).
    """

    def __init__(
        self,
        recording: rr.RecordingStream,
        topics: dict[str, str] | None,
        drawings: Sequence[SimulatorDrawing],
        batch_scalars: bool,
    ) -> None:
        self.rec = recording
        self.drawings = list(drawings)
        self._declarations()
        self._t_ns = 0
        self._t_range: list[int] = []  # first and last time seen
        # Converting a bag, scalars are kept and sent as columns by flush(): a log call per sample
        # costs ~0.5 ms, a column of thousands about the same. Live, they are logged at once.
        self._batch = batch_scalars
        self._series: dict[str, Series] = {}
        self._tab_ranges: dict[str, list[float]] = {}
        self.topics: dict[str, str] = {}
        self._topic_robots: list[str] = []  # sorted robot names of self.topics
        self._topic_names: set[str] = set()  # self.topics without leading slashes
        self._robots: dict[str, Robot] = {}
        self._outlined = False  # the world draws its robots' outlines in colour
        self._outlines: list[Outline] = []
        self._outline_match_m = 0.0
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
        self._paths: dict[str, Track] = {}
        self.layout_version = 0
        self.rec.log(WORLD, rr.ViewCoordinates.RIGHT_HAND_Z_UP, static=True)
        self.add_topics(topics or {})

    def _declarations(self) -> None:
        """What the drawings declare, gathered: topic names by role, faded namespaces, plot tabs."""
        d = self.drawings
        self.truth_pose_topics = tuple(t for s in d for t in s.truth_pose_topics)
        self._map_topics = frozenset(t for s in d for t in s.map_marker_topics)
        self._static_topics = self._map_topics | {t for s in d for t in s.static_marker_topics}
        self._wall_namespaces = frozenset(n for s in d for n in s.wall_namespaces)
        self._faded = {ns: alpha for s in d for ns, alpha in s.faded_markers.items()}
        self._path_topics = frozenset(t for s in d for t in s.path_topics)
        self._outliners = {t: s for s in d for t in s.outline_topics}
        tabs = sorted([*PLOT_TABS, *(t for s in d for t in s.plot_tabs)], key=lambda t: t.rank)
        self.tab_table: dict[str, PlotTab] = {t.key: t for t in tabs}

    @property
    def plot_groups(self) -> set[str]:
        """Entity paths of the plot tabs (``plots/<tab>``)."""
        return {f"plots/{tab}" for tab in self.plot_tabs}

    def add_topics(self, topics: dict[str, str]) -> None:
        """Register topics (name → type): robots and how the simulators' drawings see them."""
        self.topics.update(topics)
        self._topic_robots = self.robots_in_topics(self.topics)
        self._topic_names = {t.strip("/") for t in self.topics}
        if any(basename(topic) in self._outliners for topic in topics):
            self._outlined = True

    def robots_in_topics(self, topics) -> list[str]:
        """Robot names (namespaces, ``robot`` for the root) that have a pose or odometry topic."""
        poses = (*self.truth_pose_topics, "odom")
        return sorted({namespace(t) or "robot" for t in topics if basename(t) in poses})

    @property
    def planar(self) -> bool:
        """True for worlds of mobile robots (drawn top-down), False for arms (3-D)."""
        return bool(self._topic_robots or self._robots)

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

    def _grow_map(self, xy: np.ndarray) -> None:
        if len(xy):
            self._map_lo = np.minimum(self._map_lo, xy.min(axis=0))
            self._map_hi = np.maximum(self._map_hi, xy.max(axis=0))

    def _grow_world(self, xyz: np.ndarray) -> None:
        if len(xyz):
            self._world_lo = np.minimum(self._world_lo, xyz.min(axis=0))
            self._world_hi = np.maximum(self._world_hi, xyz.max(axis=0))

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
