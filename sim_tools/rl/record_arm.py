"""An ``ArmReach-v0`` episode written as a bag of an ``arm`` world's topics (for
:class:`sim_tools.rl.record.RecordEpisodeBags`).

What a recorded ``robot_sims arm`` (one arm, root namespace, default ``publish_rate``) has:
``/clock`` at the physics rate; ``/joint_states``, ``/end_effector_pose``, ``/robot_markers`` and
``/tf`` at the publish rate; latched ``/robot_description`` and ``/tf_static``; plus the env's
target on ``/target_pose`` (the arm's own command topic) at the start. Not written: the world's
``/scene_markers`` (its world axes).

Timing: an env step holds the (clipped) joint velocities for ``control_period_s`` with the joints
held in their limits, so the joints at any instant of the step are ``clip(q + q̇ t)``; the
messages due in the step are written at their instants from that, the step's end being exactly
the env's joints. The efforts are the inverse dynamics at (q, q̇, 0), as the arm world's.
"""

from __future__ import annotations

from pathlib import Path
from typing import Any

import numpy as np
from builtin_interfaces.msg import Time
from geometry_msgs.msg import PoseStamped
from rclpy.serialization import serialize_message
from rosgraph_msgs.msg import Clock
from sensor_msgs.msg import JointState
from std_msgs.msg import String

from arm_sim.arm import Arm
from arm_sim.arm_node import PatchedPoses, arm_markers, patched_markers, poses_from_frames
from arm_sim.spec import (
    DEFAULT_PUBLISH_RATE,
    END_EFFECTOR_POSE_TOPIC,
    JOINT_STATES_TOPIC,
    PHYSICS_RATE,
    ROBOT_MARKERS_TOPIC,
)
from arm_sim.urdf import WORLD_FRAME, arm_tree, arm_urdf, fixed_transforms, joint_transforms
from sim_runtime.bag.writer import BagWriter, qos_profiles_yaml
from sim_runtime.msgs import float64_array
from sim_runtime.rotations import quaternions_xyzw
from sim_runtime.tf import TFMessage, transform_msg
from sim_tools.rl.arm_reach import ArmReachEnv

CLOCK_NS = round(1e9 / PHYSICS_RATE)
PUBLISH_NS = round(1e9 / DEFAULT_PUBLISH_RATE)


def meshed_arm(env: ArmReachEnv) -> Arm:
    """The env's arm with its meshes (the env's own has none), for its ``robot_markers``; an
    unreadable mesh is a cube, as the arm world's ``skip_missing_meshes`` draws it."""
    return Arm(env.arm.config, base=env.arm.base, skip_missing_meshes=True)


def _stamp(t_ns: int) -> Time:
    return Time(sec=t_ns // 1_000_000_000, nanosec=t_ns % 1_000_000_000)


def _topics() -> dict[str, tuple[str, str]]:
    latched = qos_profiles_yaml([{"history": "keep_last", "depth": 1, "durability": "transient_local"}])
    qos = qos_profiles_yaml([{}])
    topics = {
        "/robot_description": ("std_msgs/msg/String", latched),
        "/target_pose": ("geometry_msgs/msg/PoseStamped", qos),
        "/clock": ("rosgraph_msgs/msg/Clock", qos),
        f"/{JOINT_STATES_TOPIC}": ("sensor_msgs/msg/JointState", qos),
        f"/{END_EFFECTOR_POSE_TOPIC}": ("geometry_msgs/msg/PoseStamped", qos),
        f"/{ROBOT_MARKERS_TOPIC}": ("visualization_msgs/msg/MarkerArray", qos),
    }
    if TFMessage is not None:
        topics |= {"/tf": ("tf2_msgs/msg/TFMessage", qos), "/tf_static": ("tf2_msgs/msg/TFMessage", latched)}
    return topics


def _pose_stamped(pose: np.ndarray, t_ns: int) -> PoseStamped:
    """A 4x4 pose in the world frame."""
    msg = PoseStamped()
    msg.header.stamp, msg.header.frame_id = _stamp(t_ns), WORLD_FRAME
    p, o = msg.pose.position, msg.pose.orientation
    p.x, p.y, p.z = (float(v) for v in pose[:3, 3])
    o.x, o.y, o.z, o.w = (float(v) for v in quaternions_xyzw(pose[None])[0])
    return msg


class ArmEpisodeBag:
    """One ArmReach episode being written (see the module's docstring)."""

    def __init__(self, path: Path, env: ArmReachEnv, arm: Arm, seed: int | None, compression: str) -> None:
        self.env, self.arm = env, arm
        self.t_ns = 0
        self.bag = BagWriter(path, compression=compression, clock=lambda: self.t_ns / 1e9)
        self.ids = {name: self.bag.add_topic(name, kind, q) for name, (kind, q) in _topics().items()}
        self.tree = arm_tree(arm.config, base=arm.base)
        self.markers = patched_markers(arm_markers(arm, arm.name, WORLD_FRAME, 1.0, _stamp(0)), len(arm.elements))
        self.tf = self._tf_bytes() if TFMessage is not None else None
        self._latched()
        self.q0 = env.q.copy()
        self._clock(0)
        self._publish(env.q, np.zeros(arm.n), 0)
        self.summary: dict[str, Any] = {
            "env": env.spec.id if env.spec is not None else type(env).__name__,
            "seed": seed,
            "robot": arm.name,
            "start": env.q.tolist(),
            "target": env.target.tolist(),
            "control_period_s": env.dt,
            "return": 0.0,
        }

    def _put(self, topic: str, t_ns: int, msg: object) -> None:
        data = msg if isinstance(msg, bytes) else serialize_message(msg)
        self.bag.write(self.ids[topic], t_ns, data)

    def _tf_bytes(self) -> PatchedPoses:
        """``/tf`` of the moving joints, serialized once and patched per message (as the world does)."""
        entries = [transform_msg(j.parent, j.child, 0.0, 0.0, 0.0) for j in self.tree.moving]
        poses = [(t.transform.translation, t.transform.rotation) for t in entries]
        return PatchedPoses(TFMessage(transforms=entries), poses, [t.header.stamp for t in entries])

    def _latched(self) -> None:
        """The description, the fixed joints and the target, at the start."""
        self._put("/robot_description", 0, String(data=arm_urdf(self.arm.config, base=self.arm.base)))
        if TFMessage is not None:
            transforms = []
            for joint in fixed_transforms(self.tree):
                x, y, z = joint.origin[:3, 3]
                quaternion = quaternions_xyzw(joint.origin[None])[0]
                transforms.append(transform_msg(joint.parent, joint.child, x, y, z, quaternion=quaternion))
            self._put("/tf_static", 0, TFMessage(transforms=transforms))
        self._put("/target_pose", 0, _pose_stamped(self.env.target, 0))

    def before_step(self, _action: Any) -> None:
        self.q0 = self.env.q.copy()

    def after_step(self, action: Any, reward: float) -> None:
        """Every message due in the step just taken, at its instant."""
        self.summary["return"] += reward
        arm, start = self.arm, self.t_ns
        qd = np.clip(np.asarray(action, dtype=float), -arm.velocity_limits, arm.velocity_limits)
        end = start + round(self.env.dt * 1e9)
        for tick in range(start // CLOCK_NS + 1, end // CLOCK_NS + 1):
            t_ns = tick * CLOCK_NS
            self.t_ns = t_ns
            self._clock(t_ns)
            if t_ns % PUBLISH_NS == 0:
                q = np.clip(self.q0 + qd * ((t_ns - start) / 1e9), arm.lower, arm.upper)
                held = ((q <= arm.lower) & (qd < 0)) | ((q >= arm.upper) & (qd > 0))
                self._publish(q, np.where(held, 0.0, qd), t_ns)
        self.t_ns = end

    def _clock(self, t_ns: int) -> None:
        self._put("/clock", t_ns, Clock(clock=_stamp(t_ns)))

    def _publish(self, q: np.ndarray, qd: np.ndarray, t_ns: int) -> None:
        """joint_states, end_effector_pose, robot_markers and /tf at joints ``q`` moving at ``qd``."""
        arm, stamp = self.arm, _stamp(t_ns)
        joints = JointState(name=list(arm.joint_names))
        joints.header.stamp, joints.header.frame_id = stamp, WORLD_FRAME
        joints.position, joints.velocity = float64_array(q), float64_array(qd)
        joints.effort = float64_array(arm.rne(q, qd, np.zeros(arm.n)))
        self._put(f"/{JOINT_STATES_TOPIC}", t_ns, joints)
        frames = arm.fkine_all(q)
        self._put(f"/{END_EFFECTOR_POSE_TOPIC}", t_ns, _pose_stamped(frames[-1], t_ns))
        self._put(
            f"/{ROBOT_MARKERS_TOPIC}", t_ns, self.markers.fill(poses_from_frames(frames[arm.element_links]), stamp)
        )
        if self.tf is not None:
            self._put("/tf", t_ns, self.tf.fill(poses_from_frames(joint_transforms(self.tree, q)), stamp))

    def close(self) -> tuple[Path, dict[str, Any]]:
        """Close the bag: its folder and the episode's summary."""
        self.bag.close()
        return self.bag.folder, {**self.summary, "steps": self.env.steps}
