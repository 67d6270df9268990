"""What publishing /tf costs the Create world node: real-time factor with TF on vs off.

Run:  ROS_AUTOMATIC_DISCOVERY_RANGE=LOCALHOST .venv/bin/python bench/tf_cost.py [--budget SECONDS]

The world runs at real_time_factor 0 on the benchmark map of bench/create_world.py with every
sensor at its default rate, a listener in another process subscribed to every topic it publishes
(/tf included when on). "Off" is the world as it runs without tf2_msgs. Goal: TF costs < 10 %.
Runs alternate off/on three times; the best of each is compared, by wall clock and by the world
process's CPU time (which other processes on a loaded machine disturb less).
"""

from __future__ import annotations

import argparse
import os
import sys
import tempfile
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent))
from create_world import bench_node, free_poses, random_map, write_map


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--budget", type=float, default=3.0, help="wall seconds per measurement")
    args = parser.parse_args()
    world = random_map()
    pose = free_poses(world, 1)[0]
    with tempfile.TemporaryDirectory() as folder:
        path = write_map(world, folder)
        off, on = [], []
        for _ in range(3):
            off.append(bench_node(path, pose, args.budget, subscribed=True, tf=False))
            on.append(bench_node(path, pose, args.budget, subscribed=True, tf=True))
    print(f"load average {os.getloadavg()[0]:.2f}")
    print("create_world, every topic subscribed by another process, real_time_factor 0 (best of 3 runs):")
    for label, pick in (("wall clock", float), ("per CPU second of the world's process", lambda r: r.cpu)):
        best_off, best_on = max(pick(r) for r in off), max(pick(r) for r in on)
        print(
            f"  {label}: TF off {best_off:6.1f}x real time, TF on {best_on:6.1f}x real time: "
            f"TF costs {100 * (1 - best_on / best_off):.1f} % (goal < 10 %)"
        )


if __name__ == "__main__":
    main()
