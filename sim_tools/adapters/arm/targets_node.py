"""``arm_targets``: the arm controller of batch sweeps: the world's target positions one after
another, ``hold_s`` apart, each as a ``target_pose`` keeping the flange orientation of q = 0."""

from __future__ import annotations

from typing import Any

import numpy as np
from geometry_msgs.msg import PoseStamped
from rclpy.node import Node
from sensor_msgs.msg import JointState

from arm_sim.spec import JOINT_STATES_TOPIC
from sim_runtime.msgs import quaternion_from_matrix, time_from_msg
from sim_runtime.qos import COMMAND_PUBLISHER_QOS, SENSOR_SUBSCRIBER_QOS


def target_poses(arm: Any, targets: list[list[float]]) -> np.ndarray:
    """The targets [x, y, z] (m, world frame) as 4x4 poses with the flange orientation at q = 0."""
    home = arm.fkine(np.clip(np.zeros(arm.n), arm.lower, arm.upper))
    poses = np.repeat(home[None], len(targets), axis=0)
    poses[:, :3, 3] = np.asarray(targets, dtype=float)[:, :3]
    return poses


class ArmTargetsNode(Node):
    """Publishes target k once the sim time (the stamps of ``joint_states``) reaches k·``hold_s``."""

    def __init__(self, poses: np.ndarray, hold_s: float, **node_kwargs: Any) -> None:
        super().__init__("arm_targets", **node_kwargs)
        self.poses = poses
        self.hold_s = hold_s
        self.sent = 0
        self.publisher = self.create_publisher(PoseStamped, "target_pose", COMMAND_PUBLISHER_QOS)
        self.create_subscription(JointState, JOINT_STATES_TOPIC, self._on_state, SENSOR_SUBSCRIBER_QOS)

    def _on_state(self, msg: JointState) -> None:
        now = time_from_msg(msg.header.stamp)
        while self.sent < len(self.poses) and now >= self.sent * self.hold_s - 1e-9:
            pose = self.poses[self.sent]
            out = PoseStamped()
            out.header.stamp = msg.header.stamp
            out.pose.position.x, out.pose.position.y, out.pose.position.z = (float(v) for v in pose[:3, 3])
            out.pose.orientation = quaternion_from_matrix(pose[:3, :3])
            self.publisher.publish(out)
            self.sent += 1
