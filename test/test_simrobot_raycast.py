"""The fast caster agrees with the exact grid traversal on random maps with robots."""

from __future__ import annotations

import math

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from simrobot_sim import raycast
from simrobot_sim.model import SimrobotWorld
from simrobot_sim.world_file import RobotSpec, SensorSpec, WorldSpec


def random_walls(rng: np.random.Generator, nx: int, ny: int, rects: int, specks: int) -> np.ndarray:
    walls = np.zeros((nx, ny), dtype=bool)
    for _ in range(rects):
        x, y = rng.integers(0, nx), rng.integers(0, ny)
        w, h = rng.integers(1, 25, 2)
        walls[x : x + w, y : y + h] = True
    walls.flat[rng.integers(0, nx * ny, specks)] = True
    return walls


@pytest.mark.parametrize("seed", range(6))
def test_fast_caster_matches_exact_on_random_maps_with_robots(seed):
    rng = np.random.default_rng(seed)
    nx, ny = int(rng.integers(60, 260)), int(rng.integers(60, 260))
    walls = random_walls(rng, nx, ny, rects=int(rng.integers(5, 40)), specks=int(rng.integers(0, 300)))
    robots = []
    # a wide laser, a 180 degree one looking back and a narrow sonar: the three ways the caster
    # picks the robots a fan can see (no sector test, half-plane, cone)
    sensors = (
        SensorSpec("scan", "laser", position=(0.05, 0.0), beamwidth=math.radians(300), range=1.5, rays=181),
        SensorSpec("rear", "laser", position=(-0.03, 0.0), axis=math.pi, beamwidth=math.pi, range=1.0, rays=91),
        SensorSpec("sonar", "ultrasonic", position=(0.05, 0.0), range=0.4, rays=30),
    )
    while len(robots) < 25:
        x, y = rng.uniform(0.05, nx / 100 - 0.05), rng.uniform(0.05, ny / 100 - 0.05)
        spec = RobotSpec(
            f"r{len(robots)}",
            (x, y),
            heading=rng.uniform(-math.pi, math.pi),
            scale=float(rng.uniform(0.5, 3.0)),
            sensors=sensors,
        )
        try:  # placement rejects robots on walls or on each other: keep drawing
            SimrobotWorld(WorldSpec(walls=walls, robots=(*robots, spec)))
        except ValueError:
            continue
        robots.append(spec)
    world = SimrobotWorld(WorldSpec(walls=walls, robots=tuple(robots)))
    agree = hits = 0
    for step in range(3):
        world.sense()
        for k, s in enumerate(world.sensors):
            ox, oy, _ = world.sensor_origin(k)
            angles = world.ray_angles(k)
            dirs = np.column_stack([np.cos(angles), np.sin(angles)])
            exact_t = np.empty(len(angles))
            exact_v = np.empty(len(angles), dtype=np.int64)
            raycast.cast_scan_exact(
                world.grid, ox / 0.01, oy / 0.01, dirs, s.range / 0.01, s.robot + 2, exact_t, exact_v
            )
            got_t, got_v = world.ranges(k)
            got_t = got_t / 0.01
            both = np.isfinite(exact_t) & np.isfinite(got_t)
            # a miss and a hit may differ only at the very end of the range
            one = np.isfinite(exact_t) != np.isfinite(got_t)
            assert np.all(np.minimum(exact_t[one], got_t[one]) > s.range / 0.01 - 1.0), (step, k)
            assert np.all(np.abs(exact_t[both] - got_t[both]) <= 1.0), (step, k)
            same = both & (np.abs(np.where(both, exact_t, 0.0) - np.where(both, got_t, 0.0)) < 1e-6)
            assert np.array_equal(exact_v[same], got_v[same]), (step, k)
            agree += int(same.sum())
            hits += int(np.isfinite(exact_t).sum())
        for i in range(len(robots)):
            world.set_wheel_speeds(i, *rng.uniform(-3, 3, 2))
        world.step()
    assert hits > 0 and agree >= 0.99 * hits  # in practice the two casters give the same numbers


@settings(max_examples=40, deadline=None)
@given(
    seed=st.integers(0, 2**31 - 1),
    angle=st.floats(-math.pi, math.pi),
    ox=st.floats(0.0, 99.999),
    oy=st.floats(0.0, 99.999),
)
def test_fast_and_exact_single_rays_agree(seed, angle, ox, oy):
    rng = np.random.default_rng(seed)
    grid = random_walls(rng, 100, 100, rects=15, specks=100).astype(np.uint8)
    clear = raycast.clearance_field(grid == 1)
    d = np.array([[math.cos(angle), math.sin(angle)]])
    et, ev, ft, fv = np.empty(1), np.empty(1, np.int64), np.empty(1), np.empty(1, np.int64)
    raycast.cast_scan_exact(grid, ox, oy, d, 150.0, 0, et, ev)
    fan = raycast.Fan(ox, oy, d, angle, 0.0, 150.0, 0)
    raycast.cast_scan_fast(raycast.Occupancy(grid, clear), fan, raycast.no_candidates(), ft, fv)
    if math.isfinite(et[0]):
        assert ft[0] == pytest.approx(et[0], abs=1.0)
    else:
        assert not math.isfinite(ft[0])


def test_exact_caster_cannot_slip_between_diagonal_cells():
    grid = np.zeros((20, 20), dtype=np.uint8)
    grid[10, 10] = grid[11, 11] = 1  # cells touching only at the corner (11, 11)
    t, v = raycast.cast_ray_exact(grid, 5.0, 5.0, math.sqrt(0.5), math.sqrt(0.5), 30.0, 0)
    assert v == 1 and t == pytest.approx(math.hypot(5.0, 5.0))
    assert raycast.cast_ray_plain_bresenham_python(grid.tolist(), 5.0, 5.0, math.pi / 4, 30.0)[1] == 1


def test_squared_distance_transform_is_exact():
    rng = np.random.default_rng(3)
    occ = rng.random((37, 23)) < 0.05
    d = raycast.squared_distance_transform(occ)
    pts = np.argwhere(occ)
    ii, jj = np.meshgrid(np.arange(37), np.arange(23), indexing="ij")
    brute = ((ii[..., None] - pts[:, 0]) ** 2 + (jj[..., None] - pts[:, 1]) ** 2).min(-1)
    assert np.array_equal(d, brute)
