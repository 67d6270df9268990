"""A world compiles (or loads from numba's cache) every kernel it can use before it is ready: a
subscriber joining later, to any sensor, never makes it compile and stall (a ~2 s /clock gap when
an RViz joined a running Create world). The timing itself is measured by ``bench/first_start.py``.

Each world is probed in a fresh process (kernels a test before it used would be in memory already
and prove nothing): the probe builds the node, notes every kernel's compiled signatures, subscribes
to every topic the node publishes, steps it, and prints the signatures that appeared after that."""

from __future__ import annotations

import json
import os
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

from sim_runtime.kernels import COMPILING_NOTICE, announce_compiling

ROOT = Path(__file__).resolve().parent.parent


def kernel_signatures() -> dict[str, int]:
    """Every numba kernel of our packages loaded in this process, with how many signatures it has."""
    from numba.core.registry import CPUDispatcher

    counts = {}
    for name, module in list(sys.modules.items()):
        if module is None or not name.startswith(("create_sim", "simrobot_sim", "arm_sim", "sim_runtime")):
            continue
        for attribute, value in vars(module).items():
            if isinstance(value, CPUDispatcher):
                counts[f"{name}.{attribute}"] = len(value.overloads)
    return counts


def probe(world_name: str) -> dict[str, list[str]]:
    """In this process: the kernels that gained a signature after ``world_name``'s node was built."""
    import rclpy
    from rclpy.qos import qos_profile_sensor_data

    from sim_runtime.paths import config_path
    from sim_runtime.run import drain, make_executor
    from sim_runtime.testing import spin_until

    rclpy.init()
    if world_name == "create_world":
        from create_sim.world_node import CreateWorldNode

        world = CreateWorldNode()
    elif world_name == "arm":
        from arm_sim.arm_node import ArmNode

        world = ArmNode()
    else:
        from simrobot_sim.world_file import load_world
        from simrobot_sim.world_node import SimrobotWorldNode

        world = SimrobotWorldNode(load_world(config_path("simrobot/demo.yaml")))
    before = kernel_signatures()
    listener = rclpy.create_node("listener")
    executor = make_executor()
    executor.add_node(world)
    executor.add_node(listener)
    for topic, types in world.get_publisher_names_and_types_by_node(world.get_name(), world.get_namespace()):
        module, _, name = types[0].replace("/msg/", "/").partition("/")
        msg_type = getattr(__import__(f"{module}.msg", fromlist=[name]), name)
        listener.create_subscription(msg_type, topic, lambda _msg: None, qos_profile_sensor_data)
    assert spin_until(executor, lambda: all(p.get_subscription_count() for p in world.publishers), 30.0)
    for _ in range(30):
        drain(executor)
        world.step()
    drain(executor)
    after = kernel_signatures()
    return {"new": sorted(k for k, n in after.items() if n > before.get(k, 0)), "checked": sorted(before)}


@pytest.mark.parametrize("world_name", ["create_world", "simrobot_world", "arm"])
def test_a_subscriber_joining_a_running_world_makes_it_compile_no_kernel(world_name):
    done = subprocess.run(
        [sys.executable, __file__, world_name],
        cwd=ROOT,
        env=dict(os.environ, PYTHONPATH=str(ROOT)),
        capture_output=True,
        text=True,
        timeout=600,
    )
    assert done.returncode == 0, done.stderr
    result = json.loads(done.stdout.splitlines()[-1])
    assert result["new"] == [], f"compiled or loaded after the node was ready: {result['new']}"
    assert len(result["checked"]) >= 8  # the probe saw the world's kernels


def test_the_compiling_notice_comes_only_when_numba_really_compiles():
    import numba

    said: list[str] = []
    with announce_compiling(said.append):
        kernel = numba.njit(lambda x: x + 1)  # never cached: compiled here
        kernel(1)
        kernel(2)  # the same signature again: nothing more
    assert said[0] == COMPILING_NOTICE
    assert said[1].startswith("kernels compiled in ")
    said.clear()
    with announce_compiling(said.append):
        kernel(3)  # already compiled: silent
    assert said == []


if __name__ == "__main__":
    print(json.dumps(probe(sys.argv[1])))


def small_world():
    from simrobot_sim.model import SimrobotWorld
    from simrobot_sim.world_file import RobotSpec, SensorSpec, WorldSpec

    walls = np.zeros((60, 60), dtype=bool)
    walls[0, :] = walls[-1, :] = walls[:, 0] = walls[:, -1] = True
    sonar = SensorSpec("s", "ultrasonic", beamwidth=0.5, range=0.2, rays=5)
    return SimrobotWorld(WorldSpec(walls=walls, robots=(RobotSpec("a", (0.3, 0.3), sensors=(sonar,)),)))


def test_a_cold_simrobot_world_has_its_sensing_compiled_by_a_helper_process_meanwhile(monkeypatch):
    import numba

    from sim_runtime import kernels

    world = small_world()
    world.step()  # its kernels now in this process, whatever the cache held
    started: list[subprocess.Popen] = []
    real_start = kernels._start_helper

    def start(pickled: bytes, method: str) -> subprocess.Popen:
        started.append(helper := real_start(pickled, method))
        return helper

    monkeypatch.setattr(kernels, "_start_helper", start)
    with kernels.compiled_aside(world, "sense"):
        world.step()  # nothing to compile: no helper
    assert started == []
    with kernels.compiled_aside(world, "sense"):
        numba.njit(lambda x: x * 2)(3)  # a kernel numba really compiles: the cache is cold
    assert len(started) == 1
    assert started[0].returncode == 0  # waited for; the helper unpickled the world and sensed it
