"""The poses family: ground-truth poses (PoseStamped), odometry beside them, other poses (a target,
an end effector and its path)."""

from __future__ import annotations

import math

import numpy as np
import rerun as rr

from sim_runtime.angles import wrap_angle
from sim_runtime.msgs import yaw_from_quaternion
from sim_tools.rerun_kit.robots import Robots
from sim_tools.rerun_kit.ros import basename, follow_transform, namespace, pose_transform, topic_path, yaw_transform
from sim_tools.rerun_kit.state import Robot, Track
from sim_tools.rerun_kit.style import AXES_LENGTH_M, HEADING_COLOR, MAP, PATH_COLOR, WORLD


class Poses(Robots):
    """Draws geometry_msgs/PoseStamped and nav_msgs/Odometry."""

    def _pose_stamped(self, topic: str, msg) -> None:
        if basename(topic) not in self.truth_pose_topics or not self.planar:
            self._other_pose(topic, msg)
            return
        robot = self.robot(namespace(topic))
        x, y, yaw = msg.pose.position.x, msg.pose.position.y, yaw_from_quaternion(msg.pose.orientation)
        robot.expects_truth = True
        robot.truths.append((self._t_ns, x, y, yaw))
        self._robot_pose(robot, x, y, yaw)
        robot.truth.add(self.rec, x, y)
        self._compare_odometry(robot)

    def _robot_pose(self, robot: Robot, x: float, y: float, yaw: float) -> None:
        robot.pose = (x, y, yaw)
        self.rec.log(f"{MAP}/robots/{robot.name}", yaw_transform(x, y, yaw))
        self.rec.log(f"{MAP}/robots/{robot.name}/follow", follow_transform(yaw))
        if robot.color is None:
            self._match_outlines()

    def _other_pose(self, topic: str, msg) -> None:
        """A pose that is no robot's: axes at it (a target pose) and, for an end effector, its path."""
        base = self.frame_entity(msg.header.frame_id)
        entity = f"{base}/poses/{topic_path(topic)}"
        p = msg.pose.position
        if base == WORLD:
            self._grow_world(np.array([[p.x, p.y, p.z]]))
            if basename(topic) not in self._path_topics:  # a target: axes and its name
                label = rr.Points3D([[0, 0, 0]], radii=0.006, colors=[HEADING_COLOR], labels=[basename(topic)])
                self.rec.log(entity, pose_transform(msg.pose), rr.TransformAxes3D(AXES_LENGTH_M), label)
            else:  # the end effector: small axes and the path it followed
                self.rec.log(entity, pose_transform(msg.pose), rr.TransformAxes3D(0.6 * AXES_LENGTH_M))
                path = self._paths.setdefault(
                    topic, Track(f"{WORLD}/paths/{topic_path(topic)}", PATH_COLOR, 2.0, dims=3)
                )
                path.add(self.rec, p.x, p.y, p.z)
        else:
            yaw = yaw_from_quaternion(msg.pose.orientation)
            self.rec.log(
                entity,
                yaw_transform(p.x, p.y, yaw),
                rr.Arrows2D(origins=[[0, 0]], vectors=[[0.2, 0]], colors=[HEADING_COLOR], labels=[basename(topic)]),
            )

    def _odometry(self, topic: str, msg) -> None:
        child = msg.child_frame_id.strip("/")
        robot = self.robot(child.rpartition("/")[0] if child else namespace(topic))
        p = msg.pose.pose
        robot.pending_odom.append((self._t_ns, p.position.x, p.position.y, yaw_from_quaternion(p.orientation)))
        self._compare_odometry(robot)

    def _compare_odometry(self, robot: Robot) -> None:
        """Draw odometry in the map frame, next to the ground truth of the same instant.

        The odom frame starts wherever the world put it, so it is aligned with the truth at the
        first odometry message; each odometry pose waits until the truth of its instant (which may
        be logged just after it) is known, then is compared with it.
        """
        if robot.expects_truth and not robot.truths:
            return
        now = self._t_ns
        while robot.pending_odom:
            t, ox, oy, oyaw = robot.pending_odom[0]
            truth = None
            if robot.expects_truth:
                if robot.truths[-1][0] < t:
                    break  # the truth of this instant has not arrived yet
                truth = min(robot.truths, key=lambda tr: abs(tr[0] - t))[1:]
            robot.pending_odom.popleft()
            if robot.odom_to_map is None:
                if truth is None:
                    robot.odom_to_map = (0.0, 0.0, 0.0)
                else:
                    dyaw = truth[2] - oyaw
                    c, s = math.cos(dyaw), math.sin(dyaw)
                    robot.odom_to_map = (truth[0] - (c * ox - s * oy), truth[1] - (s * ox + c * oy), dyaw)
            dx, dy, dyaw = robot.odom_to_map
            c, s = math.cos(dyaw), math.sin(dyaw)
            x, y, yaw = dx + c * ox - s * oy, dy + s * ox + c * oy, oyaw + dyaw
            self._set_time(t)
            robot.odom.add(self.rec, x, y)
            if truth is None:  # odometry is all we know of this robot's pose
                self._robot_pose(robot, x, y, yaw)
            else:
                error = math.hypot(x - truth[0], y - truth[1])
                self.scalar("odom_error", robot.name, "position_m", error, 0, "position (m)")
                error = wrap_angle(yaw - truth[2])
                self.scalar("odom_error", robot.name, "heading_rad", error, 1, "heading (rad)")
        self._set_time(now)
