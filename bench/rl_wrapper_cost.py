"""What the Gymnasium wrappers cost over the bare models: env steps per CPU-second, one core.

    .venv/bin/python bench/rl_wrapper_cost.py

``robot_sims/CreateNav-v0`` (default sensors: 24 LIDAR beams, bumpers, goal; 10 physics steps per
env step) against the same work on ``CreateModel`` directly (set the command, 10 physics steps,
read the LIDAR, the bumpers and the odometry); ``robot_sims/ArmReach-v0`` against ``Arm.fkine``
alone. Best of 3 × 5,000 steps, CPU time of this process.
"""

from __future__ import annotations

import argparse
import time
from collections.abc import Callable

import numpy as np

from create_sim import spec
from create_sim.mapfile import load_map
from create_sim.model import CreateModel
from sim_runtime.paths import config_path
from sim_tools.rl.arm_reach import ArmReachEnv
from sim_tools.rl.create_nav import CreateNavEnv

STEPS = 5000
START = (-1.5, -1.0, 0.0)
ACTION = np.array([0.05, 0.3], dtype=np.float32)  # a slow circle: no bump, no goal


def rate(run: Callable[[], None]) -> float:
    """Steps per CPU-second, the best of 3 runs (after one warm-up)."""
    run()
    best = 0.0
    for _ in range(3):
        t = time.process_time()
        run()
        best = max(best, STEPS / (time.process_time() - t))
    return best


def create_rates() -> tuple[float, float]:
    env = CreateNavEnv(start=START, goal=(3.0, 1.0), max_steps=10**9)
    env.reset(seed=0)
    model = CreateModel(load_map(config_path("create/example.map")), pose=START)
    index, substeps = env.lidar_index, env.substeps

    def bare() -> None:
        for _ in range(STEPS):
            model.set_velocity(float(ACTION[0]), float(ACTION[1]))
            for _ in range(substeps):
                model.step(1.0 / spec.PHYSICS_RATE)
            model.lidar()[index], model.bumps(), model.odometry_pose

    def wrapped() -> None:
        for _ in range(STEPS):
            env.step(ACTION)

    return rate(bare), rate(wrapped)


def arm_rates() -> tuple[float, float]:
    env = ArmReachEnv("irb120", max_steps=10**9)
    env.reset(seed=0)
    still = np.zeros(env.arm.n, dtype=np.float32)

    def bare() -> None:
        for _ in range(STEPS):
            env.arm.fkine(env.q)

    def wrapped() -> None:
        for _ in range(STEPS):
            env.step(still)

    return rate(bare), rate(wrapped)


def main() -> None:
    argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter).parse_args()
    for name, (bare, wrapped) in (("CreateNav-v0", create_rates()), ("ArmReach-v0", arm_rates())):
        print(f"{name}: {wrapped:,.0f} env steps/s; bare model {bare:,.0f}/s; wrapper cost {bare / wrapped - 1:+.0%}")


if __name__ == "__main__":
    main()
