"""Example controller: drive forward; on a bump, back up, turn away, drive on.

This is the "write your own controller" example: a plain rclpy node that subscribes to the
bumpers and publishes ``cmd_vel``. Its clock is the stamps of the bump messages (sim time), not a
wall-clock timer, so it behaves the same at any ``real_time_factor``.
"""

from __future__ import annotations

import math
import time
from collections.abc import Callable, Sequence
from functools import partial
from typing import Any

import numpy as np
from geometry_msgs.msg import Twist
from rclpy.context import Context
from rclpy.node import Node
from sensor_msgs.msg import Range

from create_sim import spec
from sim_runtime.msgs import time_from_msg
from sim_runtime.params import CheckedNode
from sim_runtime.qos import COMMAND_PUBLISHER_QOS, SENSOR_SUBSCRIBER_QOS
from sim_runtime.run import run_nodes

FORWARD_SPEED = 0.3  # m/s
BACK_SPEED = -0.2  # m/s
BACK_TIME = 0.5  # s of backing up after a bump
TURN_SPEED = 1.5  # rad/s
TURN_ANGLES = (math.radians(60), math.radians(150))  # random turn between these, away from the bump


class BumpTurnNode(CheckedNode):
    """Forward → (bump) → back up → turn away → forward."""

    def __init__(self, node_name: str = "create_bump_turn", **node_kwargs: Any) -> None:
        super().__init__(node_name, **node_kwargs)
        seed = self.declare_checked("seed", 0, None, "seed of the random turn angles", bounds=(0, 2**63 - 1))
        self.rng = np.random.default_rng(seed)
        self.cmd_pub = self.create_publisher(Twist, spec.CMD_VEL_TOPIC, COMMAND_PUBLISHER_QOS)
        self.pressed = {"left": False, "right": False}
        for side in self.pressed:
            self.create_subscription(Range, spec.bump_topic(side), partial(self.on_bump, side), SENSOR_SUBSCRIBER_QOS)
        self.state = "forward"
        self.state_end = 0.0  # sim time at which "back" or "turn" ends
        self.hit: set[str] = set()  # bumpers pressed since the last bump began
        self.turn_rate = 0.0  # signed rad/s of the current turn
        self.bumps = 0

    def on_bump(self, side: str, msg: Range) -> None:
        """A bumper reading (-inf = pressed) is also this controller's clock tick."""
        self.pressed[side] = msg.range == -math.inf
        now = time_from_msg(msg.header.stamp)
        if self.state == "forward" and any(self.pressed.values()):
            self.bumps += 1
            self.hit = set()
            self.state, self.state_end = "back", now + BACK_TIME
        if self.state == "back":
            self.hit.update(s for s, pressed in self.pressed.items() if pressed)
            if now >= self.state_end:
                # Only the left bumper → turn right (clockwise); the right one or both (front) → turn left.
                self.turn_rate = -TURN_SPEED if self.hit == {"left"} else TURN_SPEED
                self.state, self.state_end = "turn", now + self.rng.uniform(*TURN_ANGLES) / TURN_SPEED
        elif self.state == "turn" and now >= self.state_end:
            self.state = "forward"
        v, w = {"forward": (FORWARD_SPEED, 0.0), "back": (BACK_SPEED, 0.0), "turn": (0.0, self.turn_rate)}[self.state]
        cmd = Twist()
        cmd.linear.x, cmd.angular.z = v, w
        self.cmd_pub.publish(cmd)


def main(args: list[str] | None = None) -> int:
    """Entry point ``create_bump_turn``."""
    return run_nodes(lambda: [BumpTurnNode()], args)


def demo(
    duration: float = 60.0,
    map_file: str | None = None,
    seed: int = 0,
    extra_nodes: Callable[[Context], Sequence[Node]] | None = None,
) -> dict[str, Any]:
    """Run the default world with this controller for ``duration`` sim seconds, as fast as the CPU
    allows, in this process; print and return a summary (distance driven, bumps, final pose).

    ``extra_nodes(context)`` adds nodes (a recorder, a viewer) to the same executor."""
    from rclpy.parameter import Parameter

    from create_sim.world_node import CreateWorldNode
    from sim_runtime.bag.record import wait_for_recorders
    from sim_runtime.run import drain, private_ros
    from sim_runtime.testing import wait_for_match

    # No localisation node runs in the demo: the world publishes the true map -> odom itself.
    overrides = [
        Parameter("real_time_factor", value=0.0),
        Parameter("seed", value=seed),
        Parameter("publish_map_tf", value=True),
    ]
    if map_file is not None:
        overrides.append(Parameter("map_file", value=str(map_file)))
    with private_ros() as (context, executor):
        world = CreateWorldNode(parameter_overrides=overrides, context=context)
        controller = BumpTurnNode(parameter_overrides=[Parameter("seed", value=seed)], context=context)
        nodes: list[Node] = [world, controller]
        if extra_nodes is not None:
            nodes += extra_nodes(context)
        for node in nodes:
            executor.add_node(node)
        wait_for_match(executor, controller.cmd_pub)
        for subscription in controller.subscriptions:
            wait_for_match(executor, subscription)
        wait_for_recorders(executor, nodes, world)
        start_wall = time.perf_counter()
        previous, distance = world.model.pose.copy(), 0.0
        for _ in range(round(duration * world.physics_rate)):
            world.step()
            drain(executor)
            pose = world.model.pose
            distance += math.hypot(pose[0] - previous[0], pose[1] - previous[1])
            previous = pose.copy()
        wall = time.perf_counter() - start_wall
        x, y, theta = (float(v) for v in world.model.pose)
        summary = {
            "sim_seconds": world.sim_time,
            "distance_m": distance,
            "bumps": controller.bumps,
            "final_pose": (x, y, theta),
            "wall_seconds": wall,
            "speed_vs_real_time": world.sim_time / wall if wall > 0 else math.inf,
        }
    print(
        f"create_bump_turn demo: {summary['sim_seconds']:.1f} s simulated in {wall:.1f} s "
        f"({summary['speed_vs_real_time']:.0f}x real time); drove {distance:.2f} m, "
        f"{controller.bumps} bumps; final pose x={x:.2f} m y={y:.2f} m theta={math.degrees(theta):.0f} deg"
    )
    return summary
