"""A Create run written straight into a bag, without ROS running: for tests and benchmarks of replay.

The pure :class:`~create_sim.model.CreateModel` drives a bump-and-turn pattern in a walled box at the
physics rate, and every topic a ``create_world`` publishes is written at the world's default rate with
the world's message types (log time = sim time, as the demos record), plus the controller's
``cmd_vel`` whenever it changes. A 10-minute run has ~400,000 messages, as a real recording.

The per-step writing (:func:`bag_topics`, :func:`write_latched`, :func:`write_due`) is shared with
the learning environments' episode recorder (``sim_tools.rl.record``); with ``full=True`` a bag also
holds what a recorded ``create_world`` has beyond the sensors: ``/tf`` (``odom → base_link``),
``/tf_static``, ``/robot_description`` and the walls' occupancy grid on ``/map``.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Sequence
from functools import partial
from pathlib import Path
from typing import Protocol

import numpy as np
from builtin_interfaces.msg import Time
from geometry_msgs.msg import PoseStamped, Twist, Vector3
from nav_msgs.msg import Odometry
from rclpy.serialization import serialize_message
from rosgraph_msgs.msg import Clock
from sensor_msgs.msg import BatteryState, Illuminance, Joy, LaserScan, Range
from std_msgs.msg import String
from visualization_msgs.msg import Marker, MarkerArray

from create_sim import spec
from create_sim.geometry import rasterise_walls
from create_sim.mapfile import CreateMap, parse_map
from create_sim.model import BeaconSighting, CreateModel
from create_sim.spec import BEACONS_NS, CLIFF_NAMES, DEFAULT_RATES, PHYSICS_RATE, SONAR_NAMES
from create_sim.urdf import create_urdf
from create_sim.world_node import map_markers, sensor_transforms
from sim_runtime.bag.writer import BagWriter, qos_profiles_yaml
from sim_runtime.msgs import color_msg, float32_array, occupancy_grid_msg, pose_msg, set_planar_pose
from sim_runtime.tf import TFMessage, transform_msg

PHYSICS_HZ = round(PHYSICS_RATE)
STEP_NS = 1_000_000_000 // PHYSICS_HZ
RATES_HZ = {
    "state": DEFAULT_RATES["odom"],
    **{name: DEFAULT_RATES[name] for name in ("sonar", "scan", "camera", "buttons", "battery")},
    "clock": PHYSICS_RATE,
}
"""The world's default publication rates (bumpers, cliffs, wall, odometry and pose share ``state``)."""
EVERY = {name: round(PHYSICS_RATE / hz) for name, hz in RATES_HZ.items()}
"""Physics steps between two messages of each rate."""
BOX_MAP = """\
wall -2.5 2 2.5 2
wall 2.5 2 2.5 -2
wall 2.5 -2 -2.5 -2
wall -2.5 -2 -2.5 2
wall 0.8 -0.5 0.8 0.7
line -2 -1 1.5 -1
beacon 2 1.5 [1 0 0] b1
virtwall -2.3 1.8 -0.8 1
"""
FORWARD_M_S = 0.3
TURN_RAD_S = 1.5

MAP_RESOLUTION_M = 0.05  # create_world's default map_resolution

Put = Callable[[str, int, object], None]
"""Writes one message: topic, log time (ns), message."""


class Sensed(Protocol):
    """What the messages read from a Create: a :class:`CreateModel`, or a recorder's view of one."""

    @property
    def pose(self) -> np.ndarray: ...
    @property
    def odometry_pose(self) -> np.ndarray: ...
    @property
    def velocity(self) -> tuple[float, float]: ...
    def bumps(self) -> tuple[bool, bool]: ...
    def wall_sensor(self) -> bool: ...
    def virtual_wall(self) -> bool: ...
    def cliff_signals(self) -> np.ndarray: ...
    def sonar(self) -> np.ndarray: ...
    def lidar(self) -> np.ndarray: ...
    def camera(self) -> list[BeaconSighting]: ...


def _stamp(t_ns: int) -> Time:
    return Time(sec=t_ns // 1_000_000_000, nanosec=t_ns % 1_000_000_000)


def _detector(t_ns: int, frame: str, on: bool, kind: int = Range.INFRARED) -> Range:
    """A fixed-distance binary detector: -inf = detection, +inf = none."""
    msg = Range(radiation_type=kind, min_range=0.0, max_range=0.0, range=-math.inf if on else math.inf)
    msg.header.stamp, msg.header.frame_id = _stamp(t_ns), frame
    return msg


def world_topics(full: bool = False) -> dict[str, tuple[str, str]]:
    """Topic → (type, offered QoS) of everything a run writes (``full``: also TF, the robot
    description and the occupancy grid, when tf2_msgs is importable for the TF ones)."""
    latched = qos_profiles_yaml([{"history": "keep_last", "depth": 1, "durability": "transient_local"}])
    qos = qos_profiles_yaml([{}])
    extra = {
        "/robot_description": ("std_msgs/msg/String", latched),
        "/" + spec.MAP_TOPIC: ("nav_msgs/msg/OccupancyGrid", latched),
    }
    if TFMessage is not None:
        extra |= {"/tf": ("tf2_msgs/msg/TFMessage", qos), "/tf_static": ("tf2_msgs/msg/TFMessage", latched)}
    return {
        **(extra if full else {}),
        "/" + spec.MAP_MARKERS_TOPIC: ("visualization_msgs/msg/MarkerArray", latched),
        "/" + spec.CMD_VEL_TOPIC: ("geometry_msgs/msg/Twist", qos),
        "/clock": ("rosgraph_msgs/msg/Clock", qos),
        "/" + spec.ODOM_TOPIC: ("nav_msgs/msg/Odometry", qos),
        "/" + spec.OVERHEAD_POSE_TOPIC: ("geometry_msgs/msg/PoseStamped", qos),
        "/" + spec.bump_topic("left"): ("sensor_msgs/msg/Range", qos),
        "/" + spec.bump_topic("right"): ("sensor_msgs/msg/Range", qos),
        "/" + spec.WALL_TOPIC: ("sensor_msgs/msg/Range", qos),
        "/" + spec.VIRTUAL_WALL_TOPIC: ("sensor_msgs/msg/Range", qos),
        **{"/" + spec.cliff_topic(n): ("sensor_msgs/msg/Illuminance", qos) for n in CLIFF_NAMES},
        **{"/" + spec.sonar_topic(n): ("sensor_msgs/msg/Range", qos) for n in SONAR_NAMES},
        "/" + spec.SCAN_TOPIC: ("sensor_msgs/msg/LaserScan", qos),
        "/" + spec.CAMERA_BEACONS_TOPIC: ("visualization_msgs/msg/MarkerArray", qos),
        "/" + spec.BUTTONS_TOPIC: ("sensor_msgs/msg/Joy", qos),
        "/" + spec.BATTERY_TOPIC: ("sensor_msgs/msg/BatteryState", qos),
    }


class _BumpTurn:
    """The run's controller: forward, and after a bump a turn for a random 0.3–1.5 s."""

    def __init__(self, rng: np.random.Generator) -> None:
        self.rng = rng
        self.command = (FORWARD_M_S, 0.0)
        self.turn_until = -1  # physics step the current turn ends at

    def update(self, bumps: tuple[bool, bool], k: int) -> tuple[float, float]:
        """The command after step ``k``'s bumper reading."""
        if any(bumps) and k >= self.turn_until:  # the controller sees the bump: back off turning
            self.turn_until = k + int(self.rng.uniform(0.3, 1.5) * PHYSICS_HZ)
            self.command = (0.0, TURN_RAD_S if bumps[1] else -TURN_RAD_S)
        elif k >= self.turn_until and self.command[0] == 0.0:
            self.command = (FORWARD_M_S, 0.0)
        return self.command


def write_create_run(
    folder: str | Path, duration_s: float, *, world: CreateMap | None = None, seed: int = 0, start_s: float = 0.0
) -> Path:
    """Write ``duration_s`` seconds of a Create run into the new bag folder ``folder``; returns it.

    The controller drives forward, and after a bump turns for a random 0.3–1.5 s (``seed``).
    ``start_s`` offsets every time (a bag need not start at zero)."""
    world = world if world is not None else parse_map(BOX_MAP, "box.map")
    model = CreateModel(world, pose=(-1.5, 0.0, 0.3))
    controller = _BumpTurn(np.random.default_rng(seed))
    t0 = round(start_s * 1e9)
    # Chunks close every half second of the run, as the recorder's flush interval does in real time.
    clock = {"now": 0.0}
    with BagWriter(folder, clock=lambda: clock["now"]) as bag:
        put = bag_topics(bag)
        write_latched(put, world, t0)
        model.set_velocity(*controller.command)
        put("/" + spec.CMD_VEL_TOPIC, t0, twist_msg(*controller.command))
        for k in range(round(duration_s * PHYSICS_HZ) + 1):
            clock["now"] = k / PHYSICS_HZ
            if k:
                model.step(1.0 / PHYSICS_HZ)
            t_ns = t0 + k * STEP_NS
            write_due(put, model, k, t_ns, on_state=partial(_drive, put, model, controller, k=k, t_ns=t_ns))
    return Path(folder)


def _drive(put: Put, model: CreateModel, controller: _BumpTurn, bumps: tuple[bool, bool], k: int, t_ns: int) -> None:
    """The controller's turn at a bumper reading: a new command is sent (and taken) at once."""
    command = controller.update(bumps, k)
    if command != model.command:
        model.set_velocity(*command)
        put("/" + spec.CMD_VEL_TOPIC, t_ns, twist_msg(*command))


def bag_topics(bag: BagWriter, *, full: bool = False) -> Put:
    """Add a world's topics (:func:`world_topics`) to ``bag``; the function writing a message on one."""
    ids = {name: bag.add_topic(name, kind, q) for name, (kind, q) in world_topics(full).items()}

    def put(topic: str, t_ns: int, msg: object) -> None:
        bag.write(ids[topic], t_ns, serialize_message(msg))

    return put


def write_latched(
    put: Put, world: CreateMap, t_ns: int, *, full: bool = False, extra_markers: Sequence[Marker] = ()
) -> None:
    """What a world publishes once at start: its map's markers (and ``extra_markers`` with them);
    ``full``: also the sensor mounts, the robot description and the occupancy grid."""
    markers = map_markers(world, _stamp(t_ns))
    markers.markers.extend(extra_markers)
    put("/" + spec.MAP_MARKERS_TOPIC, t_ns, markers)
    if not full:
        return
    if TFMessage is not None:
        transforms = sensor_transforms("")
        for t in transforms:
            t.header.stamp = _stamp(t_ns)
        put("/tf_static", t_ns, TFMessage(transforms=transforms))
    put("/robot_description", t_ns, String(data=create_urdf("")))
    raster = rasterise_walls(world.walls, MAP_RESOLUTION_M)
    origin = (raster.origin_x_m, raster.origin_y_m)
    put("/" + spec.MAP_TOPIC, t_ns, occupancy_grid_msg(raster.occupied, raster.resolution_m, origin, _stamp(t_ns)))


def write_due(
    put: Put,
    model: Sensed,
    k: int,
    t_ns: int,
    *,
    full: bool = False,
    on_state: Callable[[tuple[bool, bool]], None] | None = None,
) -> None:
    """Everything due at physics step ``k`` (at log time ``t_ns``), in the world's order; ``on_state``
    sees the bumpers first at each state tick (a controller's turn); ``full``: ``/tf`` too."""
    if k % EVERY["clock"] == 0:
        put("/clock", t_ns, Clock(clock=_stamp(t_ns)))
    if k % EVERY["state"] == 0:
        bumps = model.bumps()
        if on_state is not None:
            on_state(bumps)
        _state_messages(put, model, t_ns, bumps)
        if full and TFMessage is not None:
            put("/tf", t_ns, _odom_tf(model, t_ns))
    if k % EVERY["sonar"] == 0:
        _sonar_messages(put, model, t_ns)
    if k % EVERY["scan"] == 0:
        put("/" + spec.SCAN_TOPIC, t_ns, _scan(model, t_ns))
    if k % EVERY["camera"] == 0:
        put("/" + spec.CAMERA_BEACONS_TOPIC, t_ns, _camera(model, t_ns))
    if k % EVERY["buttons"] == 0:
        put("/" + spec.BUTTONS_TOPIC, t_ns, Joy(buttons=[0, 0]))
    if k % EVERY["battery"] == 0:
        put("/" + spec.BATTERY_TOPIC, t_ns, BatteryState(voltage=CreateModel.BATTERY_VOLTAGE))


def _odom_tf(model: Sensed, t_ns: int) -> object:
    """``odom → base_link`` at the odometry pose, as the world sends it with each odometry."""
    x, y, theta = model.odometry_pose.tolist()
    t = transform_msg("odom", "base_link", x, y, yaw=theta)
    t.header.stamp = _stamp(t_ns)
    return TFMessage(transforms=[t])


def _sonar_messages(put: Put, model: Sensed, t_ns: int) -> None:
    lo, hi = CreateModel.SONAR_RANGE
    for name, value in zip(SONAR_NAMES, model.sonar().tolist(), strict=True):
        msg = Range(radiation_type=Range.ULTRASOUND, min_range=lo, max_range=hi, range=value)
        msg.header.stamp, msg.header.frame_id = _stamp(t_ns), f"sonar_{name}"
        put("/" + spec.sonar_topic(name), t_ns, msg)


def _scan(model: Sensed, t_ns: int) -> LaserScan:
    lo, hi = CreateModel.LIDAR_RANGE
    msg = LaserScan(
        angle_min=-CreateModel.LIDAR_FOV / 2,
        angle_max=CreateModel.LIDAR_FOV / 2,
        angle_increment=CreateModel.LIDAR_FOV / (CreateModel.LIDAR_BEAMS - 1),
        range_min=lo,
        range_max=hi,
        ranges=float32_array(model.lidar()),
    )
    msg.header.stamp, msg.header.frame_id = _stamp(t_ns), "laser"
    return msg


def _camera(model: Sensed, t_ns: int) -> MarkerArray:
    """The beacons in sight, in the ``camera`` frame, as the world draws them."""
    markers = []
    for i, s in enumerate(model.camera()):
        m = Marker(ns=BEACONS_NS, id=i, type=Marker.SPHERE, text=s.id, scale=Vector3(x=0.1, y=0.1, z=0.1))
        m.pose = pose_msg(s.distance * math.cos(s.angle), s.distance * math.sin(s.angle), 0.0)
        m.color = color_msg(*s.rgb)
        m.header.stamp, m.header.frame_id = _stamp(t_ns), "camera"
        markers.append(m)
    return MarkerArray(markers=markers)


def twist_msg(v: float, w: float) -> Twist:
    """A ``cmd_vel`` message."""
    msg = Twist()
    msg.linear.x, msg.angular.z = float(v), float(w)
    return msg


def _state_messages(put: Put, model: Sensed, t_ns: int, bumps: tuple[bool, bool]) -> None:
    """The 50 Hz topics: odometry, ground truth, bumpers, wall, virtual wall, cliffs."""
    odom = Odometry(child_frame_id="base_link")
    odom.header.stamp, odom.header.frame_id = _stamp(t_ns), "odom"
    set_planar_pose(odom.pose.pose, *model.odometry_pose.tolist())
    odom.twist.twist.linear.x, odom.twist.twist.angular.z = model.velocity
    put("/" + spec.ODOM_TOPIC, t_ns, odom)
    pose = PoseStamped()
    pose.header.stamp, pose.header.frame_id = _stamp(t_ns), "map"
    set_planar_pose(pose.pose, *model.pose.tolist())
    put("/" + spec.OVERHEAD_POSE_TOPIC, t_ns, pose)
    put("/" + spec.bump_topic("left"), t_ns, _detector(t_ns, "bump_left", bumps[0], Range.INFRARED))
    put("/" + spec.bump_topic("right"), t_ns, _detector(t_ns, "bump_right", bumps[1], Range.INFRARED))
    put("/" + spec.WALL_TOPIC, t_ns, _detector(t_ns, "wall_ir", model.wall_sensor()))
    put("/" + spec.VIRTUAL_WALL_TOPIC, t_ns, _detector(t_ns, "virtual_wall_ir", model.virtual_wall()))
    for name, value in zip(CLIFF_NAMES, model.cliff_signals().tolist(), strict=True):
        msg = Illuminance(illuminance=value)
        msg.header.stamp, msg.header.frame_id = _stamp(t_ns), f"cliff_{name}"
        put("/" + spec.cliff_topic(name), t_ns, msg)
