"""The arm page's ROS side: finds every arm on the domain and keeps its latest state.

Like RViz it is only a client of ``robot_sims arm`` (or anything with the same topics): an arm is
a namespace with an ``end_effector_pose`` PoseStamped topic. Per arm it reads ``joint_states``,
``robot_markers`` (what to draw: mesh URI, colour, scale, and each element's pose),
``end_effector_pose`` and the latched ``robot_description`` (joint limits); per world node the
latched ``scene_markers``; and ``/rosout``, where the arm node says that a target pose is
unreachable. It publishes ``joint_command``, ``target_pose`` and ``joint_trajectory``.

It is the arm family's client (:class:`studio.arm.family.ArmFamily`), on the studio's node and
executor (:class:`studio.shell.ros.StudioRos`): subscriptions are made by its discovery timer, in
the executor thread; callbacks only replace attributes of an
:class:`ArmState`, which the page reads from NiceGUI's event loop.
"""

from __future__ import annotations

import math
import time
import xml.etree.ElementTree as ET
from dataclasses import dataclass, field

import numpy as np
from builtin_interfaces.msg import Duration
from geometry_msgs.msg import PoseStamped
from rcl_interfaces.msg import Log
from rclpy.qos import DurabilityPolicy, QoSProfile, ReliabilityPolicy
from sensor_msgs.msg import JointState
from std_msgs.msg import String
from trajectory_msgs.msg import JointTrajectory, JointTrajectoryPoint
from visualization_msgs.msg import Marker, MarkerArray

from arm_sim.robot_config import transform_from_xyz_rpy
from arm_sim.spec import END_EFFECTOR_POSE_TOPIC, JOINT_STATES_TOPIC, ROBOT_MARKERS_TOPIC
from arm_sim.urdf import rpy_from_matrix
from sim_runtime.msgs import matrix_from_quaternion, quaternion_from_matrix
from sim_runtime.qos import ANY_PUBLISHER_QOS, COMMAND_PUBLISHER_QOS, LATCHED_QOS
from studio.shell.ros import StudioRos, new_worlds, node_full_name

POSE_TYPE = "geometry_msgs/msg/PoseStamped"
UNREACHABLE = "target_pose unreachable"
"""What the arm node logs (prefixed by the arm's topic prefix) when IK finds no solution."""
ROSOUT_QOS = QoSProfile(depth=50, reliability=ReliabilityPolicy.RELIABLE, durability=DurabilityPolicy.VOLATILE)


@dataclass(frozen=True)
class JointLimit:
    lower: float
    upper: float
    prismatic: bool


def joint_limits(urdf: str) -> dict[str, JointLimit]:
    """Position limits of the moving joints of a URDF (metres or radians); continuous joints get ±π."""
    limits = {}
    for joint in ET.fromstring(urdf).iter("joint"):
        kind = joint.get("type")
        if kind not in ("revolute", "prismatic", "continuous"):
            continue
        limit = joint.find("limit")
        if kind == "continuous" or limit is None:
            lower, upper = -math.pi, math.pi
        else:
            lower, upper = float(limit.get("lower", "0")), float(limit.get("upper", "0"))
        limits[joint.get("name", "")] = JointLimit(lower, upper, kind == "prismatic")
    return limits


@dataclass(frozen=True)
class Drawable:
    """One mesh (or placeholder cube) of an arm or of the scene, as its marker describes it."""

    key: str  # marker namespace/id: stable while the world runs
    mesh_uri: str  # '' for a placeholder cube
    rgba: tuple[float, float, float, float]
    scale: tuple[float, float, float]


def drawables(msg: MarkerArray) -> tuple[list[Drawable], np.ndarray]:
    """The mesh and cube markers of ``msg`` and their poses (m, 7: x y z qx qy qz qw)."""
    items, poses = [], []
    for m in msg.markers:
        if m.type not in (Marker.MESH_RESOURCE, Marker.CUBE) or m.action != Marker.ADD:
            continue
        items.append(
            Drawable(
                key=f"{m.ns}/{m.id}",
                mesh_uri=m.mesh_resource if m.type == Marker.MESH_RESOURCE else "",
                rgba=(m.color.r, m.color.g, m.color.b, m.color.a),
                scale=(m.scale.x, m.scale.y, m.scale.z),
            )
        )
        p, o = m.pose.position, m.pose.orientation
        poses.append((p.x, p.y, p.z, o.x, o.y, o.z, o.w))
    return items, np.array(poses, dtype=np.float64).reshape(-1, 7)


@dataclass(frozen=True)
class Group:
    """What one owner (an arm's prefix, or ``scene:<world namespace>``) has drawn at an instant."""

    owner: str
    look: tuple[Drawable, ...]
    poses: np.ndarray  # (len(look), 7): x y z qx qy qz qw
    seq: int  # changes whenever the poses do: an unchanged group is not sent again


def pose_xyz_rpy(msg_pose) -> tuple[float, float, float, float, float, float]:
    """x, y, z (m), roll, pitch, yaw (rad, fixed axes X Y Z) of a geometry_msgs Pose."""
    p = msg_pose.position
    return (p.x, p.y, p.z, *rpy_from_matrix(matrix_from_quaternion(msg_pose.orientation)))


@dataclass
class ArmState:
    """Latest readings of one arm (topic prefix ``prefix``, '' for the root), written by callbacks."""

    prefix: str
    node_name: str  # the world node's full name
    relative_prefix: str  # the prefix inside the world node ('' or 'csa/'): how its log lines start
    world_ns: str  # the world node's namespace: where its scene_markers are
    frame_id: str = ""
    joint_names: tuple[str, ...] = ()
    positions: np.ndarray | None = None
    velocities: np.ndarray | None = None
    limits: dict[str, JointLimit] = field(default_factory=dict)
    look: tuple[Drawable, ...] = ()  # what to draw (changes when e.g. marker_alpha changes)
    poses: np.ndarray = field(default_factory=lambda: np.zeros((0, 7)))
    seq: int = 0  # bumped by every marker message
    end_effector: tuple[float, ...] | None = None  # x y z roll pitch yaw
    end_effector_quat: tuple[float, float, float, float] | None = None
    unreachable_at: float = -math.inf  # monotonic time of the world's last "unreachable" for this arm
    unreachable_text: str = ""
    last_heard: float = 0.0

    def topic(self, name: str) -> str:
        return f"{self.prefix}/{name}"

    @property
    def label(self) -> str:
        return self.prefix or "/"

    def moving(self, tolerance: float = 1e-6) -> bool:
        v = self.velocities
        return v is not None and bool(np.any(np.abs(v) > tolerance))


@dataclass
class SceneState:
    """A world node's scene objects (from its latched ``scene_markers``)."""

    look: tuple[Drawable, ...] = ()
    poses: np.ndarray = field(default_factory=lambda: np.zeros((0, 7)))
    seq: int = 0


class _Arm:
    def __init__(self, node, state: ArmState) -> None:
        self.state = s = state
        q = ANY_PUBLISHER_QOS
        self.subs = [
            node.create_subscription(JointState, s.topic(JOINT_STATES_TOPIC), self._on_joints, q),
            node.create_subscription(MarkerArray, s.topic(ROBOT_MARKERS_TOPIC), self._on_markers, q),
            node.create_subscription(PoseStamped, s.topic(END_EFFECTOR_POSE_TOPIC), self._on_pose, q),
            node.create_subscription(String, s.topic("robot_description"), self._on_description, LATCHED_QOS),
        ]
        self.joint_command = node.create_publisher(JointState, s.topic("joint_command"), COMMAND_PUBLISHER_QOS)
        self.target_pose = node.create_publisher(PoseStamped, s.topic("target_pose"), COMMAND_PUBLISHER_QOS)
        self.trajectory = node.create_publisher(JointTrajectory, s.topic("joint_trajectory"), COMMAND_PUBLISHER_QOS)

    def destroy(self, node) -> None:
        for sub in self.subs:
            node.destroy_subscription(sub)
        for pub in (self.joint_command, self.target_pose, self.trajectory):
            node.destroy_publisher(pub)

    def _on_joints(self, msg: JointState) -> None:
        s = self.state
        s.last_heard = time.monotonic()
        if tuple(msg.name) != s.joint_names:
            s.joint_names = tuple(msg.name)
        s.frame_id = msg.header.frame_id
        s.velocities = np.array(msg.velocity, dtype=float)
        s.positions = np.array(msg.position, dtype=float)

    def _on_markers(self, msg: MarkerArray) -> None:
        s = self.state
        items, poses = drawables(msg)
        look = tuple(items)
        if look != s.look:
            s.look = look
        s.poses = poses
        s.seq += 1

    def _on_pose(self, msg: PoseStamped) -> None:
        s = self.state
        o = msg.pose.orientation
        s.end_effector_quat = (o.x, o.y, o.z, o.w)
        s.end_effector = pose_xyz_rpy(msg.pose)

    def _on_description(self, msg: String) -> None:
        try:
            self.state.limits = joint_limits(msg.data)
        except (ET.ParseError, ValueError) as err:
            print(f"studio: {self.state.topic('robot_description')} is not a URDF I can read: {err}", flush=True)


class _Scene:
    def __init__(self, node, ns: str) -> None:
        self.state = SceneState()
        self.sub = node.create_subscription(
            MarkerArray, f"{ns.rstrip('/')}/scene_markers", self._on_markers, LATCHED_QOS
        )

    def _on_markers(self, msg: MarkerArray) -> None:
        look, poses = drawables(msg)
        self.state.look, self.state.poses = tuple(look), poses
        self.state.seq += 1


class ArmRos:
    """Every arm on the studio's ROS domain, and the commands the arm page sends them."""

    def __init__(self, ros: StudioRos) -> None:
        self.ros = ros
        self.node = ros.node
        self._arms: dict[str, _Arm] = {}
        self._scenes: dict[str, _Scene] = {}
        self.arms: dict[str, ArmState] = {}  # prefix -> state, replaced (never mutated) on changes
        self.scenes: dict[str, SceneState] = {}  # world node namespace -> scene
        self.rosout = self.node.create_subscription(Log, "/rosout", self._on_log, ROSOUT_QOS)
        self.timer = ros.every(0.5, self._discover)

    def _discover(self) -> None:
        node, now = self.node, time.monotonic()
        for prefix, arm in list(self._arms.items()):
            gone = node.count_publishers(arm.state.topic(END_EFFECTOR_POSE_TOPIC)) == 0
            if gone and now - arm.state.last_heard > 2.0:
                print(f"studio: the arm {arm.state.label} has gone", flush=True)
                arm.destroy(node)
                del self._arms[prefix]
                self.arms = {k: v for k, v in self.arms.items() if k != prefix}
        for prefix, info in new_worlds(node, END_EFFECTOR_POSE_TOPIC, POSE_TYPE, self._arms):
            world_ns = info.node_namespace.rstrip("/")
            node_name = node_full_name(info)
            relative = prefix[len(world_ns) :].strip("/") if prefix.startswith(world_ns) else prefix.strip("/")
            state = ArmState(
                prefix=prefix,
                node_name=node_name,
                relative_prefix=relative + "/" if relative else "",
                world_ns=world_ns,
                last_heard=now,
            )
            self._arms[prefix] = _Arm(node, state)
            print(f"studio: following the arm {state.label} (node {node_name})", flush=True)
            if world_ns not in self._scenes:
                self._scenes[world_ns] = _Scene(node, world_ns)
                self.scenes = {**self.scenes, world_ns: self._scenes[world_ns].state}
            self.arms = {**self.arms, prefix: state}

    def _on_log(self, msg: Log) -> None:
        if UNREACHABLE not in msg.msg:
            return
        logger = msg.name
        for state in self.arms.values():
            if logger == state.node_name.strip("/").replace("/", ".") and msg.msg.startswith(
                state.relative_prefix + UNREACHABLE
            ):
                state.unreachable_text = msg.msg
                state.unreachable_at = time.monotonic()

    def prefixes(self) -> list[str]:
        return sorted(self.arms)

    # ---------------------------------------------------------------- commands (from the page)
    def joint_command(self, prefix: str, names: list[str], positions: list[float]) -> None:
        """Move the named joints of the arm ``prefix`` to ``positions`` (rad or m)."""
        msg = JointState(name=list(names), position=[float(p) for p in positions])
        self._arms[prefix].joint_command.publish(msg)

    def target_pose(self, prefix: str, xyz: tuple[float, float, float], rpy: tuple[float, float, float]) -> None:
        """Ask the arm ``prefix`` to move its flange to ``xyz`` (m) with ``rpy`` (rad, fixed X Y Z)."""
        msg = PoseStamped()
        msg.header.frame_id = self.arms[prefix].frame_id
        msg.pose.position.x, msg.pose.position.y, msg.pose.position.z = (float(v) for v in xyz)
        msg.pose.orientation = quaternion_from_matrix(transform_from_xyz_rpy(np.zeros(3), np.array(rpy))[:3, :3])
        self._arms[prefix].target_pose.publish(msg)

    def trajectory(
        self,
        prefix: str,
        names: list[str],
        times: np.ndarray,
        positions: np.ndarray,
        velocities: np.ndarray | None = None,
    ) -> None:
        """Send a joint trajectory (times in s from now, positions (k, n)); no points = stop."""
        msg = JointTrajectory(joint_names=list(names))
        for k, t in enumerate(times):
            point = JointTrajectoryPoint(positions=[float(v) for v in positions[k]])
            if velocities is not None:
                point.velocities = [float(v) for v in velocities[k]]
            ns = round(float(t) * 1e9)
            point.time_from_start = Duration(sec=ns // 1_000_000_000, nanosec=ns % 1_000_000_000)
            msg.points.append(point)
        self._arms[prefix].trajectory.publish(msg)

    def stop(self, prefix: str) -> None:
        self._arms[prefix].trajectory.publish(JointTrajectory())
