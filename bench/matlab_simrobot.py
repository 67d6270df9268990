"""SIMROBOT's demo (4 robots, 300 steps) with every robot driven by an algorithm m-file in GNU Octave.

The same world three ways: the Python alg2 rule in this process (the reference), the alg2-style
m-file through one Octave session (``simrobot_sim.matlab_alg``, one ``oct2py`` call per step for
all four robots), and the ROS world node from a world file with ``algorithm:`` lines, in lockstep
as fast as it goes. Tracks must be identical; the times are wall seconds (Octave's time is in
another process), with the Octave start separate. Prints ``uptime`` first: the machine is shared.

Run: ``.venv/bin/python bench/matlab_simrobot.py [--steps 300]``
"""

from __future__ import annotations

import argparse
import subprocess
import sys
import time
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent.parent))

from sim_runtime.paths import config_path
from simrobot_sim.avoid import STRAIGHT, THRESHOLD, TURN
from simrobot_sim.matlab_alg import OctaveAlgorithms, start_octave
from simrobot_sim.model import SimrobotWorld
from simrobot_sim.world_file import load_world

ALG2 = config_path("simrobot/avoid_alg.m")


def demo() -> SimrobotWorld:
    return SimrobotWorld(load_world(config_path("simrobot/demo.yaml")))


def python_run(steps: int) -> tuple[np.ndarray, float]:
    world = demo()
    start = time.perf_counter()
    for _ in range(steps):
        for i in range(4):
            world.set_wheel_speeds(i, *(TURN if world.nearest(i)[0] < THRESHOLD else STRAIGHT))
        world.step()
    return world.history.array(), time.perf_counter() - start


def octave_run(steps: int) -> tuple[np.ndarray, float, float]:
    world = demo()
    start = time.perf_counter()
    session = start_octave()
    algorithms = OctaveAlgorithms(world, dict.fromkeys(range(4), ALG2), session=session)
    started = time.perf_counter()
    for _ in range(steps):
        algorithms.run()
        world.step()
    done = time.perf_counter()
    algorithms.close()
    return world.history.array(), started - start, done - started


def node_run(steps: int) -> tuple[np.ndarray, float]:
    import rclpy
    from rclpy.parameter import Parameter

    from sim_runtime.run import make_executor, spin_steps
    from simrobot_sim.world_node import SimrobotWorldNode

    # the shipped world file with algorithm lines
    rclpy.init()
    executor = make_executor()
    world = SimrobotWorldNode(parameter_overrides=[Parameter("world_file", value="simrobot/demo_matlab.yaml")])
    executor.add_node(world)
    start = time.perf_counter()
    spin_steps(executor, world, steps)
    took = time.perf_counter() - start
    history = world.model.history.array()
    executor.remove_node(world)
    world.destroy_node()
    executor.shutdown()
    rclpy.shutdown()
    return history, took


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--steps", type=int, default=300)
    steps = parser.parse_args().steps
    print(subprocess.run(["uptime"], capture_output=True, text=True).stdout.strip())
    reference, py_s = python_run(steps)
    tracks, start_s, oct_s = octave_run(steps)
    node_tracks, node_s = node_run(steps)
    same = np.array_equal(reference, tracks) and np.array_equal(reference, node_tracks)
    print(f"4 robots x {steps} steps; tracks identical to the Python alg2: {same}")
    print(f"python alg2 in-process: {py_s:.3f} s ({py_s / steps * 1e3:.2f} ms/step)")
    print(f"octave m-file:          {oct_s:.3f} s ({oct_s / steps * 1e3:.2f} ms/step), Octave start {start_s:.2f} s")
    print(f"world node, lockstep:   {node_s:.3f} s ({node_s / steps * 1e3:.2f} ms/step)")
    print(subprocess.run(["uptime"], capture_output=True, text=True).stdout.strip())


if __name__ == "__main__":
    main()
