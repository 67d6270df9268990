"""How many robots a SIMROBOT world holds, on one thread and on all cores.

Every robot: the original's shape, 2 ultrasonic sensors (30 rays, 60 degrees, 0.5 m: front and rear)
and one laser (181 rays, 180 degrees, 2 m), driving with random wheel speeds on a 10 m x 10 m map
at 1 cm (1000 x 1000 cells, border + 60 rectangles).

1. Model alone (step + every sensor cast) at N = 10, 100, 1000 (1000 needs the uint16 matrix),
   one thread (CPU time).
1b. The same on one thread and on every core side by side (wall time: CPU time would add the
   threads up), with the ratio: the parallel model's speed-up on this machine now.
2. World node at 10 Hz (dt = 0.1 s): one ``step()`` = physics + sensing + every topic published
   (3 sensor topics + 2 obstacle + odom + pose per robot, /robots, /clock). CPU ms per step for
   growing N; "holds 10 Hz" = under 100 ms per step. The node keeps the original's uint8 ids
   (<= 254 robots).
3. History memory over 100k steps (10 robots): flat, capped at ``history_steps``.

Times are CPU seconds of this process (``time.process_time``), best of the repeats.
Run: ``ROS_AUTOMATIC_DISCOVERY_RANGE=LOCALHOST .venv/bin/python bench/simrobot_scale.py``
"""

from __future__ import annotations

import argparse
import math
import os
import sys
import time
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent.parent))
os.environ.setdefault("ROS_AUTOMATIC_DISCOVERY_RANGE", "LOCALHOST")

from simrobot_sim.model import SimrobotWorld
from simrobot_sim.world_file import RobotSpec, SensorSpec, WorldSpec

SENSORS = (
    SensorSpec("sonar_front", "ultrasonic", position=(0.05, 0.0), beamwidth=math.radians(60), range=0.5, rays=30),
    SensorSpec(
        "sonar_rear", "ultrasonic", position=(-0.03, 0.0), axis=math.pi, beamwidth=math.radians(60), range=0.5, rays=30
    ),
    SensorSpec("laser", "laser", position=(0.0, 0.0), beamwidth=math.radians(180), range=2.0, rays=181),
)


def scene_walls(seed: int = 0) -> np.ndarray:
    rng = np.random.default_rng(seed)
    walls = np.zeros((1000, 1000), dtype=bool)
    walls[0, :] = walls[-1, :] = walls[:, 0] = walls[:, -1] = True
    for _ in range(60):
        x, y = rng.integers(0, 950, 2)
        w, h = rng.integers(10, 80, 2)
        walls[x : x + w, y : y + h] = True
    return walls


def scene(n: int, dt: float = 0.1, history_steps: int = 10000, seed: int = 1) -> WorldSpec:
    """``n`` robots placed at random free spots (rejection sampling on a coarse occupancy)."""
    rng = np.random.default_rng(seed)
    walls = scene_walls()
    taken = walls.copy()
    robots = []
    while len(robots) < n:
        x, y = rng.integers(10, 990, 2)
        if taken[x - 6 : x + 7, y - 6 : y + 7].any():
            continue
        taken[x - 6 : x + 7, y - 6 : y + 7] = True
        robots.append(
            RobotSpec(
                f"r{len(robots)}", (x * 0.01, y * 0.01), heading=float(rng.uniform(-math.pi, math.pi)), sensors=SENSORS
            )
        )
    return WorldSpec(walls=walls, robots=tuple(robots), dt=dt, history_steps=history_steps)


def drive(world: SimrobotWorld, seed: int = 2) -> None:
    rng = np.random.default_rng(seed)
    world.vel[:] = rng.uniform(0.0, 5.0, world.vel.shape)  # up to 5 rad/s x 1 cm = 5 cm/s


def model_rate(n: int, steps: int, threads: int = 1, clock=time.process_time) -> float:
    world = SimrobotWorld(scene(n), wide_ids=n > 254, threads=threads)
    drive(world)

    def one() -> None:
        world.step()
        world.sense()

    one()
    best = math.inf
    for _ in range(3):
        t = clock()
        for _ in range(steps):
            one()
        best = min(best, (clock() - t) / steps)
    return 1.0 / best


def parallel_table() -> None:
    import numba

    cores = numba.config.NUMBA_NUM_THREADS
    print(f"\nmodel alone, 1 thread vs {cores} threads side by side (wall time, best of 3), steps/s:")
    print(f"{'N':>6}{'1 thread':>11}{f'{cores} threads':>12}{'ratio':>8}{'load (1 min)':>14}")
    for n, steps in ((100, 20), (1000, 5)):
        serial = parallel = 0.0
        for _ in range(2):  # alternate, so both see the same load
            serial = max(serial, model_rate(n, steps, 1, time.perf_counter))
            parallel = max(parallel, model_rate(n, steps, 0, time.perf_counter))
        print(f"{n:>6}{serial:>11.1f}{parallel:>12.1f}{parallel / serial:>8.2f}{os.getloadavg()[0]:>14.2f}")


def node_step_ms(n: int, steps: int = 10) -> float:
    from simrobot_sim.world_node import SimrobotWorldNode

    world = SimrobotWorldNode(scene(n))
    try:
        drive(world.model)
        world.step(2)
        best = math.inf
        for _ in range(3):
            t = time.process_time()
            world.step(steps)
            best = min(best, (time.process_time() - t) / steps)
        return best * 1000.0
    finally:
        world.destroy_node()


def current_rss_mb() -> float:
    """Resident memory of this process now (Linux), in MB."""
    with open("/proc/self/status") as status:
        for line in status:
            if line.startswith("VmRSS:"):
                return int(line.split()[1]) / 1024.0
    return math.nan


def history_memory() -> list[tuple[int, int, float]]:
    world = SimrobotWorld(scene(10, history_steps=10000))
    drive(world)
    rows = []
    for k in range(1, 100001):
        world.step()
        if k in (1000, 10000, 50000, 100000):
            rows.append((k, world.history.nbytes() // len(world.names), current_rss_mb()))
    return rows


def main() -> None:
    import rclpy

    argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter).parse_args()
    print("model alone (step + all sensors), 2 ultrasonic x 30 rays + laser x 181 rays per robot:")
    print(f"{'N':>6}{'steps/s':>12}{'ms/step':>10}{'us/robot':>10}")
    for n, steps in ((10, 50), (100, 20), (1000, 5)):
        rate = model_rate(n, steps)
        print(f"{n:>6}{rate:>12.1f}{1000 / rate:>10.2f}{1e6 / rate / n:>10.1f}")

    print("load average (1, 5, 15 min): {:.2f} {:.2f} {:.2f} on {} CPUs".format(*os.getloadavg(), os.cpu_count()))
    parallel_table()

    print("\nworld node at 10 Hz (physics + sensing + all topics), CPU ms per step:")
    print(f"{'N':>6}{'ms/step':>10}{'holds 10 Hz':>13}")
    rclpy.init()
    try:
        largest = 0
        for n in (10, 50, 100, 150, 200, 254):
            ms = node_step_ms(n)
            ok = ms < 100.0
            largest = n if ok else largest
            print(f"{n:>6}{ms:>10.1f}{'yes' if ok else 'no':>13}")
            if not ok:
                break
        print(f"largest N tried that holds 10 Hz on one core: {largest}")
    finally:
        rclpy.shutdown()

    print("load average (1, 5, 15 min): {:.2f} {:.2f} {:.2f}".format(*os.getloadavg()))

    print("\nhistory memory, 10 robots, history_steps = 10000:")
    print(f"{'steps':>8}{'bytes/robot':>13}{'RSS MB':>12}")
    for k, per_robot, rss in history_memory():
        print(f"{k:>8}{per_robot:>13}{rss:>12.0f}")


if __name__ == "__main__":
    main()
