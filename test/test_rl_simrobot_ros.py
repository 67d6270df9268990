"""The SIMROBOT PettingZoo env and the ROS world in lockstep: the same actions, the same readings."""

from __future__ import annotations

from dataclasses import replace

import numpy as np
from geometry_msgs.msg import PoseStamped
from sensor_msgs.msg import JointState, LaserScan, Range

from sim_runtime.paths import config_path
from sim_runtime.qos import COMMAND_PUBLISHER_QOS, SENSOR_SUBSCRIBER_QOS
from sim_runtime.testing import Collector, spin_until, wait_for_match
from sim_tools.rl.simrobot_parallel import SimrobotParallelEnv
from simrobot_sim.world_file import load_world
from simrobot_sim.world_node import SimrobotWorldNode

WORLD = """\
map: {map}
resolution: 0.01
dt: 1.0
robots:
  - name: scout
    position: [0.5, 2.25]
    heading: 90
    sensors:
      - {{name: front, type: ultrasonic, position: [0.05, 0], axis: 0, beamwidth: 60, range: 0.30, rays: 30}}
      - {{name: scan, type: laser, position: [0, 0], axis: 0, beamwidth: 180, range: 1.0, rays: 9}}
  - name: rover
    position: [1.38, 3.45]
    heading: -90
    sensors:
      - {{name: front, type: ultrasonic, position: [0.05, 0], axis: 0, beamwidth: 60, range: 0.30, rays: 30}}
"""
STEPS = 60


def published_observation(got: dict, robot: str, sensors: list[tuple[str, str, float]], step: int) -> np.ndarray:
    """The robot's observation as the env normalises it, read from the world's messages of ``step``."""
    parts = []
    for name, kind, max_range in sensors:
        msg = got[f"/{robot}/{name}"].last
        assert msg.header.stamp.sec == step
        metres = np.array(msg.ranges if kind == "laser" else [msg.range], dtype=float)
        parts.append(np.minimum(metres / max_range, 1.0))
    return np.concatenate(parts).astype(np.float32)


def test_an_action_sequence_through_the_env_and_the_lockstep_ros_world_gives_the_same_readings(
    executor, make_node, tmp_path
) -> None:
    path = tmp_path / "world.yaml"
    path.write_text(WORLD.format(map=config_path("simrobot/demo_map.png")))
    env = SimrobotParallelEnv(str(path), max_steps=STEPS)
    obs, _ = env.reset()
    world = SimrobotWorldNode(replace(load_world(path), lockstep=True, lockstep_timeout=30.0))
    executor.add_node(world)
    node = make_node("rl_twin")
    spec = env.spec_file
    sensors = {r.name: [(s.name, s.kind, s.range) for s in r.sensors] for r in spec.robots}
    got = {}
    for robot, listed in sensors.items():
        for name, kind, _ in listed:
            topic = f"/{robot}/{name}"
            got[topic] = Collector(node, LaserScan if kind == "laser" else Range, topic, SENSOR_SUBSCRIBER_QOS)
        got[f"/{robot}/pose"] = Collector(node, PoseStamped, f"/{robot}/pose", SENSOR_SUBSCRIBER_QOS)
    wheels = {r: node.create_publisher(JointState, f"/{r}/wheel_cmd", COMMAND_PUBLISHER_QOS) for r in sensors}
    assert all(wait_for_match(executor, c.subscription) for c in got.values())
    assert all(wait_for_match(executor, p) for p in wheels.values())
    world.republish()
    rng = np.random.default_rng(5)
    crashes = 0
    for step in range(STEPS + 1):
        assert spin_until(executor, lambda s=step: all(c.msgs and c.last.header.stamp.sec == s for c in got.values()))
        for robot in obs:
            expected = published_observation(got, robot, sensors[robot], step)
            np.testing.assert_allclose(obs[robot], expected, rtol=1e-6, atol=1e-7, err_msg=f"{robot}, step {step}")
            pose = got[f"/{robot}/pose"].last.pose.position
            assert (pose.x, pose.y) == tuple(env.world.poses()[env.world.index[robot], :2])
        if not env.agents:
            break
        actions = {a: rng.uniform(0.3, 1.0, 2).astype(np.float32) for a in env.agents}  # mostly forward
        for agent, action in actions.items():
            wheels[agent].publish(JointState(velocity=[float(v) for v in action]))
        assert spin_until(executor, world.ready_to_step)
        world.step()
        obs, _, terms, _, _ = env.step(actions)
        crashes += sum(terms.values())
    assert crashes >= 1  # the run covered a crash
