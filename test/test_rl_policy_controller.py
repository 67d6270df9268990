"""A learned policy back in ROS: ``robot_sims policy_controller`` drives a ``create_world`` as the
policy drove the environment, and runs in ``robot_sims batch`` as a controller of ours."""

from __future__ import annotations

import subprocess
import sys
from pathlib import Path

import numpy as np
from rclpy.parameter import Parameter
from test_batch import ROOT, batch, rows, write_sweep

from sim_runtime.paths import config_path
from sim_runtime.testing import spin_until
from sim_tools.adapters.contract import world_part
from sim_tools.rl.create_nav import CreateNavEnv
from sim_tools.rl.create_sensors import goal_in_odom
from sim_tools.rl.policy import MlpPolicy
from sim_tools.rl.policy_controller import PolicyControllerNode

START = (-1.5, -1.0, 0.3)
GOAL = (1.0, 0.5)
SENSORS = ("lidar", "sonar", "bump", "goal")
STEPS = 30


def _policy(folder: Path, env: CreateNavEnv) -> Path:
    """A fixed random policy (seeded): what it does does not matter, only that both sides agree."""
    options = {"sensors": list(SENSORS), "lidar_beams": 16, "control_period_s": 0.1}
    policy = MlpPolicy.for_env(env, (8,), env_id="robot_sims/CreateNav-v0", **options)
    params = np.random.default_rng(5).normal(scale=0.5, size=policy.n_params)
    return policy.with_params(params).save(folder / "policy.npz")


def test_the_policy_as_a_ros_node_sends_the_world_the_commands_it_chose_in_the_env(executor, tmp_path):
    files = {"map": str(config_path("create/example.map")), "config": str(config_path("create/ideal_config.txt"))}
    env = CreateNavEnv(files["map"], files["config"], sensors=SENSORS, lidar_beams=16, start=START, goal=GOAL)
    path = _policy(tmp_path, env)
    world = world_part("create").make_world(files, START, [Parameter("real_time_factor", value=0.0)])
    node = PolicyControllerNode(
        parameter_overrides=[Parameter("policy", value=str(path)), Parameter("goal", value=list(GOAL))]
    )
    sent = []
    node.cmd_pub.publish = lambda msg, publish=node.cmd_pub.publish: (
        sent.append((msg.linear.x, msg.angular.z)),
        publish(msg),
    )
    executor.add_node(world)
    executor.add_node(node)
    assert spin_until(executor, lambda: world.count_subscribers("/scan") > 0 and world.count_publishers("/cmd_vel") > 0)
    obs, _info = env.reset(seed=0)
    obs, *_ = env.step(np.zeros(2, dtype=np.float32))  # the world's first period: no command yet
    world.step(env.substeps)
    for k in range(1, STEPS + 1):
        assert spin_until(executor, lambda k=k: node.actions == k and world.commands_received == k), f"step {k}"
        action = node.policy.act(obs)
        assert np.allclose(sent[-1], action, atol=1e-5), f"step {k}: the node sent {sent[-1]}, the env chose {action}"
        obs, _r, terminated, _t, _info = env.step(action)
        world.step(env.substeps)
        if terminated:
            break
    assert k > 10 and np.allclose(world.model.pose[:2], env.model.pose[:2], atol=1e-4)


def _constant_policy(folder: Path, name: str, v: float) -> Path:
    """A goal-only policy that always drives at ``v`` (m/s: ±0.5, the wheels' limit) straight on."""
    env = CreateNavEnv(sensors=("goal",))
    policy = MlpPolicy.for_env(env, (), env_id="robot_sims/CreateNav-v0", sensors=["goal"])
    params = np.zeros(policy.n_params)
    params[-2] = 20.0 * np.sign(v)  # the v output's bias: tanh → ±1 → ±0.5 m/s
    return policy.with_params(params).save(folder / name)


def test_the_policy_controller_stops_at_the_goal_and_stays_there(executor, tmp_path):
    files = {"map": str(config_path("create/example.map")), "config": str(config_path("create/ideal_config.txt"))}
    path = _constant_policy(tmp_path, "forward.npz", 0.5)
    start, goal = (-1.5, -1.0, 0.0), (-0.5, -1.0)  # 1 m straight ahead; the forward policy drives through it
    world = world_part("create").make_world(files, start, [Parameter("real_time_factor", value=0.0)])
    node = PolicyControllerNode(
        parameter_overrides=[Parameter("policy", value=str(path)), Parameter("goal", value=list(goal))]
    )
    executor.add_node(world)
    executor.add_node(node)
    assert spin_until(executor, lambda: world.count_subscribers("/odom") > 0 and world.count_publishers("/cmd_vel") > 0)
    world.step(10)
    for k in range(1, 61):  # 6 s: 2 s would have taken it to the goal, 6 s 2 m past it
        assert spin_until(executor, lambda k=k: node.actions == k and world.commands_received == k), f"step {k}"
        world.step(10)
    x, y, _theta = world.model.pose
    assert node.at_goal
    assert np.hypot(goal[0] - x, goal[1] - y) <= 0.3  # it stopped in the region (its entry side)
    assert world.model.velocity == (0.0, 0.0)


def test_the_goal_in_the_odometry_frame_is_where_the_map_goal_is_seen_from_the_start():
    # odometry (0, 0, 0) at the start: the goal as seen from the start pose
    assert np.allclose(goal_in_odom((1.0, 2.0), (1.0, 1.0, np.pi / 2), np.zeros(3)), (1.0, 0.0))
    # later the odometry has moved with the robot: the same odometry frame
    assert np.allclose(goal_in_odom((1.0, 2.0), (1.0, 1.5, np.pi / 2), np.array([0.5, 0.0, 0.0])), (1.0, 0.0))


def test_without_a_policy_file_the_executable_says_what_to_give_and_exits_2():
    done = subprocess.run(
        [str(Path(sys.executable).with_name("robot_sims")), "policy_controller"],
        capture_output=True,
        text=True,
        timeout=60,
        cwd=ROOT,
    )
    assert done.returncode == 2 and "policy:=FILE.npz" in done.stderr, done.stderr


def test_a_policy_file_runs_in_a_batch_sweep_as_a_controller_of_ours(tmp_path):
    env = CreateNavEnv(sensors=SENSORS, lidar_beams=16)
    _policy(tmp_path, env)
    sweep = write_sweep(
        tmp_path,
        "sweep.yaml",
        """
        worlds: [{map: create/example.map}]
        controllers:
          - create_bump_turn
          - {name: learned, use: policy_controller, parameters: {policy: policy.npz, goal: [1.0, 0.5]}}
        poses: [[-1.5, -1.0, 0.3]]
        duration_s: 3
        metrics: [distance_m, {goal_time_s: {center: [1.0, 0.5]}}]
        """,
    )
    done = batch(str(sweep), "--workers", "1", "--out", "out", "--no-plots", cwd=tmp_path)
    assert done.returncode == 0, done.stderr
    table = {r["controller"]: r for r in rows(tmp_path / "out" / "episodes.csv")}
    assert table["learned"]["status"] == "ok", table["learned"]["error"]
    assert float(table["learned"]["distance_m"]) > 0.05  # it drove


def test_in_a_batch_a_policy_reversing_into_a_wall_has_a_collision_and_no_bump(tmp_path):
    _constant_policy(tmp_path, "reverse.npz", -0.5)
    sweep = write_sweep(
        tmp_path,
        "sweep.yaml",
        """
        worlds: [{map: create/example.map}]
        controllers:
          - {name: reverse, use: policy_controller, parameters: {policy: reverse.npz, goal: [3.0, 0.0]}}
        poses: [[-1.74, 0.0, 0.0]]  # 0.26 m from the outer wall at x = -2, its back to it
        duration_s: 3
        metrics: [bumps, collisions, min_clearance_m]
        """,
    )
    done = batch(str(sweep), "--workers", "1", "--out", "out", "--no-plots", cwd=tmp_path)
    assert done.returncode == 0, done.stderr
    (row,) = rows(tmp_path / "out" / "episodes.csv")
    assert row["status"] == "ok", row["error"]
    assert int(row["collisions"]) == 1 and int(row["bumps"]) == 0 and float(row["min_clearance_m"]) == 0.0
