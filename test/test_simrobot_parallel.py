"""SIMROBOT on several threads: the same readings and poses, bit for bit, as on one."""

from __future__ import annotations

import math

import numba
import numpy as np
import pytest

from sim_runtime.errors import InputError
from simrobot_sim import model
from simrobot_sim.model import SimrobotWorld
from simrobot_sim.world_file import RobotSpec, SensorSpec, WorldSpec

SENSORS = (
    SensorSpec("sonar", "ultrasonic", position=(0.05, 0.0), range=0.4, rays=30),
    SensorSpec("scan", "laser", position=(0.0, 0.0), beamwidth=math.radians(270), range=1.0, rays=91),
)


def crowded_world(threads: int) -> SimrobotWorld:
    """60 robots packed on a 3 m x 3 m map with boxes: they see and hit each other and the walls."""
    rng = np.random.default_rng(7)
    walls = np.zeros((300, 300), dtype=bool)
    walls[0, :] = walls[-1, :] = walls[:, 0] = walls[:, -1] = True
    for _ in range(12):
        x, y = rng.integers(10, 260, 2)
        walls[x : x + rng.integers(5, 30), y : y + rng.integers(5, 30)] = True
    taken = walls.copy()
    robots = []
    while len(robots) < 60:
        x, y = rng.integers(8, 292, 2)
        if taken[x - 7 : x + 8, y - 7 : y + 8].any():
            continue
        taken[x - 7 : x + 8, y - 7 : y + 8] = True
        heading = float(rng.uniform(-math.pi, math.pi))
        robots.append(RobotSpec(f"r{len(robots)}", (x * 0.01, y * 0.01), heading=heading, sensors=SENSORS))
    return SimrobotWorld(WorldSpec(walls=walls, robots=tuple(robots)), threads=threads)


def run(world: SimrobotWorld, steps: int) -> list[np.ndarray]:
    rng = np.random.default_rng(11)
    seen = []
    for _ in range(steps):
        for i in range(len(world.names)):
            world.set_wheel_speeds(i, *rng.uniform(-2.0, 6.0, 2))
        world.step()
        seen += [world.poses(), world.crashed.copy(), world.grid.copy()]
        for k in range(len(world.sensors)):
            seen += [*world.ranges(k), np.array(world.nearest(k))]
    return seen


@pytest.mark.skipif(numba.config.NUMBA_NUM_THREADS < 2, reason="numba may use one thread only on this machine")
def test_one_and_two_threads_give_the_same_readings_poses_and_crashes(monkeypatch):
    # a small world, so make the parallel kernels run whatever its size
    monkeypatch.setattr(model, "PARALLEL_MIN_SENSORS", 0)
    monkeypatch.setattr(model, "PARALLEL_MIN_ROBOTS", 0)
    serial, parallel = crowded_world(threads=1), crowded_world(threads=2)
    assert (serial.threads, parallel.threads) == (1, 2)
    a, b = run(serial, 25), run(parallel, 25)
    assert serial.crashed.any() and not serial.crashed.all()  # the run met walls and robots
    assert len(a) == len(b)
    for x, y in zip(a, b, strict=True):
        assert np.array_equal(x, y)


def test_threads_default_to_every_core_and_must_be_a_count():
    walls = np.zeros((50, 50), dtype=bool)
    spec = WorldSpec(walls=walls, robots=(RobotSpec("a", (0.25, 0.25)),))
    assert SimrobotWorld(spec).threads == numba.config.NUMBA_NUM_THREADS
    with pytest.raises(InputError, match="threads: expected an integer >= 0"):
        SimrobotWorld(spec, threads=-1)


def test_the_world_file_sets_the_threads(tmp_path):
    from PIL import Image

    from simrobot_sim.world_file import load_world

    Image.fromarray(np.full((50, 50), 255, dtype=np.uint8)).convert("1").save(tmp_path / "map.png")
    path = tmp_path / "world.yaml"
    path.write_text("map: map.png\nthreads: 1\nrobots:\n  - {name: a, position: [0.25, 0.25]}\n")
    assert SimrobotWorld(load_world(path)).threads == 1
    path.write_text("map: map.png\nthreads: two\nrobots:\n  - {name: a, position: [0.25, 0.25]}\n")
    with pytest.raises(InputError, match=r"world\.yaml: threads: expected an integer >= 0 .*, got .two."):
        load_world(path)
