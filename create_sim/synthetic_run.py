"""A Create run written straight into a bag, without ROS running: for tests and benchmarks of replay.

The pure :class:`~create_sim.model.CreateModel` drives a bump-and-turn pattern in a walled box at the
physics rate, and every topic a ``create_world`` publishes is written at the world's default rate with
the world's message types (log time = sim time, as the demos record), plus the controller's
``cmd_vel`` whenever it changes. A 10-minute run has ~400,000 messages, as a real recording.
"""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
from builtin_interfaces.msg import Time
from geometry_msgs.msg import PoseStamped, Twist
from nav_msgs.msg import Odometry
from rclpy.serialization import serialize_message
from rosgraph_msgs.msg import Clock
from sensor_msgs.msg import BatteryState, Illuminance, Joy, LaserScan, Range
from visualization_msgs.msg import Marker, MarkerArray

from create_sim.mapfile import CreateMap, parse_map
from create_sim.model import CreateModel
from create_sim.spec import CLIFF_NAMES, SONAR_NAMES
from create_sim.world_node import map_markers
from sim_runtime.bag.writer import BagWriter, qos_profiles_yaml
from sim_runtime.msgs import float32_array, pose_msg, set_planar_pose

PHYSICS_HZ = 100
RATES_HZ = {"state": 50, "sonar": 20, "scan": 10, "camera": 10, "buttons": 10, "battery": 1, "clock": 100}
"""The world's default publication rates (bumpers, cliffs, wall, odometry and pose share ``state``)."""
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


def _stamp(t_ns: int) -> Time:
    return Time(sec=t_ns // 1_000_000_000, nanosec=t_ns % 1_000_000_000)


def _detector(t_ns: int, frame: str, on: bool, kind: int = Range.INFRARED) -> Range:
    """A fixed-distance binary detector: -inf = detection, +inf = none."""
    msg = Range(radiation_type=kind, min_range=0.0, max_range=0.0, range=-math.inf if on else math.inf)
    msg.header.stamp, msg.header.frame_id = _stamp(t_ns), frame
    return msg


def write_create_run(
    folder: str | Path, duration_s: float, *, world: CreateMap | None = None, seed: int = 0, start_s: float = 0.0
) -> Path:
    """Write ``duration_s`` seconds of a Create run into the new bag folder ``folder``; returns it.

    The controller drives forward, and after a bump turns for a random 0.3–1.5 s (``seed``).
    ``start_s`` offsets every time (a bag need not start at zero)."""
    world = world if world is not None else parse_map(BOX_MAP, "box.map")
    model = CreateModel(world, pose=(-1.5, 0.0, 0.3))
    rng = np.random.default_rng(seed)
    latched = qos_profiles_yaml([{"history": "keep_last", "depth": 1, "durability": "transient_local"}])
    qos = qos_profiles_yaml([{}])
    topics = {
        "/map_markers": ("visualization_msgs/msg/MarkerArray", latched),
        "/cmd_vel": ("geometry_msgs/msg/Twist", qos),
        "/clock": ("rosgraph_msgs/msg/Clock", qos),
        "/odom": ("nav_msgs/msg/Odometry", qos),
        "/overhead_pose": ("geometry_msgs/msg/PoseStamped", qos),
        "/bump/left": ("sensor_msgs/msg/Range", qos),
        "/bump/right": ("sensor_msgs/msg/Range", qos),
        "/wall": ("sensor_msgs/msg/Range", qos),
        "/virtual_wall": ("sensor_msgs/msg/Range", qos),
        **{f"/cliff/{n}": ("sensor_msgs/msg/Illuminance", qos) for n in CLIFF_NAMES},
        **{f"/sonar/{n}": ("sensor_msgs/msg/Range", qos) for n in SONAR_NAMES},
        "/scan": ("sensor_msgs/msg/LaserScan", qos),
        "/camera/beacons": ("visualization_msgs/msg/MarkerArray", qos),
        "/buttons": ("sensor_msgs/msg/Joy", qos),
        "/battery_state": ("sensor_msgs/msg/BatteryState", qos),
    }
    step_ns = 1_000_000_000 // PHYSICS_HZ
    every = {name: PHYSICS_HZ // hz for name, hz in RATES_HZ.items()}
    t0 = round(start_s * 1e9)
    # Chunks close every half second of the run, as the recorder's flush interval does in real time.
    clock = {"now": 0.0}
    with BagWriter(folder, clock=lambda: clock["now"]) as bag:
        ids = {name: bag.add_topic(name, kind, q) for name, (kind, q) in topics.items()}

        def put(topic: str, t_ns: int, msg) -> None:
            bag.write(ids[topic], t_ns, serialize_message(msg))

        put("/map_markers", t0, map_markers(world, _stamp(t0)))
        command, turn_until = (FORWARD_M_S, 0.0), -1
        model.set_velocity(*command)
        put("/cmd_vel", t0, _twist(*command))
        for k in range(round(duration_s * PHYSICS_HZ) + 1):
            t_ns = t0 + k * step_ns
            clock["now"] = k / PHYSICS_HZ
            if k:
                model.step(1.0 / PHYSICS_HZ)
            if k % every["clock"] == 0:
                put("/clock", t_ns, Clock(clock=_stamp(t_ns)))
            if k % every["state"] == 0:
                bumps = model.bumps()
                if any(bumps) and k >= turn_until:  # the controller sees the bump: back off turning
                    turn_until = k + int(rng.uniform(0.3, 1.5) * PHYSICS_HZ)
                    command = (0.0, TURN_RAD_S if bumps[1] else -TURN_RAD_S)
                elif k >= turn_until and command[0] == 0.0:
                    command = (FORWARD_M_S, 0.0)
                if command != model.command:
                    model.set_velocity(*command)
                    put("/cmd_vel", t_ns, _twist(*command))
                _state_messages(put, model, t_ns, bumps)
            if k % every["sonar"] == 0:
                for name, value in zip(SONAR_NAMES, model.sonar().tolist(), strict=True):
                    msg = Range(radiation_type=Range.ULTRASOUND, min_range=0.02, max_range=3.0, range=value)
                    msg.header.stamp, msg.header.frame_id = _stamp(t_ns), f"sonar_{name}"
                    put(f"/sonar/{name}", t_ns, msg)
            if k % every["scan"] == 0:
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
                put("/scan", t_ns, msg)
            if k % every["camera"] == 0:
                markers = []
                for i, s in enumerate(model.camera()):
                    m = Marker(ns="beacons", id=i, type=Marker.SPHERE, text=s.id)
                    m.pose = pose_msg(s.distance * math.cos(s.angle), s.distance * math.sin(s.angle), 0.0)
                    markers.append(m)
                put("/camera/beacons", t_ns, MarkerArray(markers=markers))
            if k % every["buttons"] == 0:
                put("/buttons", t_ns, Joy(buttons=[0, 0]))
            if k % every["battery"] == 0:
                put("/battery_state", t_ns, BatteryState(voltage=CreateModel.BATTERY_VOLTAGE))
    return Path(folder)


def _twist(v: float, w: float) -> Twist:
    msg = Twist()
    msg.linear.x, msg.angular.z = float(v), float(w)
    return msg


def _state_messages(put, model: CreateModel, t_ns: int, bumps: tuple[bool, bool]) -> None:
    """The 50 Hz topics: odometry, ground truth, bumpers, wall, virtual wall, cliffs."""
    odom = Odometry(child_frame_id="base_link")
    odom.header.stamp, odom.header.frame_id = _stamp(t_ns), "odom"
    set_planar_pose(odom.pose.pose, *model.odometry_pose.tolist())
    odom.twist.twist.linear.x, odom.twist.twist.angular.z = model.velocity
    put("/odom", t_ns, odom)
    pose = PoseStamped()
    pose.header.stamp, pose.header.frame_id = _stamp(t_ns), "map"
    set_planar_pose(pose.pose, *model.pose.tolist())
    put("/overhead_pose", t_ns, pose)
    put("/bump/left", t_ns, _detector(t_ns, "bump_left", bumps[0], Range.INFRARED))
    put("/bump/right", t_ns, _detector(t_ns, "bump_right", bumps[1], Range.INFRARED))
    put("/wall", t_ns, _detector(t_ns, "wall_ir", model.wall_sensor()))
    put("/virtual_wall", t_ns, _detector(t_ns, "virtual_wall", model.virtual_wall()))
    for name, value in zip(CLIFF_NAMES, model.cliff_signals().tolist(), strict=True):
        msg = Illuminance(illuminance=value)
        msg.header.stamp, msg.header.frame_id = _stamp(t_ns), f"cliff_{name}"
        put(f"/cliff/{name}", t_ns, msg)
