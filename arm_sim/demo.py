"""Arm demo for ``make demo``: the IRB120 follows a joint trajectory, then a target pose.

Runs in-process on its own rclpy context: an :class:`ArmNode` and a commander node that sends
the commands over the real topics; the world is stepped with ``node.step`` (deterministic).
``python -m arm_sim.demo [OUT_DIR]`` prints the summary and, with OUT_DIR, draws the final pose.
"""

from __future__ import annotations

import sys
from collections.abc import Callable, Sequence
from pathlib import Path
from typing import Any

import numpy as np

from arm_sim.arm import Arm
from arm_sim.spec import END_EFFECTOR_POSE_TOPIC, JOINT_STATES_TOPIC

TRAJECTORY = [  # (seconds from start, joint positions in rad)
    (1.0, [0.5, 0.2, -0.3, 0.0, 0.6, 0.0]),
    (2.0, [0.8, 0.4, 0.1, 0.5, -0.4, 1.0]),
    (3.0, [0.0, 0.3, -0.2, 0.0, 0.9, 0.0]),
]
TARGET_Q = [-0.6, 0.35, 0.25, 0.3, 0.7, -0.2]  # the target pose is the flange pose here


def run_demo(
    out_dir: str | Path | None = None, extra_nodes: Callable[[Any], Sequence[Any]] | None = None
) -> dict[str, Any]:
    """Run the demo; returns a summary (errors in m/rad, sim time, messages received, PNG path).

    ``extra_nodes(context)`` adds nodes (a recorder, a viewer) to the demo's executor."""
    from builtin_interfaces.msg import Duration
    from geometry_msgs.msg import PoseStamped
    from rclpy.node import Node
    from sensor_msgs.msg import JointState
    from trajectory_msgs.msg import JointTrajectory, JointTrajectoryPoint

    from arm_sim.arm_node import ArmNode
    from sim_runtime.bag.record import wait_for_recorders
    from sim_runtime.msgs import quaternion_from_matrix
    from sim_runtime.qos import COMMAND_PUBLISHER_QOS, SENSOR_SUBSCRIBER_QOS
    from sim_runtime.run import private_ros
    from sim_runtime.testing import Collector, drain, spin_until, wait_for_match

    nodes: list[Node] = []
    with private_ros() as (context, executor):
        world = ArmNode(context=context)
        commander = Node("arm_demo_commander", context=context)
        nodes += [world, commander]
        if extra_nodes is not None:
            nodes += extra_nodes(context)
        for node in nodes:
            executor.add_node(node)
        arm = world.arm("")
        states = Collector(commander, JointState, JOINT_STATES_TOPIC, SENSOR_SUBSCRIBER_QOS)
        poses = Collector(commander, PoseStamped, END_EFFECTOR_POSE_TOPIC, SENSOR_SUBSCRIBER_QOS)
        traj_pub = commander.create_publisher(JointTrajectory, "joint_trajectory", COMMAND_PUBLISHER_QOS)
        pose_pub = commander.create_publisher(PoseStamped, "target_pose", COMMAND_PUBLISHER_QOS)
        for endpoint in (states.subscription, poses.subscription, traj_pub, pose_pub):
            wait_for_match(executor, endpoint)
        wait_for_recorders(executor, nodes, world)

        def run(seconds: float) -> None:
            for _ in range(int(round(seconds / world.physics_dt))):
                world.step()
                drain(executor)

        msg = JointTrajectory(joint_names=list(arm.arm.joint_names))
        for t, q in TRAJECTORY:
            msg.points.append(JointTrajectoryPoint(positions=q, time_from_start=Duration(sec=int(t))))
        traj_pub.publish(msg)
        spin_until(executor, lambda: np.allclose(arm.motion.goal, TRAJECTORY[-1][1]))
        run(TRAJECTORY[-1][0] + 0.5)
        trajectory_error = float(np.abs(np.array(states.last.position) - TRAJECTORY[-1][1]).max())

        target = arm.arm.fkine(np.array(TARGET_Q))
        pose = PoseStamped()
        pose.header.frame_id = world.frame_id
        pose.pose.position.x, pose.pose.position.y, pose.pose.position.z = target[:3, 3].tolist()
        pose.pose.orientation = quaternion_from_matrix(target[:3, :3])
        pose_pub.publish(pose)
        spin_until(executor, lambda: arm.motion.moving)
        run(3.0)
        reached = poses.last.pose.position
        target_error = float(
            np.linalg.norm([reached.x - target[0, 3], reached.y - target[1, 3], reached.z - target[2, 3]])
        )
        summary = {
            "sim_time_s": round(world.sim_time, 3),
            "joint_states_received": len(states.msgs),
            "trajectory_final_error_rad": trajectory_error,
            "target_position_error_m": target_error,
            "final_q": [round(v, 4) for v in arm.motion.q.tolist()],
            "peak_speed_fraction": float(
                max(np.max(np.abs(m.velocity) / arm.arm.velocity_limits) for m in states.msgs)
            ),
        }
        if out_dir is not None:
            summary["png"] = str(draw_arm(arm.arm, arm.motion.q, Path(out_dir) / "arm_demo.png"))
        return summary


def draw_arm(arm: Arm, q: np.ndarray, path: Path) -> Path:
    """Render the arm's meshes at q with matplotlib (the original's view limits and camera)."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    from mpl_toolkits.mplot3d.art3d import Poly3DCollection

    path.parent.mkdir(parents=True, exist_ok=True)
    fig = plt.figure(figsize=(7, 6))
    ax = fig.add_subplot(projection="3d")
    for element, T in zip(arm.elements, arm.element_poses(q), strict=True):
        world = element.triangles @ T[:3, :3].T.astype(np.float32) + T[:3, 3].astype(np.float32)
        ax.add_collection3d(Poly3DCollection(world, facecolor=element.element.color, edgecolor="none"))
    view = arm.config.view
    ax.set_xlim(*view.limits[0:2])
    ax.set_ylim(*view.limits[2:4])
    ax.set_zlim(*view.limits[4:6])
    ax.set_box_aspect(
        [view.limits[1] - view.limits[0], view.limits[3] - view.limits[2], view.limits[5] - view.limits[4]]
    )
    # MATLAB's azimuth is measured from -y, matplotlib's from +x
    ax.view_init(elev=view.elevation, azim=view.azimuth - 90)
    ax.set_title(f"{arm.name} after the demo")
    fig.savefig(path, dpi=90)
    plt.close(fig)
    return path


if __name__ == "__main__":
    print(run_demo(sys.argv[1] if len(sys.argv) > 1 else None))
