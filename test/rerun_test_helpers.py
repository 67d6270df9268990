"""Helpers for the Rerun tests: write small rosbag2-style MCAP bags, read entities back from .rrd."""

from __future__ import annotations

import math
import struct
from dataclasses import dataclass
from pathlib import Path

import numpy as np
import pyarrow as pa
import rerun.chunk as rrc
import yaml
from builtin_interfaces.msg import Time
from geometry_msgs.msg import Point, PoseStamped, Quaternion
from mcap.writer import Writer
from nav_msgs.msg import OccupancyGrid, Odometry
from rclpy.serialization import serialize_message
from rosgraph_msgs.msg import Clock
from sensor_msgs.msg import Illuminance, JointState, LaserScan, Range
from visualization_msgs.msg import Marker, MarkerArray

from sim_tools.rerun_kit.ros import type_name
from simrobot_sim.world_file import DEFAULT_SHAPE

NS = 1_000_000_000


def stamp(t: float) -> Time:
    ns = int(round(t * NS))
    return Time(sec=ns // NS, nanosec=ns % NS)


@dataclass
class Raw:
    """A message given as its type name and CDR bytes (a type whose package may not be installed)."""

    type: str
    data: bytes


def write_bag(path: Path, messages: list[tuple[str, object, float]]) -> Path:
    """A minimal rosbag2-style MCAP (ros2 profile, cdr) holding ``(topic, msg, t)``, t in seconds."""
    with path.open("wb") as f:
        writer = Writer(f)
        writer.start(profile="ros2", library="test")
        channels: dict[str, int] = {}
        for topic, msg, t in messages:
            if topic not in channels:
                kind = msg.type if isinstance(msg, Raw) else type_name(msg)
                schema = writer.register_schema(name=kind, encoding="ros2msg", data=b"")
                channels[topic] = writer.register_channel(topic=topic, message_encoding="cdr", schema_id=schema)
            ns = int(round(t * NS))
            data = msg.data if isinstance(msg, Raw) else serialize_message(msg)
            writer.add_message(channels[topic], log_time=ns, data=data, publish_time=ns)
        writer.finish()
    return path


def tf_message(transforms: list[tuple[str, str, float, float, float, float]], t: float = 0.0) -> Raw:
    """A tf2_msgs/TFMessage as CDR bytes (little endian), written by hand so that tests do not
    need tf2_msgs: transforms are (parent, child, x, y, z, yaw)."""
    out = bytearray(b"\x00\x01\x00\x00")

    def align(n: int) -> None:
        out.extend(b"\x00" * (-(len(out) - 4) % n))

    def string(text: str) -> None:
        align(4)
        data = text.encode() + b"\x00"
        out.extend(struct.pack("<I", len(data)) + data)

    align(4)
    out.extend(struct.pack("<I", len(transforms)))
    ns = int(round(t * NS))
    for parent, child, x, y, z, yaw in transforms:
        align(4)
        out.extend(struct.pack("<iI", ns // NS, ns % NS))
        string(parent)
        string(child)
        align(8)
        out.extend(struct.pack("<3d", x, y, z))
        out.extend(struct.pack("<4d", 0.0, 0.0, math.sin(yaw / 2), math.cos(yaw / 2)))
    return Raw("tf2_msgs/msg/TFMessage", bytes(out))


def blueprint_views(rrd: Path) -> list[dict]:
    """The views of the blueprint stored in ``rrd``: class, name, origin and their properties."""
    reader = rrc.RrdReader(rrd)
    views: dict[str, dict] = {}
    for store in reader.blueprints():
        for chunk in reader.stream(store=store).to_chunks():
            path = str(chunk.entity_path)
            if not path.startswith("/view/"):
                continue
            view = views.setdefault(path.split("/")[2], {})
            batch = chunk.to_record_batch()
            for name in batch.schema.names:
                if ":" in name:
                    values = [v for v in batch.column(name).to_pylist() if v is not None]
                    if values:
                        view[name] = values[-1]
    return list(views.values())


def world_file_colors(world_file: Path) -> dict[str, tuple[int, int, int]]:
    """Robot name → its colour in a SIMROBOT world file, as rgb 0-255."""
    spec = yaml.safe_load(world_file.read_text())
    return {r["name"]: tuple(round(255 * c) for c in r["color"]) for r in spec["robots"]}


def load_entities(rrd: Path) -> dict[str, list[pa.RecordBatch]]:
    """entity path → record batches of its chunks."""
    out: dict[str, list[pa.RecordBatch]] = {}
    for chunk in rrc.RrdReader(rrd).stream().to_chunks():
        out.setdefault(str(chunk.entity_path), []).append(chunk.to_record_batch())
    return out


def column(batches: list[pa.RecordBatch], name: str) -> list:
    values: list = []
    for b in batches:
        if name in b.schema.names:
            values += b.column(name).to_pylist()
    return values


def quat(yaw: float) -> Quaternion:
    return Quaternion(z=math.sin(yaw / 2), w=math.cos(yaw / 2))


def create_messages(steps: int = 50, ns: str = "") -> list[tuple[str, object, float]]:
    """A Create driving a quarter circle: map markers, overhead pose, odom, scan, sonar, bump, cliff."""
    pre = f"/{ns}" if ns else ""
    fp = f"{ns}/" if ns else ""
    walls = Marker(
        ns="walls",
        id=0,
        type=Marker.LINE_LIST,
        action=Marker.ADD,
        points=[Point(x=-2.0, y=-2.0), Point(x=2.0, y=-2.0), Point(x=2.0, y=-2.0), Point(x=2.0, y=2.0)],
    )
    walls.header.frame_id = "map"
    walls.scale.x = 0.03
    walls.color.a = 1.0
    beacon = Marker(ns="beacons", id=0, type=Marker.SPHERE, action=Marker.ADD, text="7")
    beacon.header.frame_id = "map"
    beacon.pose.position.x, beacon.pose.position.y = 1.5, 1.0
    beacon.scale.x = beacon.scale.y = beacon.scale.z = 0.1
    beacon.color.r, beacon.color.a = 1.0, 1.0
    msgs: list[tuple[str, object, float]] = [(f"{pre}/map_markers", MarkerArray(markers=[walls, beacon]), 0.0)]
    for k in range(steps):
        t = 0.02 * k
        yaw = 0.5 * math.pi * k / steps
        x, y = math.sin(yaw), 1.0 - math.cos(yaw)
        msgs.append(("/clock", Clock(clock=stamp(t)), t))
        pose = PoseStamped()
        pose.header.stamp, pose.header.frame_id = stamp(t), "map"
        pose.pose.position.x, pose.pose.position.y = x, y
        pose.pose.orientation = quat(yaw)
        msgs.append((f"{pre}/overhead_pose", pose, t))
        odom = Odometry(child_frame_id=f"{fp}base_link")
        odom.header.stamp, odom.header.frame_id = stamp(t), "odom"
        odom.pose.pose.position.x, odom.pose.pose.position.y = 1.02 * x, 1.02 * y  # 2 % scale error
        odom.pose.pose.orientation = quat(yaw)
        msgs.append((f"{pre}/odom", odom, t))
        if k % 5 == 0:
            scan = LaserScan(
                angle_min=-2 * math.pi / 3,
                angle_max=2 * math.pi / 3,
                angle_increment=4 * math.pi / 3 / 680,
                range_min=0.02,
                range_max=4.0,
            )
            scan.header.stamp, scan.header.frame_id = stamp(t), f"{fp}laser"
            ranges = np.full(681, 2.0, dtype=np.float32)
            ranges[:100] = np.inf  # no return
            scan.ranges = ranges.tolist()
            msgs.append((f"{pre}/scan", scan, t))
            sonar = Range(radiation_type=Range.ULTRASOUND, min_range=0.02, max_range=3.0, range=1.25)
            sonar.header.stamp, sonar.header.frame_id = stamp(t), f"{fp}sonar_front"
            msgs.append((f"{pre}/sonar/front", sonar, t))
        bump = Range(
            radiation_type=Range.INFRARED, min_range=0.0, max_range=0.0, range=-math.inf if 20 <= k < 30 else math.inf
        )
        bump.header.stamp, bump.header.frame_id = stamp(t), f"{fp}bump_left"
        msgs.append((f"{pre}/bump/left", bump, t))
        cliff = Illuminance(illuminance=1.5 if k == 40 else 21.5)
        cliff.header.stamp, cliff.header.frame_id = stamp(t), f"{fp}cliff_left"
        msgs.append((f"{pre}/cliff/left", cliff, t))
    return msgs


def arm_messages(stl: Path, steps: int = 10) -> list[tuple[str, object, float]]:
    msgs: list[tuple[str, object, float]] = []
    for k in range(steps):
        t = 0.1 * k
        js = JointState(name=["q1", "q2"], position=[0.1 * k, -0.05 * k], velocity=[1.0, -0.5], effort=[])
        js.header.stamp = stamp(t)
        link = Marker(ns="links", id=1, type=Marker.MESH_RESOURCE, action=Marker.ADD, mesh_resource=f"file://{stl}")
        link.header.frame_id, link.header.stamp = "world", stamp(t)
        link.pose.position.z = 0.3
        link.pose.orientation = quat(0.1 * k)
        link.scale.x = link.scale.y = link.scale.z = 1.0
        link.color.g, link.color.a = 0.8, 1.0
        msgs += [("/joint_states", js, t), ("/robot_markers", MarkerArray(markers=[link]), t)]
    return msgs


def simrobot_messages() -> list[tuple[str, object, float]]:
    grid = OccupancyGrid()
    grid.header.frame_id = "map"
    grid.info.resolution, grid.info.width, grid.info.height = 0.1, 20, 10
    grid.info.origin.position.x = -1.0
    cells = np.zeros((10, 20), dtype=np.int8)
    cells[:, 0] = 100  # a wall along the left edge, 10 cells
    cells[4:7, 10:13] = 100  # a 3x3 block: 8 border cells, 1 interior
    grid.data = cells.ravel().tolist()
    msgs: list[tuple[str, object, float]] = [("/map", grid, 0.0)]
    for k in range(5):
        pose = PoseStamped()
        pose.header.stamp, pose.header.frame_id = stamp(float(k)), "map"
        pose.pose.position.x = 0.1 * k
        pose.pose.orientation.w = 1.0
        msgs.append(("/r1/pose", pose, float(k)))
    return msgs


def robots_outlines(robots: list[tuple[float, float, tuple[float, float, float]]]) -> MarkerArray:
    """SIMROBOT's ``/robots``: robot i at (x, y) in colour rgb 0-1 as LINE_STRIP marker id i, its
    points the default shape placed on the map."""
    out = MarkerArray()
    for i, (x, y, rgb) in enumerate(robots):
        m = Marker(ns="robots", id=i, type=Marker.LINE_STRIP, action=Marker.ADD)
        m.header.frame_id = "map"
        m.scale.x = 0.01
        m.color.r, m.color.g, m.color.b, m.color.a = (*rgb, 1.0)
        shape = [*DEFAULT_SHAPE, DEFAULT_SHAPE[0]]
        m.points = [Point(x=x + px, y=y + py) for px, py in shape]
        out.markers.append(m)
    return out


def packed(rgb: tuple[int, int, int]) -> int:
    """An rgb colour as Rerun stores it (0xRRGGBBAA)."""
    return (rgb[0] << 24) | (rgb[1] << 16) | (rgb[2] << 8) | 0xFF
