"""``robot_sims policy_controller``: a learned Create policy driving a ROS ``create_world``.

The policy file (:mod:`sim_tools.rl.policy`) names the environment it learned in and that env's
options; this node builds the same observation from the world's messages
(:func:`~sim_tools.rl.create_sensors.observation`) and publishes the policy's ``[v, ω]`` on
``cmd_vel`` once every ``control_period_s`` of sim time, as an env step does. Its clock is the
odometry's stamps (sim time), so it behaves the same at any ``real_time_factor``.

The goal (parameter ``goal``, map frame) is turned into the odometry frame once, from the first
``overhead_pose`` and the odometry of the same instant: a real robot is given its goal once,
relative to where it stands, and then has only its odometry.

At the goal it stops, as the env's episode ends there: once the odometry puts the robot within the
policy's ``goal_radius_m`` (its env option, default 0.3 m) of the goal, the node sends ``[0, 0]``
every control period from then on (``stop_at_goal:=false`` lets the policy drive on; a policy
without a goal, CreateCover's, never stops). It judges by odometry, the only pose a robot has: with
odometry noise it stops where it *believes* the goal is.

    robot_sims policy_controller --ros-args -p policy:=examples/learning/create_nav_policy.npz -p goal:=[1.5,1.0]
"""

from __future__ import annotations

import math
from functools import partial
from typing import Any

import numpy as np
from geometry_msgs.msg import PoseStamped, Twist
from nav_msgs.msg import Odometry
from sensor_msgs.msg import Illuminance, LaserScan, Range

from create_sim import spec
from create_sim.spec import CLIFF_NAMES, SONAR_NAMES
from sim_runtime.errors import InputError
from sim_runtime.msgs import time_from_msg, yaw_from_quaternion
from sim_runtime.params import CheckedNode
from sim_runtime.qos import COMMAND_PUBLISHER_QOS, SENSOR_SUBSCRIBER_QOS
from sim_runtime.run import run_nodes
from sim_tools.rl.create_sensors import (
    DEFAULT_GOAL_RADIUS_M,
    DEFAULT_SENSORS,
    blank_readings,
    checked_sensors,
    goal_in_odom,
    lidar_index,
    observation,
)
from sim_tools.rl.policy import MlpPolicy, load_policy

#: The environments whose policies this node runs.
NAV_ENV = "robot_sims/CreateNav-v0"
CREATE_ENVS = (NAV_ENV, "robot_sims/CreateCover-v0")
DEFAULT_CONTROL_PERIOD_S = 0.1
DEFAULT_LIDAR_BEAMS = 24


class PolicyControllerNode(CheckedNode):
    """Sensors → the policy's observation → ``cmd_vel``, every control period of sim time."""

    def __init__(self, node_name: str = "policy_controller", **node_kwargs: Any) -> None:
        super().__init__(node_name, **node_kwargs)
        path = self.declare_checked("policy", "", None, "the policy file (.npz) to run (sim_tools.rl.policy)")
        goal = self.declare_checked(
            "goal",
            [0.0, 0.0],
            lambda v: len(v) == 2 and all(math.isfinite(c) for c in v),
            "the goal [x, y] in the map frame (m), for a policy that observes its goal",
        )
        self.goal_map = (float(goal[0]), float(goal[1]))
        self.stop_at_goal = self.declare_checked(
            "stop_at_goal",
            True,
            None,
            "stop (send [0, 0] every control period) once odometry puts the robot in the goal region",
        )
        self.cmd_pub = self.create_publisher(Twist, spec.CMD_VEL_TOPIC, COMMAND_PUBLISHER_QOS)
        if self.describe_only:
            return
        self.policy = _checked_policy(path)
        options = self.policy.env_kwargs
        self.sensors = checked_sensors(options.get("sensors", DEFAULT_SENSORS))
        self.beams = lidar_index(int(options.get("lidar_beams", DEFAULT_LIDAR_BEAMS)))
        self.period_s = float(options.get("control_period_s", DEFAULT_CONTROL_PERIOD_S))
        #: The goal region's radius (m) if the policy has a goal (a CreateNav policy), else None.
        self.goal_radius_m: float | None = (
            float(options.get("goal_radius_m", DEFAULT_GOAL_RADIUS_M)) if self.policy.env_id == NAV_ENV else None
        )
        #: Whether the robot has reached the goal (by odometry) and stopped there.
        self.at_goal = False
        self.raw: dict[str, np.ndarray] = {}
        #: per part, the sim time (s) of each of its topics' last message
        self.stamps: dict[str, np.ndarray] = {}
        self.goal_odom: tuple[float, float] | None = None
        self.first_truth: tuple[float, float, float] | None = None
        self.next_act_s = 0.0
        self.actions = 0
        # the observation's kernels compiled (or loaded from numba's cache) now, not at the first
        # control instant: a world at real time would run on meanwhile
        observation(blank_readings(self.sensors, len(self.beams)), (0.0, 0.0))
        self._subscribe()

    def _subscribe(self) -> None:
        sub = partial(self.create_subscription, qos_profile=SENSOR_SUBSCRIBER_QOS)
        self._track("goal", 1)  # the odometry pose is the goal part's reading
        sub(Odometry, spec.ODOM_TOPIC, self.on_odom)
        sub(PoseStamped, spec.OVERHEAD_POSE_TOPIC, self.on_truth)
        if "lidar" in self.sensors:
            self._track("lidar", 1)
            sub(LaserScan, spec.SCAN_TOPIC, self.on_scan)
        for part, names, msg_type, topic in (
            ("sonar", SONAR_NAMES, Range, spec.sonar_topic),
            ("bump", spec.BUMP_SIDES, Range, spec.bump_topic),
            ("cliff", CLIFF_NAMES, Illuminance, spec.cliff_topic),
        ):
            if part in self.sensors:
                self._track(part, len(names))
                for i, name in enumerate(names):
                    sub(msg_type, topic(name), partial(self.on_reading, part, i))

    def _track(self, part: str, topics: int) -> None:
        self.raw[part] = np.full(topics, np.nan)
        self.stamps[part] = np.full(topics, -np.inf)

    def on_scan(self, msg: LaserScan) -> None:
        self.raw["lidar"] = np.asarray(msg.ranges, dtype=float)[self.beams]
        self._arrived("lidar", 0, msg.header.stamp)

    def on_reading(self, part: str, i: int, msg: Any) -> None:
        """One sonar, bumper (-inf = pressed) or cliff reading."""
        value = msg.illuminance if part == "cliff" else msg.range
        self.raw[part][i] = float(value == -math.inf) if part == "bump" else value
        self._arrived(part, i, msg.header.stamp)

    def on_truth(self, msg: PoseStamped) -> None:
        """The first overhead pose: where the robot starts, to put the goal in the odometry frame."""
        if self.first_truth is None:
            p, q = msg.pose.position, msg.pose.orientation
            self.first_truth = (p.x, p.y, yaw_from_quaternion(q))
            self._arrived("goal", 0, msg.header.stamp, truth=True)

    def on_odom(self, msg: Odometry) -> None:
        p, q = msg.pose.pose.position, msg.pose.pose.orientation
        self.raw["goal"] = np.array([p.x, p.y, yaw_from_quaternion(q)])
        self._arrived("goal", 0, msg.header.stamp)

    def _arrived(self, part: str, i: int, stamp: Any, truth: bool = False) -> None:
        """Act once every part has its readings of the next control instant (the world publishes
        every sensor at instants the default rates share, so they come together)."""
        if not truth:
            self.stamps[part][i] = time_from_msg(stamp)
        if self.goal_odom is None and self.first_truth is not None and not np.isnan(self.raw["goal"]).any():
            self.goal_odom = goal_in_odom(self.goal_map, self.first_truth, self.raw["goal"])
        now = min(float(t.min()) for t in self.stamps.values())
        if self.goal_odom is not None and now + 1e-9 >= self.next_act_s:
            self.next_act_s = now + self.period_s
            self.act()

    def act(self) -> None:
        """The policy's command for the latest readings, published ([0, 0] at the goal)."""
        assert self.goal_odom is not None
        if self._reached():
            v, w = 0.0, 0.0
        else:
            raw = {name: self.raw[name] for name in self.sensors}  # in the env's order
            v, w = self.policy.act(observation(raw, self.goal_odom)).tolist()
        cmd = Twist()
        cmd.linear.x, cmd.angular.z = float(v), float(w)
        self.cmd_pub.publish(cmd)
        self.actions += 1

    def _reached(self) -> bool:
        """Whether the robot is (or was: it stays stopped) in the goal region, by its odometry."""
        if self.at_goal or not self.stop_at_goal or self.goal_radius_m is None or self.goal_odom is None:
            return self.at_goal
        x, y = self.raw["goal"][:2]
        if math.hypot(self.goal_odom[0] - x, self.goal_odom[1] - y) <= self.goal_radius_m:
            self.at_goal = True
            self.get_logger().info(f"at the goal {list(self.goal_map)} (by odometry): stopped")
        return self.at_goal


def _checked_policy(path: str) -> MlpPolicy:
    if not path:
        raise InputError("parameter policy: give the policy file, -p policy:=FILE.npz")
    policy = load_policy(path)
    if policy.env_id not in CREATE_ENVS:
        raise InputError(f"{path}: a policy of {policy.env_id or 'no env'}; this node runs {list(CREATE_ENVS)}")
    return policy


def main(args: list[str] | None = None) -> int:
    """Entry point ``policy_controller``."""
    return run_nodes(lambda: [PolicyControllerNode()], args)
