"""ROS 2 node for simulated serial arms: ``robot_sims arm`` (topics, frames, parameters: docs/arm.md).

One world node (it owns ``/clock``; physics at a fixed 100 Hz) holding one or more arms. The arm
of ``robot_config_file`` uses the node's namespace directly (``joint_states``, …); arms listed in
the scene file get their own prefix (``<name>/joint_states``, …) and frame prefix
(``<name>/base_link``, …). Per arm: ``joint_states``, ``robot_markers``, ``end_effector_pose``
and ``/tf`` at ``publish_rate``; ``robot_description`` (latched URDF, :mod:`arm_sim.urdf`); in:
``joint_trajectory``, ``joint_command``, ``target_pose``. World-level: ``scene_markers`` and
``/tf_static`` (arm bases, tool frames, scene objects).

Commands with NaN/inf, unknown joint names, non-increasing trajectory times or target poses in
another frame are rejected with a throttled warning and change nothing. Positions beyond the
joint limits are clamped with a warning. Trajectory ``header.stamp`` is ignored: a trajectory
starts when it is received.
"""

from __future__ import annotations

import math
import struct
import sys
from collections.abc import Sequence
from typing import Any

import numpy as np
from builtin_interfaces.msg import Time
from geometry_msgs.msg import Point, PoseStamped, TransformStamped
from rclpy.parameter import Parameter
from rclpy.serialization import serialize_message
from sensor_msgs.msg import JointState
from std_msgs.msg import ColorRGBA, String
from trajectory_msgs.msg import JointTrajectory
from visualization_msgs.msg import Marker, MarkerArray

from arm_sim.arm import PLACEHOLDER_SIZE, Arm
from arm_sim.motion import JointMotion
from arm_sim.scene import Scene, load_scene
from arm_sim.spec import (
    DEFAULT_PUBLISH_RATE,
    END_EFFECTOR_POSE_TOPIC,
    JOINT_STATES_TOPIC,
    PHYSICS_RATE,
    ROBOT_MARKERS_TOPIC,
    SCENE_MARKERS_TOPIC,
    WORLD_AXES_NS,
    mesh_marker_ns,
    scene_marker_ns,
)
from arm_sim.urdf import arm_tree, arm_urdf, fixed_transforms, joint_transforms
from sim_runtime.errors import InputError
from sim_runtime.kernels import announce_compiling
from sim_runtime.msgs import float64_array, matrix_from_quaternion
from sim_runtime.paths import mesh_uri, resolve_input_file
from sim_runtime.qos import LATCHED_QOS, create_command_subscription, create_sensor_publisher
from sim_runtime.rotations import quaternions_xyzw
from sim_runtime.run import run_nodes
from sim_runtime.tf import TfBroadcaster, transform_msg
from sim_runtime.world_node import SimWorldNode

AXES_LENGTH = 0.2  # m, RefSystem axes


def _color(rgba: Sequence[float] | np.ndarray, alpha: float = 1.0) -> ColorRGBA:
    return ColorRGBA(r=float(rgba[0]), g=float(rgba[1]), b=float(rgba[2]), a=float(rgba[3]) * alpha)


def _axes_marker(frame_id: str, ns: str, pose: np.ndarray, stamp: Time) -> Marker:
    """RefSystem: x red, y green, z blue lines from the origin of ``pose``."""
    m = Marker(ns=ns, id=0, type=Marker.LINE_LIST, action=Marker.ADD)
    m.header.frame_id = frame_id
    m.header.stamp = stamp
    _set_pose(m, pose[:3, 3], quaternions_xyzw(pose[None])[0])
    m.scale.x = 0.01
    for axis, rgb in enumerate(((1.0, 0.0, 0.0), (0.0, 1.0, 0.0), (0.0, 0.0, 1.0))):
        tip = [0.0, 0.0, 0.0]
        tip[axis] = AXES_LENGTH
        m.points.extend([Point(), Point(x=tip[0], y=tip[1], z=tip[2])])
        m.colors.extend([ColorRGBA(r=rgb[0], g=rgb[1], b=rgb[2], a=1.0)] * 2)
    return m


def arm_markers(arm: Arm, label: str, frame_id: str, alpha: float, stamp: Time) -> MarkerArray:
    """An arm's ``robot_markers``: every element's marker with its static fields (poses are filled
    at publish time, :func:`patched_markers`), then its base's axes."""
    markers = []
    for k, element in enumerate(arm.elements):
        m = Marker(ns=mesh_marker_ns(label), id=k, action=Marker.ADD)
        m.header.frame_id = frame_id
        m.color = _color(element.element.color, alpha)
        if element.placeholder:
            m.type = Marker.CUBE
            m.scale.x = m.scale.y = m.scale.z = PLACEHOLDER_SIZE
        else:
            m.type = Marker.MESH_RESOURCE
            m.mesh_resource = mesh_uri(element.element.mesh)
            m.scale.x = m.scale.y = m.scale.z = element.element.scale
        markers.append(m)
    return MarkerArray(markers=[*markers, _axes_marker(frame_id, f"{label}/axes", arm.base, stamp)])


def _set_pose(marker_or_pose: Any, xyz: Sequence[float] | np.ndarray, quat: Sequence[float] | np.ndarray) -> None:
    # a Marker or a PoseStamped: anything with a ``pose`` (ROS messages are untyped)
    pose = marker_or_pose.pose
    pose.position.x, pose.position.y, pose.position.z = float(xyz[0]), float(xyz[1]), float(xyz[2])
    o = pose.orientation
    o.x, o.y, o.z, o.w = float(quat[0]), float(quat[1]), float(quat[2]), float(quat[3])


class PatchedPoses:
    """A message serialized once; each publication only patches poses and stamps in the bytes.

    Converting a Python MarkerArray of a few dozen markers (or a TFMessage of a dozen transforms)
    to its C form costs about a millisecond per publication, most of the node's CPU at 100 Hz;
    patching the CDR bytes with numpy costs microseconds. ``poses`` lists the (position,
    orientation) field pairs to patch (a Pose's position/orientation or a Transform's
    translation/rotation: 7 contiguous doubles), ``stamps`` the header stamps; the byte offsets are
    found by serializing sentinel values once.
    """

    def __init__(self, msg: Any, poses: list[tuple[Any, Any]], stamps: list[Time]) -> None:
        sentinel_poses = 0x5EED0000 + np.arange(len(poses) * 7, dtype=float).reshape(len(poses), 7) + 0.25
        for (position, orientation), values in zip(poses, sentinel_poses.tolist(), strict=True):
            position.x, position.y, position.z = values[:3]
            orientation.x, orientation.y, orientation.z, orientation.w = values[3:]
        for k, stamp in enumerate(stamps):
            stamp.sec = 0x5EED00 + k
            stamp.nanosec = 999_000_000 + k
        data = serialize_message(msg)
        self.buffer = np.frombuffer(bytearray(data), dtype=np.uint8)
        self.pose_index = np.array([self._find(data, struct.pack("<d", p[0])) for p in sentinel_poses], dtype=int)[
            :, None
        ] + np.arange(56)
        self.stamp_index = np.array(
            [self._find(data, struct.pack("<iI", 0x5EED00 + k, 999_000_000 + k)) for k in range(len(stamps))],
            dtype=int,
        )[:, None] + np.arange(8)
        expected = sentinel_poses.view(np.uint8).reshape(len(poses), 56)
        if not np.array_equal(self.buffer[self.pose_index], expected):
            raise RuntimeError("pose fields are not contiguous in the serialized message")
        self.stamps = np.zeros(len(stamps), dtype=[("sec", "<i4"), ("nanosec", "<u4")])

    @staticmethod
    def _find(data: bytes, pattern: bytes) -> int:
        at = data.find(pattern)
        if at < 0 or data.find(pattern, at + 1) >= 0:
            raise RuntimeError("sentinel not found exactly once in the serialized message")
        return at

    def fill(self, poses: np.ndarray, stamp: Time) -> bytes:
        """Serialized message with ``poses`` (posed, 7: x y z qx qy qz qw) and ``stamp``."""
        self.buffer[self.pose_index] = np.ascontiguousarray(poses, dtype="<f8").view(np.uint8).reshape(-1, 56)
        self.stamps["sec"] = stamp.sec
        self.stamps["nanosec"] = stamp.nanosec
        self.buffer[self.stamp_index] = self.stamps.view(np.uint8).reshape(-1, 8)
        return self.buffer.tobytes()


def patched_markers(markers: MarkerArray, posed: int) -> PatchedPoses:
    """The first ``posed`` markers' poses and every marker's stamp patched per publication."""
    poses = [(m.pose.position, m.pose.orientation) for m in markers.markers[:posed]]
    return PatchedPoses(markers, poses, [m.header.stamp for m in markers.markers])


def poses_from_frames(frames: np.ndarray) -> np.ndarray:
    """(m, 7) x y z qx qy qz qw of poses (m, 4, 4)."""
    out = np.empty((len(frames), 7))
    out[:, :3] = frames[:, :3, 3]
    out[:, 3:] = quaternions_xyzw(frames)
    return out


class ArmInstance:
    """One arm in the world: model, motion, and its topics under ``prefix``."""

    def __init__(self, node: ArmNode, arm: Arm, prefix: str) -> None:
        self.node = node
        self.arm = arm
        self.prefix = prefix
        namespace = node.get_namespace().strip("/")
        self.label = "/".join(part for part in (namespace, prefix.rstrip("/")) if part) or arm.name
        # Frames are global: the namespace goes into their names (/ns + csa/ -> ns/csa/base_link).
        self.frame_prefix = "".join(part + "/" for part in (namespace, prefix.rstrip("/")) if part)
        self.tree = arm_tree(arm.config, self.frame_prefix, base=arm.base, world_frame=node.frame_id)
        self.motion = JointMotion(
            np.clip(np.zeros(arm.n), arm.lower, arm.upper), arm.lower, arm.upper, arm.velocity_limits
        )
        # joint_states names the joints with the frame prefix (csa/joint_1: two arms never share a
        # name); commands may use those or the config's own names
        self.joint_names = [joint.name for joint in self.tree.moving]
        self.index = {name: i for i, name in enumerate(arm.joint_names)} | {
            name: i for i, name in enumerate(self.joint_names)
        }
        frame = node.frame_id
        self.joint_pub = create_sensor_publisher(node, JointState, prefix + JOINT_STATES_TOPIC)
        self.marker_pub = create_sensor_publisher(node, MarkerArray, prefix + ROBOT_MARKERS_TOPIC)
        self.pose_pub = create_sensor_publisher(node, PoseStamped, prefix + END_EFFECTOR_POSE_TOPIC)
        self.description_pub = node.create_publisher(String, prefix + "robot_description", LATCHED_QOS)
        create_command_subscription(node, JointTrajectory, prefix + "joint_trajectory", self.on_trajectory)
        create_command_subscription(node, JointState, prefix + "joint_command", self.on_joint_command)
        create_command_subscription(node, PoseStamped, prefix + "target_pose", self.on_target_pose)
        self.joint_msg = JointState(name=list(self.joint_names))
        self.joint_msg.header.frame_id = frame
        self.pose_msg = PoseStamped()
        self.pose_msg.header.frame_id = frame
        self.set_marker_alpha(node.marker_alpha)
        self.description = arm_urdf(arm.config, self.frame_prefix, base=arm.base, world_frame=frame)
        self.description_pub.publish(String(data=self.description))

    def compile_kernels(self) -> None:
        """Run every kernel that publishing and the commands use once, at the start pose: each is
        compiled (or loaded from numba's cache) before the world is ready, not when a subscriber
        joins or the first target arrives (the world would stall then)."""
        q, zero = self.motion.q, np.zeros(self.arm.n)
        self.arm.rne(q, zero, zero)
        self.arm.fkine_all(q)
        joint_transforms(self.tree, q)
        self.arm.ikine(self.arm.fkine(q), q0=q, ilimit=1, slimit=1)

    # --- messages out -----------------------------------------------------------------------
    def set_marker_alpha(self, alpha: float) -> None:
        """(Re)build the markers with opacity ``alpha``: every publication from now on uses it."""
        self.markers = self._build_markers(alpha)
        self.marker_bytes = patched_markers(self.markers, len(self.arm.elements))

    def _build_markers(self, alpha: float) -> MarkerArray:
        """Every element's marker with its static fields; poses are filled at publish time."""
        markers = arm_markers(self.arm, self.label, self.node.frame_id, alpha, self.node.stamp())
        self.axes = markers.markers[-1]
        return markers

    def static_transforms(self) -> list[TransformStamped]:
        """The fixed joints of this arm's URDF (world -> base_link, link_n -> tool0), for /tf_static."""
        out = []
        for joint in fixed_transforms(self.tree):
            x, y, z = joint.origin[:3, 3]
            quaternion = quaternions_xyzw(joint.origin[None])[0]
            out.append(transform_msg(joint.parent, joint.child, x, y, z, quaternion=quaternion))
        return out

    def tf_entries(self) -> list[TransformStamped]:
        """One TransformStamped per moving joint (parent link -> child link), poses to be patched."""
        return [transform_msg(j.parent, j.child, 0.0, 0.0, 0.0) for j in self.tree.moving]

    def publish(self) -> np.ndarray:
        """Publish this arm's joint_states, robot_markers and end_effector_pose at sim time;
        return its joints' transforms (n, 4, 4) at the published joint state, for /tf."""
        stamp = self.node.stamp()
        q, qd, qdd = self.motion.q, self.motion.qd, self.motion.qdd
        msg = self.joint_msg
        msg.header.stamp = stamp
        msg.position = float64_array(q)
        msg.velocity = float64_array(qd)
        msg.effort = float64_array(self.arm.rne(q, qd, qdd))
        self.joint_pub.publish(msg)

        frames = self.arm.fkine_all(q)
        flange = frames[-1:]
        quats = quaternions_xyzw(np.concatenate([frames[self.arm.element_links], flange]))
        self.pose_msg.header.stamp = stamp
        _set_pose(self.pose_msg, flange[0, :3, 3], quats[-1])
        self.pose_pub.publish(self.pose_msg)

        poses = np.empty((len(self.arm.elements), 7))
        poses[:, :3] = frames[self.arm.element_links, :3, 3]
        poses[:, 3:] = quats[:-1]
        self.marker_pub.publish(self.marker_bytes.fill(poses, stamp))
        return joint_transforms(self.tree, q)

    # --- commands in ------------------------------------------------------------------------
    def _reject(self, what: str, why: str) -> None:
        self.node.warn_throttled(f"{self.label}/{what}", f"{self.prefix}{what} rejected: {why}")

    def _joint_indices(self, names: Sequence[str], what: str) -> np.ndarray | None:
        unknown = [n for n in names if n not in self.index]
        if unknown or len({self.index[n] for n in names}) != len(names):
            self._reject(what, f"joint names {list(names)} must be distinct names of {self.joint_names}")
            return None
        return np.array([self.index[n] for n in names], dtype=np.int64)

    def _clamped(self, q: np.ndarray, what: str) -> np.ndarray:
        clipped, joints = self.motion.clamp(q)
        if len(joints):
            names = [self.joint_names[j] for j in joints]
            self.node.warn_throttled(
                f"{self.label}/{what}/clamp", f"{self.prefix}{what}: {names} beyond joint limits, clamped"
            )
        return clipped

    def on_trajectory(self, msg: JointTrajectory) -> None:
        """Follow ``msg`` from now on (it replaces any motion); bad trajectories are rejected."""
        what = "joint_trajectory"
        if not msg.points:
            self.motion.stop()
            return
        idx = self._joint_indices(msg.joint_names, what)
        if idx is None:
            return
        times = np.array([p.time_from_start.sec + 1e-9 * p.time_from_start.nanosec for p in msg.points])
        if np.any(np.diff(times) <= 0) or times[0] < 0:
            self._reject(what, f"time_from_start must increase strictly, got {times.tolist()}")
            return
        if any(len(p.positions) != len(idx) for p in msg.points):
            self._reject(what, f"every point needs {len(idx)} positions, one per joint name")
            return
        has_velocities = all(len(p.velocities) == len(idx) for p in msg.points)
        if not has_velocities and any(len(p.velocities) for p in msg.points):
            self._reject(what, "velocities must be given for every point or for none")
            return
        positions = np.tile(self.motion.goal, (len(times), 1))
        positions[:, idx] = np.array([p.positions for p in msg.points], dtype=float)
        velocities = None
        if has_velocities:
            velocities = np.zeros_like(positions)
            velocities[:, idx] = np.array([p.velocities for p in msg.points], dtype=float)
        if not np.isfinite(positions).all() or (velocities is not None and not np.isfinite(velocities).all()):
            self._reject(what, "NaN or infinite position/velocity")
            return
        positions = self._clamped(positions, what)
        self.motion.follow(times, positions, velocities)

    def on_joint_command(self, msg: JointState) -> None:
        """Move the named (or all) joints to the given positions, clamped to their limits."""
        what = "joint_command"
        names = list(msg.name) if msg.name else list(self.joint_names)
        if len(msg.position) != len(names):
            self._reject(what, f"expected {len(names)} positions (one per name), got {len(msg.position)}")
            return
        idx = self._joint_indices(names, what)
        if idx is None:
            return
        values = np.array(msg.position, dtype=float)
        if not np.isfinite(values).all():
            self._reject(what, f"NaN or infinite position {values.tolist()}")
            return
        target = self.motion.goal
        target[idx] = values
        self.motion.move_to(self._clamped(target, what))

    def on_target_pose(self, msg: PoseStamped) -> None:
        """Solve IK for ``msg`` and move there; an unreachable or invalid target leaves the arm still."""
        what = "target_pose"
        frame = msg.header.frame_id
        if frame not in ("", self.node.frame_id):
            self._reject(what, f"frame_id {frame!r}: poses must be in {self.node.frame_id!r}")
            return
        p, o = msg.pose.position, msg.pose.orientation
        values = [p.x, p.y, p.z, o.x, o.y, o.z, o.w]
        if not all(math.isfinite(v) for v in values):
            self._reject(what, f"NaN or infinite value in {values}")
            return
        if math.sqrt(o.x * o.x + o.y * o.y + o.z * o.z + o.w * o.w) < 1e-9:
            self._reject(what, "zero quaternion")
            return
        target = np.eye(4)
        target[:3, :3] = matrix_from_quaternion(o)  # normalises a non-unit quaternion
        target[:3, 3] = [p.x, p.y, p.z]
        result = self.arm.ikine(target, q0=self.motion.q, seed=int(self.node.rng.integers(2**31)))
        if not result.success:
            self.node.warn_throttled(
                f"{self.label}/{what}/unreachable",
                f"{self.prefix}{what} unreachable (pose error {result.residual:.3g}): no motion",
            )
            return
        self.motion.move_to(result.q)


class ArmNode(SimWorldNode):
    """The arm world: arms from ``robot_config_file`` and ``scene_file``, scene objects, axes."""

    def __init__(self, node_name: str = "arm", **node_kwargs: Any) -> None:
        super().__init__(node_name, physics_rate=PHYSICS_RATE, **node_kwargs)
        try:
            self._declare_parameters()
            self.parameters_declared()
            self.tf = TfBroadcaster(self)
            self._add_arms()
            with announce_compiling(self.get_logger().info):
                for instance in self.arms:
                    instance.compile_kernels()
        except InputError:
            self.destroy_node()  # a half-built node must not linger in the graph
            raise
        self.scene_pub = self.create_publisher(MarkerArray, SCENE_MARKERS_TOPIC, LATCHED_QOS)
        self.scene_pub.publish(self._scene_markers())
        self._publish_static_transforms()
        entries = [t for arm in self.arms for t in arm.tf_entries()]
        self.tf_msg = self.tf.message(entries) if self.tf.enabled else None
        self.tf_bytes = (
            PatchedPoses(
                self.tf_msg,
                [(t.transform.translation, t.transform.rotation) for t in entries],
                [t.header.stamp for t in entries],
            )
            if self.tf.enabled
            else None
        )
        self.publisher_entry = self.every(self.publish_rate, self.publish)
        names = ", ".join(f"{a.arm.name} ({a.arm.n} joints{', ' + a.prefix if a.prefix else ''})" for a in self.arms)
        self.get_logger().info(f"arms: {names}; publishing at {self.publish_rate:g} Hz")

    def _deprecated_alias(self, old: str, new: str) -> None:
        """Accept parameter ``old`` given at start as ``new``, with a warning."""
        if old not in self._parameter_overrides:
            return
        if new in self._parameter_overrides:
            self.get_logger().warning(f"parameter '{old}' is deprecated and ignored: '{new}' is also set")
            return
        self.get_logger().warning(f"parameter '{old}' is deprecated: use '{new}'")
        self._parameter_overrides[new] = Parameter(new, value=self._parameter_overrides[old].value)

    def _declare_parameters(self) -> None:
        declare = self.declare_checked
        self._deprecated_alias("robot_config", "robot_config_file")
        self._deprecated_alias("alpha", "marker_alpha")
        self.robot_config_file = declare(
            "robot_config_file",
            "arm/irb120.yaml",
            None,
            "robot config YAML of the main arm: a path, or relative to the current directory or to the "
            "shipped config/ ('' = only the scene file's arms)",
        )
        self.scene_file = declare(
            "scene_file",
            "",
            None,
            "scene YAML (objects and more arms): a path, or relative to the current directory or to the "
            "shipped config/ ('' = none)",
        )
        self.marker_alpha = declare(
            "marker_alpha",
            1.0,
            None,
            "opacity of the arms' mesh markers, 0 (invisible) to 1 (opaque), times each element's own alpha",
            live=True,
            on_change=self._change_marker_alpha,
            bounds=(0.0, 1.0),
        )
        self.frame_id = declare(
            "frame_id", "world", lambda v: bool(v), "world frame: of every pose and marker, root of every arm's TF"
        )
        self.publish_rate = declare(
            "publish_rate",
            DEFAULT_PUBLISH_RATE,
            math.isfinite,
            f"Hz of joint_states, robot_markers, end_effector_pose and /tf (0 = never, at most the physics "
            f"rate {PHYSICS_RATE:g})",
            live=True,
            on_change=self._change_publish_rate,
            bounds=(0.0, PHYSICS_RATE),
        )
        self.skip_missing_meshes = declare(
            "skip_missing_meshes",
            False,
            None,
            "draw a placeholder cube for an unreadable STL file instead of refusing to start",
        )

    def _add_arms(self) -> None:
        skip = self.skip_missing_meshes
        scene_file = self.scene_file
        self.scene: Scene | None = load_scene(resolve_input_file(scene_file, "scene_file")) if scene_file else None
        self.arms: list[ArmInstance] = []
        if self.robot_config_file:
            path = resolve_input_file(self.robot_config_file, "robot_config_file")
            self._add_arm(Arm.from_file(path, skip_missing_meshes=skip), "")
        for scene_arm in self.scene.arms if self.scene else ():
            arm = Arm.from_file(scene_arm.config, base=scene_arm.base, skip_missing_meshes=skip)
            self._add_arm(arm, scene_arm.name + "/")
        if not self.arms:
            raise InputError("no arm: set robot_config_file or list arms in the scene file")

    def _add_arm(self, arm: Arm, prefix: str) -> None:
        for element in arm.elements:
            if element.placeholder:
                self.get_logger().warning(f"{element.error}: drawing a placeholder cube")
        self.arms.append(ArmInstance(self, arm, prefix))

    def _change_marker_alpha(self, alpha: float) -> None:
        self.marker_alpha = alpha
        for arm in self.arms:
            arm.set_marker_alpha(alpha)

    def _change_publish_rate(self, rate: float) -> None:
        self.publish_rate = rate
        self.publisher_entry.set_rate(rate / self.physics_rate, self.step_count)

    def _scene_frame_prefix(self) -> str:
        namespace = self.get_namespace().strip("/")
        return namespace + "/" if namespace else ""

    def _scene_markers(self) -> MarkerArray:
        markers = [_axes_marker(self.frame_id, WORLD_AXES_NS, np.eye(4), self.stamp())]
        for k, obj in enumerate(self.scene.objects if self.scene else ()):
            m = Marker(ns=scene_marker_ns(obj.name), id=k, type=Marker.MESH_RESOURCE, action=Marker.ADD)
            m.header.frame_id = self.frame_id
            m.header.stamp = self.stamp()
            m.mesh_resource = mesh_uri(obj.mesh)
            m.scale.x = m.scale.y = m.scale.z = obj.scale
            m.color = _color(obj.color, 1.0)
            _set_pose(m, obj.pose[:3, 3], quaternions_xyzw(obj.pose[None])[0])
            markers.append(m)
        return MarkerArray(markers=markers)

    def _publish_static_transforms(self) -> None:
        """Every arm's base and tool frames, and a frame per scene object (``<object name>``)."""
        transforms = [t for arm in self.arms for t in arm.static_transforms()]
        prefix = self._scene_frame_prefix()
        for obj in self.scene.objects if self.scene else ():
            x, y, z = obj.pose[:3, 3]
            quaternion = quaternions_xyzw(obj.pose[None])[0]
            transforms.append(transform_msg(self.frame_id, prefix + obj.name, x, y, z, quaternion=quaternion))
        self.tf.send_static(transforms, self.stamp())

    def physics_step(self) -> None:
        """Advance every arm's motion by one physics step."""
        for arm in self.arms:
            arm.motion.step(self.physics_dt)

    def publish(self) -> None:
        """Publish every arm's state and markers, and every moving joint's transform on /tf."""
        joints = [arm.publish() for arm in self.arms]
        tf_pub, tf_bytes = self.tf.publisher, self.tf_bytes  # both set when tf is enabled
        if tf_pub is not None and tf_bytes is not None and self.tf.heard():
            tf_pub.publish(tf_bytes.fill(poses_from_frames(np.concatenate(joints)), self.stamp()))

    def arm(self, prefix: str = "") -> ArmInstance:
        """The arm whose topics live under ``prefix`` ('' for robot_config_file's, else '<name>/')."""
        for arm in self.arms:
            if arm.prefix == prefix:
                return arm
        raise KeyError(prefix)


def main(args: list[str] | None = None) -> int:
    """Entry point ``arm``."""
    return run_nodes(lambda: [ArmNode()], args)


if __name__ == "__main__":
    sys.exit(main())
