"""The studio's Create side of ROS, on the studio's node (:class:`studio.shell.ros.StudioRos`),
the Create family's client (:class:`studio.create.family.CreateFamily`).

Like RViz it is only a client: it finds Create worlds by their ``overhead_pose`` topics (any
namespace, started by the studio or not) and talks to them through topics, services and
parameters. Callbacks run in the executor thread and only store the latest readings on a
:class:`RobotState`; the pages read those from NiceGUI's event loop (plain attribute reads).
Every ROS entity is created in the executor thread; the pages publish and call services.
"""

from __future__ import annotations

import math
import time
from collections import deque
from dataclasses import dataclass, field
from functools import partial

import numpy as np
from geometry_msgs.msg import PoseStamped, Twist
from nav_msgs.msg import Odometry
from rcl_interfaces.msg import ParameterType
from rcl_interfaces.srv import GetParameters, SetParameters
from rclpy.node import Node
from sensor_msgs.msg import Illuminance, LaserScan, Range
from std_srvs.srv import SetBool, Trigger
from visualization_msgs.msg import MarkerArray

from create_sim import spec
from create_sim.mapfile import CreateMap
from create_sim.spec import (
    BEACONS_NS,
    CLIFF_NAMES,
    LINES_NS,
    SONAR_NAMES,
    VIRTUAL_WALL_FIELDS_NS,
    WALLS_NS,
    virtual_wall_setting,
)
from sim_runtime.msgs import pose_msg, time_from_msg, yaw_from_quaternion
from sim_runtime.qos import ANY_PUBLISHER_QOS, COMMAND_PUBLISHER_QOS, COMMAND_SUBSCRIBER_QOS, LATCHED_QOS
from studio.shell.ros import StudioRos, new_worlds, node_full_name, parameter

try:  # built with the venv (interfaces/build_interfaces.py); without it Set position uses the topic
    from robot_sims_interfaces.srv import SetPose
except ImportError:  # pragma: no cover - only where no compiler built the package
    SetPose = None

POSE_TYPE = "geometry_msgs/msg/PoseStamped"
TRACK_POINTS = 2000
TRACK_MIN_STEP_M = 0.01


@dataclass
class RobotState:
    """Latest readings of one Create (namespace ``ns``, '' for the root), written by ROS callbacks."""

    ns: str
    node_name: str = ""  # the world node's full name, for its parameter services
    seq: int = 0  # bumped by every drawn reading: the view redraws when it changes
    map_seq: int = 0
    map: CreateMap = field(default_factory=CreateMap)
    pose: tuple[float, float, float] | None = None
    odom: tuple[float, float, float] | None = None
    velocity: tuple[float, float] = (0.0, 0.0)
    command: tuple[float, float] = (0.0, 0.0)  # the last cmd_vel (v, ω) anyone sent this world
    sim_time: float = 0.0
    rtf: float = float("nan")  # sim seconds per wall second, measured over the last seconds
    scan: tuple[float, float, np.ndarray] | None = None
    scan_stamp: float = 0.0
    scan_count: int = 0
    sonar: dict[str, float] = field(default_factory=dict)
    bumps: tuple[bool, bool] = (False, False)
    wall: bool = False
    virtual_wall: bool = False
    cliffs: dict[str, float] = field(default_factory=dict)
    sightings: list[tuple[float, float, str]] = field(default_factory=list)
    track: deque = field(default_factory=lambda: deque(maxlen=TRACK_POINTS))
    last_heard: float = 0.0  # wall time of the last message
    _rtf_ref: tuple[float, float] | None = None

    def topic(self, name: str) -> str:
        return f"{self.ns}/{name}"

    def _tick(self, stamp) -> None:
        now = time.monotonic()
        self.sim_time = time_from_msg(stamp)
        self.last_heard = now
        if self._rtf_ref is None or self.sim_time < self._rtf_ref[1]:
            self._rtf_ref = (now, self.sim_time)
        elif now - self._rtf_ref[0] >= 2.0:
            self.rtf = (self.sim_time - self._rtf_ref[1]) / (now - self._rtf_ref[0])
            self._rtf_ref = (now, self.sim_time)
        self.seq += 1


def map_from_markers(msg: MarkerArray) -> CreateMap:
    """The world's map rebuilt from its ``map_markers`` (walls, lines, beacons, virtual walls).

    Works with any world, local or not; a virtual wall's setting is the field whose length
    matches its triangle."""
    walls: list[tuple[float, float, float, float]] = []
    lines: list[tuple[float, float, float, float]] = []
    beacons: list[tuple[float, float, tuple[float, float, float], str]] = []
    vwalls: list[tuple[float, float, float, int]] = []
    for m in msg.markers:
        pts = [(p.x, p.y) for p in m.points]
        if m.ns in (WALLS_NS, LINES_NS):
            segs = [(*pts[i], *pts[i + 1]) for i in range(0, len(pts) - 1, 2)]
            (walls if m.ns == WALLS_NS else lines).extend(segs)
        elif m.ns == BEACONS_NS:
            beacons.append((m.pose.position.x, m.pose.position.y, (m.color.r, m.color.g, m.color.b), m.text))
        elif m.ns == VIRTUAL_WALL_FIELDS_NS and len(pts) >= 3:
            (ex, ey), (ax, ay), (bx, by) = pts[:3]
            theta = math.atan2((ay + by) / 2 - ey, (ax + bx) / 2 - ex)
            vwalls.append((ex, ey, theta, virtual_wall_setting(math.hypot(ax - ex, ay - ey))))
    return CreateMap(
        walls=np.array(walls, dtype=np.float64).reshape(-1, 4),
        lines=np.array(lines, dtype=np.float64).reshape(-1, 4),
        beacon_xy=np.array([b[:2] for b in beacons], dtype=np.float64).reshape(-1, 2),
        beacon_rgb=np.array([b[2] for b in beacons], dtype=np.float64).reshape(-1, 3),
        beacon_ids=[b[3] for b in beacons],
        virtwalls=np.array(vwalls, dtype=np.float64).reshape(-1, 4),
    )


class _Robot:
    """A RobotState plus the ROS entities that feed it and command it."""

    def __init__(self, node: Node, ns: str, node_name: str) -> None:
        self.state = RobotState(ns=ns, node_name=node_name, last_heard=time.monotonic())
        s = self.state
        sub, q = node.create_subscription, ANY_PUBLISHER_QOS
        self.subs = [
            sub(PoseStamped, s.topic(spec.OVERHEAD_POSE_TOPIC), self._on_pose, q),
            sub(Odometry, s.topic(spec.ODOM_TOPIC), self._on_odom, q),
            sub(LaserScan, s.topic(spec.SCAN_TOPIC), self._on_scan, q),
            sub(Range, s.topic(spec.WALL_TOPIC), self._on_wall, q),
            sub(Range, s.topic(spec.VIRTUAL_WALL_TOPIC), self._on_virtual_wall, q),
            *(
                sub(Range, s.topic(spec.bump_topic(side)), partial(self._on_bump, i), q)
                for i, side in enumerate(spec.BUMP_SIDES)
            ),
            sub(MarkerArray, s.topic(spec.CAMERA_BEACONS_TOPIC), self._on_camera, q),
            sub(MarkerArray, s.topic(spec.MAP_MARKERS_TOPIC), self._on_map, LATCHED_QOS),
        ]
        for name in SONAR_NAMES:
            self.subs.append(sub(Range, s.topic(spec.sonar_topic(name)), partial(self._on_sonar, name), q))
        for name in CLIFF_NAMES:
            self.subs.append(sub(Illuminance, s.topic(spec.cliff_topic(name)), partial(self._on_cliff, name), q))
        # Every tab, teleop and controller commands the same world: the speed steps start from
        # its last command, whoever sent it.
        # Reliable, as the world listens: a best-effort reader loses a one-shot command from a
        # publisher it has not matched yet (the world would hear a stop the label never shows).
        self.subs.append(sub(Twist, s.topic(spec.CMD_VEL_TOPIC), self._on_command, COMMAND_SUBSCRIBER_QOS))
        self.cmd_vel = node.create_publisher(Twist, s.topic(spec.CMD_VEL_TOPIC), COMMAND_PUBLISHER_QOS)
        self.set_pose = node.create_publisher(PoseStamped, s.topic(spec.SET_POSE_TOPIC), COMMAND_PUBLISHER_QOS)
        # The service answers with the reason a pose is refused (in a wall, ...); the topic cannot.
        self.set_pose_service = None if SetPose is None else node.create_client(SetPose, s.topic(spec.SET_POSE_SERVICE))
        self.reset = node.create_client(Trigger, s.topic("reset"))
        self.step = node.create_client(Trigger, s.topic("step"))
        self.buttons = [node.create_client(SetBool, s.topic(b)) for b in ("press_play", "press_advance")]
        self.set_params = node.create_client(SetParameters, f"{node_name}/set_parameters")
        self.get_params = node.create_client(GetParameters, f"{node_name}/get_parameters")

    def destroy(self, node: Node) -> None:
        for sub in self.subs:
            node.destroy_subscription(sub)
        for pub in (self.cmd_vel, self.set_pose):
            node.destroy_publisher(pub)
        for client in (self.reset, *self.buttons, self.set_params, self.get_params, self.set_pose_service):
            if client is not None:
                node.destroy_client(client)

    def _on_pose(self, msg: PoseStamped) -> None:
        s = self.state
        p = msg.pose.position
        s.pose = (p.x, p.y, yaw_from_quaternion(msg.pose.orientation))
        if not s.track or math.hypot(p.x - s.track[-1][0], p.y - s.track[-1][1]) >= TRACK_MIN_STEP_M:
            s.track.append((p.x, p.y))
        s._tick(msg.header.stamp)

    def _on_odom(self, msg: Odometry) -> None:
        p = msg.pose.pose
        self.state.odom = (p.position.x, p.position.y, yaw_from_quaternion(p.orientation))
        self.state.velocity = (msg.twist.twist.linear.x, msg.twist.twist.angular.z)

    def _on_command(self, msg: Twist) -> None:
        self.state.command = (msg.linear.x, msg.angular.z)

    def _on_scan(self, msg: LaserScan) -> None:
        s = self.state
        s.scan = (msg.angle_min, msg.angle_increment, np.asarray(msg.ranges, dtype=np.float32))
        s.scan_stamp = time_from_msg(msg.header.stamp)
        s.scan_count += 1
        s.seq += 1

    def _on_wall(self, msg: Range) -> None:
        self.state.wall = msg.range == -math.inf

    def _on_virtual_wall(self, msg: Range) -> None:
        self.state.virtual_wall = msg.range == -math.inf

    def _on_sonar(self, name: str, msg: Range) -> None:
        self.state.sonar[name] = msg.range

    def _on_cliff(self, name: str, msg: Illuminance) -> None:
        self.state.cliffs[name] = msg.illuminance

    def _on_bump(self, index: int, msg: Range) -> None:
        bumps = list(self.state.bumps)
        bumps[index] = msg.range == -math.inf
        self.state.bumps = (bumps[0], bumps[1])

    def _on_camera(self, msg: MarkerArray) -> None:
        self.state.sightings = [(m.pose.position.x, m.pose.position.y, m.text) for m in msg.markers]

    def _on_map(self, msg: MarkerArray) -> None:
        self.state.map = map_from_markers(msg)
        self.state.map_seq += 1
        self.state.seq += 1


class CreateRos:
    """The studio's ROS client for Create worlds, on the studio's node ``ros``; ``robots`` maps
    namespace → :class:`RobotState`."""

    def __init__(self, ros: StudioRos) -> None:
        self.ros = ros
        self.node = ros.node
        self._robots: dict[str, _Robot] = {}
        self.robots: dict[str, RobotState] = {}
        self.timer = ros.every(0.5, self._discover)

    def _discover(self) -> None:
        """Follow every namespace with a Create world (an ``overhead_pose`` PoseStamped topic);
        forget a world whose publisher has gone (stopped, or restarted under another node)."""
        now = time.monotonic()
        for ns, robot in list(self._robots.items()):
            if (
                self.node.count_publishers(robot.state.topic(spec.OVERHEAD_POSE_TOPIC)) == 0
                and now - robot.state.last_heard > 2.0
            ):
                print(f"studio: the world in {ns or '/'} has gone", flush=True)
                robot.destroy(self.node)
                del self._robots[ns]
                self.robots = {k: v for k, v in self.robots.items() if k != ns}
        for ns, info in new_worlds(self.node, spec.OVERHEAD_POSE_TOPIC, POSE_TYPE, self._robots):
            node_name = node_full_name(info)
            robot = _Robot(self.node, ns, node_name)
            print(f"studio: following the world in {ns or '/'} (node {node_name})", flush=True)
            self._robots[ns] = robot
            self.robots = {**self.robots, ns: robot.state}

    def namespaces(self) -> list[str]:
        return sorted(self.robots)

    # ---------------------------------------------------------------- commands (from the pages)
    def drive(self, ns: str, v: float, w: float) -> None:
        """Publish ``cmd_vel`` (m/s, rad/s) to the Create in ``ns``."""
        msg = Twist()
        msg.linear.x, msg.angular.z = float(v), float(w)
        robot = self._robots[ns]
        robot.state.command = (msg.linear.x, msg.angular.z)  # at once: the next key press builds on it
        robot.cmd_vel.publish(msg)

    async def set_pose(self, ns: str, x: float, y: float, theta: float) -> tuple[bool, str]:
        """Put the Create in ``ns`` at (x, y, theta) in the map: through its ``set_pose`` service,
        which says whether it did and why not; on the topic (no answer) where the world offers
        no service. Returns (accepted, what to tell the user)."""
        msg = PoseStamped()
        msg.header.frame_id = "map"
        msg.pose = pose_msg(x, y, theta)
        robot = self._robots[ns]
        service = robot.set_pose_service
        if service is not None and service.service_is_ready():
            response = await self.ros.call(service, SetPose.Request(pose=msg), timeout=5.0)
            return bool(response.success), str(response.message)
        robot.set_pose.publish(msg)
        return True, f"set_pose x={x:.2f} y={y:.2f} θ={theta:.2f} (on the topic: a refusal shows in the world's log)"

    async def reset(self, ns: str) -> str:
        response = await self.ros.call(self._robots[ns].reset, Trigger.Request())
        return response.message

    async def step(self, ns: str) -> tuple[bool, str]:
        """One physics step of a paused world: (done, the world's answer)."""
        response = await self.ros.call(self._robots[ns].step, Trigger.Request())
        return response.success, response.message

    async def press(self, ns: str, button: int, down: bool) -> str:
        response = await self.ros.call(self._robots[ns].buttons[button], SetBool.Request(data=down))
        return response.message

    async def set_parameters(self, ns: str, values: dict[str, bool | float | str | list[float]]) -> list[str]:
        """Set the world's parameters; the reasons of refused ones (empty when all were taken)."""
        request = SetParameters.Request(parameters=[parameter(k, v) for k, v in values.items()])
        response = await self.ros.call(self._robots[ns].set_params, request)
        return [
            f"{name}: {r.reason or 'refused'}"
            for name, r in zip(values, response.results, strict=True)
            if not r.successful
        ]

    async def get_parameter(self, ns: str, name: str):
        """A parameter of the world (python value), or None when it has none."""
        response = await self.ros.call(self._robots[ns].get_params, GetParameters.Request(names=[name]))
        if not response.values:
            return None
        v = response.values[0]
        return {
            ParameterType.PARAMETER_DOUBLE: v.double_value,
            ParameterType.PARAMETER_INTEGER: v.integer_value,
            ParameterType.PARAMETER_STRING: v.string_value,
            ParameterType.PARAMETER_BOOL: v.bool_value,
        }.get(v.type)
