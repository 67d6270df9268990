"""A fingerprint of everything a SIMROBOT run observes, to prove a refactoring changed nothing.

Two runs through the public model API only (no ROS):

* the shipped demo world, four robots running alg2 in the model (nearer than 0.20 m: wheels
  [0, 0.5], else [0.5, 0.5]) for 300 steps;
* the scale benchmark's world with 100 robots (two sonars and a 181-ray laser each) at random
  wheel speeds, 40 steps (robots meet walls and each other).

Every step it collects every sensor's readings (distances in metres and obstacle numbers), every
pose and the crash flags, and prints one SHA-256 per run. Run it on two checkouts and compare the
digests; ``--save FILE.npz`` keeps the raw arrays to find where two runs part.

Run: ``.venv/bin/python bench/simrobot_readings.py [--save out.npz]``
"""

from __future__ import annotations

import argparse
import hashlib
import sys
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent.parent))

from bench.simrobot_scale import drive, scene
from sim_runtime.paths import config_path
from simrobot_sim.model import SimrobotWorld
from simrobot_sim.world_file import load_world


def observe(world: SimrobotWorld) -> list[np.ndarray]:
    """Every reading, pose and crash flag of the world's current step."""
    out = [world.poses().copy(), world.crashed.astype(np.int64)]
    for k in range(len(world.sensors)):
        dist, value = world.ranges(k)
        out += [np.asarray(dist, dtype=float).copy(), np.asarray(value, dtype=np.int64).copy()]
        near = world.nearest(k)
        out.append(np.array([near[0], float(near[1])]))
    return out


def demo_run(steps: int = 300, **world_kw) -> list[np.ndarray]:
    world = SimrobotWorld(load_world(config_path("simrobot/demo.yaml")), **world_kw)
    sonar = [next(k for k, s in enumerate(world.sensors) if s.robot == i) for i in range(len(world.names))]
    rows = []
    for _ in range(steps):
        rows += observe(world)
        for i, k in enumerate(sonar):
            dist, _ = world.nearest(k)
            world.set_wheel_speeds(i, *((0.0, 0.5) if dist < 0.20 else (0.5, 0.5)))
        world.step()
    rows += observe(world)
    return rows


def crowd_run(n: int = 100, steps: int = 40, **world_kw) -> list[np.ndarray]:
    world = SimrobotWorld(scene(n), **world_kw)
    drive(world)
    rows = []
    for _ in range(steps):
        world.step()
        rows += observe(world)
    return rows


def digest(rows: list[np.ndarray]) -> str:
    h = hashlib.sha256()
    for a in rows:
        h.update(np.ascontiguousarray(a).tobytes())
    return h.hexdigest()


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--save", help="write the raw arrays to this .npz")
    parser.add_argument("--threads", type=int, help="threads of the worlds (default: all cores)")
    args = parser.parse_args()
    kw = {} if args.threads is None else {"threads": args.threads}
    runs = {"demo": demo_run(**kw), "crowd": crowd_run(**kw)}
    for name, rows in runs.items():
        print(f"{name:<6} {digest(rows)}  ({len(rows)} arrays)")
    if args.save:
        np.savez(args.save, **{f"{name}_{i}": a for name, rows in runs.items() for i, a in enumerate(rows)})


if __name__ == "__main__":
    main()
