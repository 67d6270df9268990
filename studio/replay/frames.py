"""What the replay page shows at an instant of a bag (no GUI here): robots, readings, commands.

:class:`Replay` opens a bag through :class:`~sim_runtime.bag.index.BagIndex` and answers
:meth:`Replay.frame` for any time: every robot's pose, a Create's sensor readings as the live view
draws them, SIMROBOT robots, an arm's joints, the commands sent so far (the original's function-call
column) and a one-line summary of every topic's latest message. Robots are found by their topics:
a Create by ``overhead_pose``, a SIMROBOT robot by ``pose`` (both PoseStamped), any other robot by
``odom``, an arm by ``joint_states`` (drawn in 3D from its ``robot_markers`` and its world's
``scene_markers``, as the Arm page draws a live arm). Stepping goes from one message of the *frame
topic* (the first robot's pose, else the joints, else any topic) to the next.
"""

from __future__ import annotations

import math
import warnings
from collections import OrderedDict
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np
from nav_msgs.msg import OccupancyGrid
from visualization_msgs.msg import MarkerArray

from arm_sim import spec as arm_spec
from create_sim import spec
from create_sim.mapfile import CreateMap
from create_sim.spec import CLIFF_NAMES, MAP_NAMESPACES, SONAR_NAMES
from sim_runtime.bag.cdr import track_positions
from sim_runtime.bag.index import BagIndex
from sim_runtime.bag.reader import BagMessage, CorruptMessage, UnknownMessageType
from sim_runtime.msgs import yaw_from_quaternion
from simrobot_sim.spec import ROBOTS_TOPIC
from studio.arm.ros_client import Group, drawables

POSE = "geometry_msgs/msg/PoseStamped"
GRID = "nav_msgs/msg/OccupancyGrid"
ODOM = "nav_msgs/msg/Odometry"
JOINTS = "sensor_msgs/msg/JointState"
MARKERS = "visualization_msgs/msg/MarkerArray"
ARM_MARKER_TOPICS = (arm_spec.ROBOT_MARKERS_TOPIC, arm_spec.SCENE_MARKERS_TOPIC)
"""An arm world's 3D look: each arm's meshes posed (robot_markers), the scene's objects (scene_markers)."""
COMMAND_TOPICS = ("cmd_vel", "wheel_cmd", "joint_command", "joint_trajectory", "target_pose", "set_pose")
"""What a controller or a person sends: the replay's list of calls made."""
COMMANDS_SHOWN = 12
DECODED_KEPT = 1024
TRACK_MIN_STEP_M = 0.02
"""A drawn track gets a point per this many metres travelled (a 10-minute run stays a few thousand)."""


def namespace(topic: str) -> str:
    """``/robot2/overhead_pose`` → ``/robot2``; a root topic → ``''``."""
    ns = topic.rstrip("/").rpartition("/")[0]
    return ns


def basename(topic: str) -> str:
    return topic.rstrip("/").rpartition("/")[2]


def is_world_topic(topic: str, kind: str) -> bool:
    """Whether ``topic`` is a world's own (not a robot's): a Create map, a SIMROBOT occupancy grid
    or robot outlines. Its namespace is the world's."""
    name = basename(topic)
    return name == spec.MAP_MARKERS_TOPIC or kind == GRID or (name == ROBOTS_TOPIC and kind == MARKERS)


def in_world(topic: str, world: str | None) -> bool:
    """Whether a world topic belongs to ``world`` (None: every world)."""
    return world is None or namespace(topic) == world


@dataclass
class Robot:
    """A robot found in the bag: its kind ('create', 'simrobot', 'mobile'), pose topic and track."""

    ns: str
    kind: str
    pose_topic: str
    track_times: np.ndarray = field(default_factory=lambda: np.zeros(0, np.int64))
    track: np.ndarray = field(default_factory=lambda: np.zeros((0, 2)))

    @property
    def label(self) -> str:
        return self.ns or "/"

    def topic(self, name: str) -> str:
        return f"{self.ns}/{name}"


def world_of(robot: Robot, map_worlds: set[str]) -> str:
    """The namespace of the world ``robot`` is in: a Create's (or any odometry robot's) own
    namespace; a SIMROBOT robot's is the nearest enclosing namespace with a world topic, else its
    parent (``/simrobot1/r1`` → ``/simrobot1``)."""
    if robot.kind != "simrobot":
        return robot.ns
    enclosing = [w for w in map_worlds if not w or robot.ns == w or robot.ns.startswith(w + "/")]
    return max(enclosing, key=len) if enclosing else namespace(robot.ns)


@dataclass
class RobotFrame:
    """One robot at an instant: pose and, for a Create, what the live view draws."""

    robot: Robot
    pose: tuple[float, float, float] | None = None
    odom: tuple[float, float, float] | None = None
    velocity: tuple[float, float] | None = None
    scan: tuple[float, float, np.ndarray] | None = None
    scan_stamp: float = 0.0
    sonar: dict[str, float] = field(default_factory=dict)
    wall: bool | None = None
    bumps: tuple[bool, bool] | None = None
    cliffs: dict[str, float] = field(default_factory=dict)
    sightings: list[tuple[float, float, str]] = field(default_factory=list)
    track: np.ndarray | None = None
    crashed: bool = False


@dataclass
class Frame:
    """The bag at time ``t_ns`` (``elapsed_s`` since its first message)."""

    t_ns: int
    elapsed_s: float
    robots: list[RobotFrame]
    joints: dict[str, list[tuple[str, float]]]  # arm namespace → (joint, position rad)
    end_effectors: dict[str, tuple[float, ...]]  # arm namespace → x y z (m) qx qy qz qw
    commands: list[tuple[float, str, str]]  # (elapsed s, topic, summary), newest first
    latest: list[tuple[str, float, str]]  # (topic, age s, summary) of every topic
    map: CreateMap | None = None
    grid: OccupancyGrid | None = None  # SIMROBOT's map
    outlines: MarkerArray | None = None  # /robots
    map_extras: MarkerArray | None = None  # map_markers beyond the map's own (a learning env's goal region)
    arm_groups: list[Group] = field(default_factory=list)  # what the arm view draws, as live


def decode(m: BagMessage):
    """The message, or None if its type is not installed or its bytes are bad (warned once per topic)."""
    try:
        return m.msg
    except (UnknownMessageType, CorruptMessage) as err:
        warnings.warn(str(err), stacklevel=2)
        return None


def planar(pose) -> tuple[float, float, float]:
    return (pose.position.x, pose.position.y, yaw_from_quaternion(pose.orientation))


def summary(type_name: str, msg) -> str:
    """One line saying what a message holds (the side panel's messages at this instant)."""
    if msg is None:
        return f"({type_name}, not decoded)"
    kind = type_name.rpartition("/")[2]
    if kind in ("Twist", "TwistStamped"):
        t = msg.twist if kind == "TwistStamped" else msg
        return f"v {t.linear.x:.3f} m/s, ω {t.angular.z:.3f} rad/s"
    if kind == "PoseStamped":
        x, y, th = planar(msg.pose)
        return f"x {x:.3f}, y {y:.3f}, θ {th:.3f}"
    if kind == "Odometry":
        x, y, th = planar(msg.pose.pose)
        return f"x {x:.3f}, y {y:.3f}, θ {th:.3f}; v {msg.twist.twist.linear.x:.3f}, ω {msg.twist.twist.angular.z:.3f}"
    if kind == "Range":
        r = msg.range
        if msg.min_range == msg.max_range:  # a fixed-distance detector
            return "detected" if r == -math.inf else "clear"
        return f"{r:.3f} m" if math.isfinite(r) else ("no return" if r > 0 else "too close")
    if kind == "LaserScan":
        ranges = np.asarray(msg.ranges, dtype=np.float32)
        finite = ranges[np.isfinite(ranges)]
        nearest = f"{float(finite.min()):.3f} m" if len(finite) else "none"
        return f"{len(ranges)} beams, nearest {nearest}"
    if kind == "Illuminance":
        return f"{msg.illuminance:.1f} %"
    if kind == "JointState":
        values, unit = (msg.position, "") if len(msg.position) else (msg.velocity, " rad/s")
        names = list(msg.name) or [f"#{i}" for i in range(len(values))]
        return ", ".join(f"{n} {v:.3f}{unit}" for n, v in zip(names, values, strict=False))
    if kind == "MarkerArray":
        return f"{len(msg.markers)} markers"
    if kind == "Bool":
        return str(msg.data).lower()
    if kind == "Joy":
        return f"buttons {list(msg.buttons)}"
    if kind == "Clock":
        return f"{msg.clock.sec + 1e-9 * msg.clock.nanosec:.3f} s"
    if kind == "BatteryState":
        return f"{msg.voltage:.1f} V"
    if kind == "JointTrajectory":
        return f"{len(msg.points)} points for {', '.join(msg.joint_names)}"
    return kind


class Replay:
    """A bag opened for replay: robots, frame times, and :meth:`frame` at any instant."""

    def __init__(self, index: BagIndex) -> None:
        self.index = index
        self.path = Path(index.path)
        self.start_ns = index.start_ns
        self.end_ns = index.end_ns
        topics = index.topics
        self.robots: list[Robot] = []
        poses = sorted(
            t for t, kind in topics.items() if kind == POSE and basename(t) in (spec.OVERHEAD_POSE_TOPIC, "pose")
        )
        for topic in poses:
            kind = "create" if basename(topic) == spec.OVERHEAD_POSE_TOPIC else "simrobot"
            self.robots.append(Robot(namespace(topic), kind, topic))
        with_pose = {r.ns for r in self.robots}
        for topic in sorted(t for t, kind in topics.items() if kind == ODOM and basename(t) == "odom"):
            if namespace(topic) not in with_pose:
                self.robots.append(Robot(namespace(topic), "mobile", topic))
        self.arms = sorted(
            namespace(t) for t, kind in topics.items() if kind == JOINTS and basename(t) == arm_spec.JOINT_STATES_TOPIC
        )
        self.arm_marker_topics = sorted(
            t for t, kind in topics.items() if kind == MARKERS and basename(t) in ARM_MARKER_TOPICS
        )
        self.command_topics = sorted(t for t in topics if basename(t) in COMMAND_TOPICS)
        # The worlds recorded (each its own map and frame of reference: a Create's walls drawn
        # over a SIMROBOT grid, or its robot inside the other's walls, would be nonsense).
        map_worlds = {namespace(t) for t, kind in topics.items() if is_world_topic(t, kind)}
        self.worlds: dict[str, list[Robot]] = {}
        for robot in self.robots:
            self.worlds.setdefault(world_of(robot, map_worlds), []).append(robot)
        for ns in sorted(map_worlds - set(self.worlds)):
            self.worlds[ns] = []
        self.worlds = dict(sorted(self.worlds.items()))
        if self.robots:
            self.frame_topic: str | None = self.robots[0].pose_topic
        elif self.arms:
            self.frame_topic = f"{self.arms[0]}/joint_states"
        else:
            self.frame_topic = None
        if self.frame_topic is not None and self.frame_topic in index.by_topic:
            self.frames = index.by_topic[self.frame_topic].times
        else:
            self.frames = np.unique(np.concatenate([ti.times for ti in index.by_topic.values()] or [np.zeros(0, int)]))
        self._world_frames: dict[str, np.ndarray] = {}
        for robot in self.robots:
            self._load_track(robot)
        self._maps: dict[str, tuple[CreateMap, MarkerArray | None]] = {}
        self._decoded: OrderedDict[tuple[str, int], tuple[BagMessage, Any]] = OrderedDict()
        self._groups: dict[str, tuple[int, Group]] = {}  # marker topic -> (position, its group)

    @classmethod
    def open(cls, path: str | Path) -> Replay:
        return cls(BagIndex.open(path))

    @property
    def has_plan_view(self) -> bool:
        """Whether anything is drawn on the map view (robots, a Create map, an occupancy grid)."""
        topics = self.index.topics
        return bool(self.robots) or any(
            basename(t) == spec.MAP_MARKERS_TOPIC or kind == "nav_msgs/msg/OccupancyGrid" for t, kind in topics.items()
        )

    @property
    def first_frame_ns(self) -> int:
        """Where the page opens and Stop goes back to: the first frame (an arm bag's first instant
        holds only its latched description, its first joints come a step later)."""
        return int(self.frames[0]) if len(self.frames) else self.start_ns

    def robots_of(self, world: str | None) -> list[Robot]:
        """The robots of ``world`` (None: every robot in the bag)."""
        return self.robots if world is None else self.worlds.get(world, [])

    def world_kind(self, world: str) -> str:
        """What the world in ``world`` is ('create', 'simrobot', 'mobile'), for its label."""
        robots = self.worlds.get(world, [])
        if robots:
            return robots[0].kind
        grid = any(kind == GRID and namespace(t) == world for t, kind in self.index.topics.items())
        return "simrobot" if grid else "create"

    def frame_times(self, world: str | None) -> np.ndarray:
        """The frames of ``world``: its first robot's poses (None, or a world without robots: the bag's)."""
        robots = self.robots_of(world)
        if world is None or not robots or robots[0].pose_topic not in self.index.by_topic:
            return self.frames
        if world not in self._world_frames:
            self._world_frames[world] = self.index.by_topic[robots[0].pose_topic].times
        return self._world_frames[world]

    def first_frame_of(self, world: str | None) -> int:
        """Where the page opens ``world`` and Stop goes back to: its first frame."""
        times = self.frame_times(world)
        return int(times[0]) if len(times) else self.first_frame_ns

    @property
    def duration_s(self) -> float:
        return (self.end_ns - self.start_ns) / 1e9

    def _load_track(self, robot: Robot) -> None:
        """Every pose of the robot, read once: the track drawn up to any instant."""
        ti = self.index.by_topic.get(robot.pose_topic)
        if ti is None:
            return
        messages = self.index.messages(robot.pose_topic)
        xy = track_positions(ti.type, [m.data for m in messages])
        if xy is None:
            xy = np.full((len(messages), 2), np.nan)
        for i in np.flatnonzero(np.isnan(xy[:, 0])):  # what the fast read could not: deserialise
            msg = decode(messages[i])
            if msg is not None:
                position = (msg.pose.pose if robot.kind == "mobile" else msg.pose).position
                xy[i] = position.x, position.y
        # One point per TRACK_MIN_STEP_M travelled: a parked robot's 50 Hz poses are one point.
        travelled = np.concatenate([[0.0], np.cumsum(np.nan_to_num(np.hypot(*np.diff(xy, axis=0).T)))])
        keep = np.flatnonzero(np.diff(np.floor(travelled / TRACK_MIN_STEP_M), prepend=-1.0) > 0)
        robot.track_times = ti.times[keep]
        robot.track = xy[keep]

    # ------------------------------------------------------------------ stepping
    def step(self, t_ns: int, frames: int, world: str | None = None) -> int:
        """The time ``frames`` frames (of ``world``) after (negative: before) the frame at or before ``t_ns``."""
        times = self.frame_times(world)
        if not len(times):
            return t_ns
        i = int(np.searchsorted(times, t_ns, side="right")) - 1
        if frames > 0 or i < 0 or times[i] == t_ns or frames == 0:
            i += frames
        else:  # between two frames: one step back is the frame just before
            i += frames + 1
        return int(times[min(max(i, 0), len(times) - 1)])

    def clamp(self, t_ns: int) -> int:
        return min(max(int(t_ns), self.start_ns), self.end_ns)

    # ------------------------------------------------------------------ the frame
    def frame(self, t_ns: int, world: str | None = None) -> Frame:
        """Everything the page shows at ``t_ns``: of ``world`` only (its map and robots), or of
        the whole bag (None: a bag of one world)."""
        index = self.index
        state, decoded, positions = {}, {}, {}
        for topic, ti in index.by_topic.items():
            position = ti.at_or_before(t_ns)
            if position >= 0:
                state[topic], decoded[topic] = self._message(topic, position)
                positions[topic] = position
        robots = [self._robot_frame(r, state, decoded, t_ns) for r in self.robots_of(world)]
        joints: dict[str, list[tuple[str, float]]] = {}
        effectors: dict[str, tuple[float, ...]] = {}
        for arm in self.arms:
            msg = decoded.get(f"{arm}/joint_states")
            if msg is not None:
                joints[arm] = list(zip(msg.name, msg.position, strict=False))
            pose = decoded.get(f"{arm}/end_effector_pose")
            if pose is not None:
                p, o = pose.pose.position, pose.pose.orientation
                effectors[arm] = (p.x, p.y, p.z, o.x, o.y, o.z, o.w)
        arm_groups = [
            self._group(topic, positions[topic], decoded[topic])
            for topic in self.arm_marker_topics
            if decoded.get(topic) is not None
        ]
        commands = []
        for topic in self.command_topics:
            commanded = index.by_topic.get(topic)
            last = -1 if commanded is None else commanded.at_or_before(t_ns)
            for i in range(last, max(last - COMMANDS_SHOWN, -1), -1):
                m, msg = self._message(topic, i)
                commands.append(((m.log_time_ns - self.start_ns) / 1e9, topic, summary(m.type, msg)))
        commands.sort(key=lambda c: -c[0])
        # Age: how long before the instant shown the message came (never negative: at_or_before).
        latest = [
            (topic, (t_ns - m.log_time_ns) / 1e9, summary(m.type, decoded[topic])) for topic, m in sorted(state.items())
        ]
        create_map, extras = None, None
        markers = [t for t in state if basename(t) == spec.MAP_MARKERS_TOPIC and in_world(t, world)]
        if markers:
            create_map, extras = self._create_map(state[markers[0]], decoded[markers[0]])
        grids = [t for t, kind in index.topics.items() if kind == GRID and t in decoded and in_world(t, world)]
        outlines = [
            t for t in decoded if basename(t) == ROBOTS_TOPIC and index.topics[t] == MARKERS and in_world(t, world)
        ]
        return Frame(
            t_ns=t_ns,
            elapsed_s=(t_ns - self.start_ns) / 1e9,
            robots=robots,
            joints=joints,
            end_effectors=effectors,
            commands=commands[:COMMANDS_SHOWN],
            latest=latest,
            map=create_map,
            grid=decoded[grids[0]] if grids else None,
            outlines=decoded[outlines[0]] if outlines else None,
            map_extras=extras,
            arm_groups=arm_groups,
        )

    def _group(self, topic: str, position: int, msg) -> Group:
        """The meshes of a ``robot_markers`` (owner: the arm's namespace) or ``scene_markers`` (owner
        ``scene:<namespace>``) message, as the Arm page groups a live arm's; made once per message."""
        kept = self._groups.get(topic)
        if kept is None or kept[0] != position:
            look, poses = drawables(msg)
            ns = namespace(topic)
            owner = ns if basename(topic) == arm_spec.ROBOT_MARKERS_TOPIC else f"scene:{ns}"
            kept = self._groups[topic] = (position, Group(owner, tuple(look), poses, position))
        return kept[1]

    def _message(self, topic: str, position: int) -> tuple[BagMessage, Any]:
        """A topic's message and its decoded form (of the topic's type, hence ``Any``); the last
        DECODED_KEPT are kept, so a map, a robot description or a sensor that did not publish again
        is not decoded at every frame."""
        key = (topic, position)
        found = self._decoded.get(key)
        if found is None:
            m = self.index.message(topic, position)
            found = self._decoded[key] = (m, decode(m))
            if len(self._decoded) > DECODED_KEPT:
                self._decoded.popitem(last=False)
        else:
            self._decoded.move_to_end(key)
        return found

    def _create_map(self, m: BagMessage, msg) -> tuple[CreateMap | None, MarkerArray | None]:
        """The map a ``map_markers`` message holds, and its markers beyond the map's own (None: none)."""
        from studio.create.ros_client import map_from_markers

        key = f"{m.topic}@{m.log_time_ns}"
        if key not in self._maps and msg is not None:
            extras = [marker for marker in msg.markers if marker.ns not in MAP_NAMESPACES]
            self._maps[key] = (map_from_markers(msg), MarkerArray(markers=extras) if extras else None)
        return self._maps.get(key, (None, None))

    def _robot_frame(self, robot: Robot, state: dict, decoded: dict, t_ns: int) -> RobotFrame:
        rf = RobotFrame(robot)
        msg = decoded.get(robot.pose_topic)
        if msg is not None:
            rf.pose = planar(msg.pose.pose if robot.kind == "mobile" else msg.pose)
        odom = decoded.get(robot.topic("odom"))
        if odom is not None:
            rf.odom = planar(odom.pose.pose)
            rf.velocity = (odom.twist.twist.linear.x, odom.twist.twist.angular.z)
        n = int(np.searchsorted(robot.track_times, t_ns, side="right"))
        rf.track = robot.track[:n]
        crashed = decoded.get(robot.topic("crashed"))
        rf.crashed = bool(crashed is not None and getattr(crashed, "data", False))
        if robot.kind != "create":
            return rf
        scan = decoded.get(robot.topic(spec.SCAN_TOPIC))
        if scan is not None:
            rf.scan = (scan.angle_min, scan.angle_increment, np.asarray(scan.ranges, dtype=np.float32))
            rf.scan_stamp = scan.header.stamp.sec + 1e-9 * scan.header.stamp.nanosec
        for name in SONAR_NAMES:
            sonar = decoded.get(robot.topic(spec.sonar_topic(name)))
            if sonar is not None:
                rf.sonar[name] = sonar.range
        for name in CLIFF_NAMES:
            cliff = decoded.get(robot.topic(spec.cliff_topic(name)))
            if cliff is not None:
                rf.cliffs[name] = cliff.illuminance
        wall = decoded.get(robot.topic(spec.WALL_TOPIC))
        rf.wall = None if wall is None else wall.range == -math.inf
        left, right = (decoded.get(robot.topic(spec.bump_topic(side))) for side in spec.BUMP_SIDES)
        if left is not None and right is not None:
            rf.bumps = (left.range == -math.inf, right.range == -math.inf)
        camera = decoded.get(robot.topic(spec.CAMERA_BEACONS_TOPIC))
        if camera is not None:
            rf.sightings = [(mk.pose.position.x, mk.pose.position.y, mk.text) for mk in camera.markers]
        return rf
