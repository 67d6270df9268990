"""``sensor_model: original``: the original SIMROBOT's sensor rules, checked on small bitmaps whose
answers follow from those rules by hand (cell indices; our cell k spans [k, k+1), so the cell
holding a point is the original's nearest cell centre)."""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pytest
from PIL import Image

from sim_runtime.errors import InputError
from simrobot_sim import raycast
from simrobot_sim.model import SimrobotWorld
from simrobot_sim.world_file import RobotSpec, SensorSpec, WorldSpec, load_world

CELL = 0.01


def one_ray(matrix: np.ndarray, ox: float, oy: float, angle: float, max_range: float) -> tuple[float, int]:
    """The original's reading of one ray from the point (ox, oy) (cells)."""
    fan = raycast.Fan(ox, oy, np.array([[math.cos(angle), math.sin(angle)]]), angle, 0.0, max_range, 0)
    t, v = np.empty(1), np.empty(1, dtype=np.int64)
    raycast.cast_scan_original(matrix, fan, t, v)
    return float(t[0]), int(v[0])


def exact_ray(matrix: np.ndarray, ox: float, oy: float, angle: float, max_range: float) -> tuple[float, int]:
    return raycast.cast_ray_exact(matrix, ox, oy, math.cos(angle), math.sin(angle), max_range, 0)


def test_the_distance_runs_from_the_sensor_cell_centre_to_the_hit_cell_centre():
    grid = np.zeros((30, 30), dtype=np.uint8)
    grid[20:, :] = 1  # a wall from x = 20 on
    # sensor at (5.3, 5.8): its cell is (5, 5); the ray along +x first meets cell (20, 5)
    assert one_ray(grid, 5.3, 5.8, 0.0, 20.0) == (20 - 5, 1)
    # ours: from the exact point to where the ray enters the wall
    assert exact_ray(grid, 5.3, 5.8, 0.0, 20.0) == (pytest.approx(20 - 5.3), 1)


def test_a_ray_tests_the_next_cell_along_x_so_it_sees_a_wall_beside_it():
    grid = np.zeros((30, 30), dtype=np.uint8)
    grid[6, 8] = 1  # one cell to the right of a ray going straight up from cell (5, 5)
    # steps (5, 6), (5, 7), (5, 8): after each, cell (6, y) too; (6, 8) is the hit
    assert one_ray(grid, 5.5, 5.5, math.pi / 2, 10.0) == (pytest.approx(math.hypot(1, 3)), 1)
    assert exact_ray(grid, 5.5, 5.5, math.pi / 2, 10.0)[1] == 0  # our ray stays in column 5


def test_a_ray_can_echo_one_cell_beyond_its_range():
    grid = np.zeros((30, 30), dtype=np.uint8)
    grid[21:, :] = 1
    # range 15 from cell (5, 5) ends at cell (20, 5); the next cell along x, (21, 5), is tested too
    assert one_ray(grid, 5.5, 5.5, 0.0, 15.0) == (16.0, 1)
    assert exact_ray(grid, 5.5, 5.5, 0.0, 15.0)[1] == 0


def test_the_ray_ends_at_a_rounded_end_point_which_turns_it():
    grid = np.zeros((30, 30), dtype=np.uint8)
    grid[13, 7] = 1
    # 10 degrees, range 10 from cell (5, 5): end (5 + 9.85, 5 + 1.74) rounds to (15, 7). The
    # Bresenham line (5,5)-(15,7) runs (6,5) (7,5) (8,6) ... (12,6) (13,7): the wall at step 8.
    angle = math.radians(10.0)
    assert one_ray(grid, 5.5, 5.5, angle, 10.0) == (pytest.approx(math.hypot(13 - 5, 7 - 5)), 1)
    # the true 10 degree ray from the cell centre passes below cell (13, 7): y = 6.82 to 7.0 there
    assert exact_ray(grid, 5.5, 5.5, angle, 10.0)[1] == 0


def test_a_bresenham_ray_slips_through_a_diagonal_wall_at_its_first_step():
    grid = np.zeros((30, 30), dtype=np.uint8)
    grid[6, 5] = grid[5, 6] = 1  # two wall cells touching at a corner, across a 45 degree ray
    # from cell (5, 5) the line steps diagonally to (6, 6); the cells beside the first step are
    # never tested (only the cell after a step and its neighbour along x)
    assert one_ray(grid, 5.2, 5.5, math.pi / 4, 10.0) == (math.inf, 0)
    t, v = exact_ray(grid, 5.2, 5.5, math.pi / 4, 10.0)
    assert v == 1 and t == pytest.approx(0.5 * math.sqrt(2))  # ours enters (5, 6) at y = 6


def test_an_obstacle_in_the_sensor_cell_is_read_at_distance_zero():
    grid = np.zeros((30, 30), dtype=np.uint8)
    grid[5, 5] = 1
    assert one_ray(grid, 5.5, 5.5, 0.0, 10.0) == (0.0, 1)


def walled(nx: int = 200, ny: int = 100) -> np.ndarray:
    walls = np.zeros((nx, ny), dtype=bool)
    walls[0, :] = walls[-1, :] = walls[:, 0] = walls[:, -1] = True
    return walls


def test_a_world_with_the_original_model_reads_centre_to_centre_in_metres():
    walls = walled()
    walls[70:, :] = True
    sonar = SensorSpec("s", "ultrasonic", position=(0.05, 0.0), beamwidth=0.0, range=0.30, rays=1)
    robot = RobotSpec("a", (0.503, 0.506), sensors=(sonar,))
    original = SimrobotWorld(WorldSpec(walls=walls, robots=(robot,), sensor_model="original"))
    exact = SimrobotWorld(WorldSpec(walls=walls, robots=(robot,)))
    # the sensor point (55.3, 50.6) lies in cell (55, 50); the wall starts at cell 70
    assert original.read("a", "s") == (pytest.approx((70 - 55) * CELL), 1)
    assert exact.read("a", "s") == (pytest.approx((70 - 55.3) * CELL), 1)


def test_the_original_model_sees_other_robots_by_id_but_never_its_own():
    laser = SensorSpec("scan", "laser", position=(0.0, 0.0), beamwidth=0.0, range=0.30, rays=1)
    sonar = SensorSpec("s", "ultrasonic", position=(0.05, 0.0), beamwidth=0.0, range=0.30, rays=1)
    a = RobotSpec("a", (0.503, 0.506), sensors=(laser, sonar))
    b = RobotSpec("b", (0.755, 0.505))  # the default shape reaches back to x = 73.5: cell 73
    world = SimrobotWorld(WorldSpec(walls=walled(), robots=(a, b), sensor_model="original"))
    dist, value = world.read("a", "scan")  # from the pivot's cell (50, 50), inside robot a
    assert (dist[0], value[0]) == (pytest.approx((73 - 50) * CELL), 3)
    assert world.read("a", "s") == (pytest.approx((73 - 55) * CELL), 3)


def test_the_original_fan_runs_from_minus_half_the_beamwidth_and_leaves_out_the_left_edge():
    laser = SensorSpec("scan", "laser", position=(0.0, 0.0), beamwidth=math.radians(60), range=0.30, rays=30)
    robot = RobotSpec("a", (0.5, 0.5), heading=math.radians(90), sensors=(laser,))
    world = SimrobotWorld(WorldSpec(walls=walled(), robots=(robot,), sensor_model="original"))
    offsets = np.degrees(world.ray_angles(0) - math.radians(90))
    assert offsets == pytest.approx([-30 + 2 * k for k in range(30)])
    info = world.sensors[0]
    assert (math.degrees(info.angle_min), math.degrees(info.angle_max)) == pytest.approx((-30, 28))
    assert math.degrees(info.angle_increment) == pytest.approx(2.0)
    exact = SimrobotWorld(WorldSpec(walls=walled(), robots=(robot,)))
    assert np.degrees(exact.ray_angles(0) - math.radians(90)) == pytest.approx(np.linspace(-30, 30, 30))


def write_world(tmp_path: Path, text: str) -> Path:
    Image.fromarray(np.full((100, 200), 255, dtype=np.uint8)).convert("1").save(tmp_path / "map.png")
    path = tmp_path / "world.yaml"
    path.write_text("map: map.png\n" + text)
    return path


def test_the_world_file_chooses_the_sensor_model_and_refuses_unknown_ones(tmp_path):
    robot = "robots:\n  - {name: a, position: [0.5, 0.5]}\n"
    assert load_world(write_world(tmp_path, robot)).sensor_model == "exact"
    assert load_world(write_world(tmp_path, "sensor_model: original\n" + robot)).sensor_model == "original"
    with pytest.raises(InputError, match=r"world\.yaml: sensor_model: expected one of exact, original, got 'matlab'"):
        load_world(write_world(tmp_path, "sensor_model: matlab\n" + robot))


def test_readable_robot_keys_stand_for_r_la_and_lb(tmp_path):
    text = "robots:\n  - {name: a, position: [0.5, 0.5], wheel_radius: 0.02, half_track: 0.04, axle_offset: 0.01}\n"
    r = load_world(write_world(tmp_path, text)).robots[0]
    assert (r.R, r.la, r.lb) == (0.02, 0.04, 0.01)
    old = "robots:\n  - {name: a, position: [0.5, 0.5], R: 0.02, la: 0.04, lb: 0.01}\n"
    assert load_world(write_world(tmp_path, old)).robots[0] == r
    with pytest.raises(InputError, match=r"'half_track' and 'la' are the same field"):
        load_world(write_world(tmp_path, "robots:\n  - {name: a, position: [0.5, 0.5], half_track: 0.04, la: 0.04}\n"))
    with pytest.raises(InputError, match=r"\('a'\)\.wheel_radius: must be > 0"):
        load_world(write_world(tmp_path, "robots:\n  - {name: a, position: [0.5, 0.5], wheel_radius: -1}\n"))
