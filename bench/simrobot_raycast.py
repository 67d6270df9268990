"""Ray-casting speed on the issue's reference scene, single thread.

Scene: 1000 x 1000 cells, border + 60 random rectangles, 20 robots (the original's shape at scale 3,
24 cm long, or at the scale given as the first argument) each with a 683-ray, 240 degree laser of
range 560 cells (13,660 rays per frame). Casters:

* fast   — simrobot_sim's caster as the world uses it (clearance-field jumps, free discs reused
           across a scan, exact traversal near walls, exact robot tests): ``SimrobotWorld.sense``;
* exact  — numba Amanatides-Woo, one cell per step (the reference);
* python — a plain 8-connected Bresenham in plain Python (a speed baseline, not the original's
           sensor rules; on one scan only: it is slow).

Times are CPU seconds of this process (``time.process_time``), best of several repeats, so other
load on a shared machine inflates them less. Run: ``.venv/bin/python bench/simrobot_raycast.py [scale]``
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

from simrobot_sim import raycast
from simrobot_sim.model import SimrobotWorld
from simrobot_sim.world_file import RobotSpec, SensorSpec, WorldSpec

N_CELLS = 1000
N_RECTS = 60
N_ROBOTS = 20
RAYS = 683
RANGE_CELLS = 560
ROBOT_SCALE = 3.0


def reference_scene(seed: int = 0, scale: float = ROBOT_SCALE) -> SimrobotWorld:
    """The benchmark world (resolution 0.01 m, so 560 cells = 5.6 m)."""
    rng = np.random.default_rng(seed)
    walls = np.zeros((N_CELLS, N_CELLS), dtype=bool)
    walls[0, :] = walls[-1, :] = walls[:, 0] = walls[:, -1] = True
    for _ in range(N_RECTS):
        x, y = rng.integers(0, N_CELLS - 50, 2)
        w, h = rng.integers(10, 80, 2)
        walls[x : x + w, y : y + h] = True
    laser = SensorSpec(
        "scan", "laser", position=(0.0, 0.0), beamwidth=math.radians(240), range=RANGE_CELLS * 0.01, rays=RAYS
    )
    robots: list[RobotSpec] = []
    while len(robots) < N_ROBOTS:
        spec = RobotSpec(
            f"r{len(robots)}",
            tuple(rng.uniform(0.2, N_CELLS * 0.01 - 0.2, 2)),
            heading=float(rng.uniform(-math.pi, math.pi)),
            scale=scale,
            sensors=(laser,),
        )
        try:
            SimrobotWorld(WorldSpec(walls=walls, robots=(*robots, spec)))
        except ValueError:
            continue  # on a wall or another robot: draw again
        robots.append(spec)
    return SimrobotWorld(WorldSpec(walls=walls, robots=tuple(robots)))


def best_cpu(fn, repeats: int) -> float:
    best = math.inf
    for _ in range(repeats):
        t = time.process_time()
        fn()
        best = min(best, time.process_time() - t)
    return best


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("scale", nargs="?", type=float, default=ROBOT_SCALE, help="robots' scale (default 3)")
    world = reference_scene(scale=parser.parse_args().scale)
    n_rays = N_ROBOTS * RAYS
    scans = []
    for k in range(len(world.sensors)):
        ox, oy, _ = world.sensor_origin(k)
        angles = world.ray_angles(k)
        scans.append((ox / 0.01, oy / 0.01, angles, np.column_stack([np.cos(angles), np.sin(angles)]), k + 2))
    exact_t = np.empty(n_rays)
    exact_v = np.empty(n_rays, dtype=np.int64)

    def fast() -> None:
        world._sensed_at = -1  # force a fresh cast of every sensor
        world.sense()

    def exact() -> None:
        for k, (ox, oy, _, dirs, rid) in enumerate(scans):
            sl = slice(k * RAYS, (k + 1) * RAYS)
            raycast.cast_scan_exact(world.grid, ox, oy, dirs, float(RANGE_CELLS), rid, exact_t[sl], exact_v[sl])

    rows = world.grid.tolist()

    def python_one_scan() -> None:
        ox, oy, angles, _, rid = scans[0]
        for a in angles:
            raycast.cast_ray_plain_bresenham_python(rows, ox, oy, float(a), float(RANGE_CELLS), rid)

    fast()
    exact()  # compile / load cached machine code before timing
    t_fast = best_cpu(fast, 7)
    t_exact = best_cpu(exact, 5)
    t_py = best_cpu(python_one_scan, 2)
    fast_rps = n_rays / t_fast
    exact_rps = n_rays / t_exact
    py_rps = RAYS / t_py

    f = np.isfinite(exact_t)
    fast_t = np.concatenate([world.ranges(k)[0] for k in range(len(world.sensors))]) / 0.01
    agree = np.isfinite(fast_t) == f
    diff = np.abs(np.where(f, exact_t, 0.0) - np.where(f, fast_t, 0.0))
    print(
        f"scene: {N_CELLS}x{N_CELLS} cells, {N_RECTS} rectangles, {N_ROBOTS} robots, "
        f"{RAYS}-ray laser, range {RANGE_CELLS} cells; {n_rays} rays per frame"
    )
    print(f"{'caster':<34}{'rays/s':>14}{'fast is':>12}")
    print(f"{'fast (clearance jumps + discs)':<34}{fast_rps:>14,.0f}{'':>12}")
    print(f"{'numba exact traversal (per cell)':<34}{exact_rps:>14,.0f}{fast_rps / exact_rps:>11.1f}x")
    print(f"{'plain-Python Bresenham (baseline)':<34}{py_rps:>14,.0f}{fast_rps / py_rps:>11.0f}x")
    print(
        f"agreement with exact: {agree.mean() * 100:.2f}% same hit/miss, max |difference| "
        f"{diff[f & agree].max():.2e} cells, mean hit distance {exact_t[f].mean():.0f} cells"
    )
    print(
        "load average (1, 5, 15 min) after the runs: {:.2f} {:.2f} {:.2f} on {} CPUs (other processes share "
        "them: run a few times, keep the best)".format(*os.getloadavg(), os.cpu_count())
    )
    goals = (fast_rps >= 5e6, fast_rps >= 3 * exact_rps, fast_rps >= 100 * py_rps)
    print("goals (>= 5M rays/s, >= 3x exact, >= 100x python):", ", ".join("met" if g else "MISSED" for g in goals))


if __name__ == "__main__":
    main()
