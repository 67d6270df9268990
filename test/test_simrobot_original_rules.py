"""``sensor_model: original``: the end-point rounding and the Bresenham tie rule of the original's C
code, each on a hand-made case where the rule changes the reading (cell indices: ours count from 0,
the original's from 1, so the original's coordinate is ours + 1)."""

from __future__ import annotations

import math

import numpy as np
import pytest
from rclpy.parameter import Parameter

from sim_runtime.errors import InputError
from simrobot_sim import raycast
from simrobot_sim.model import SimrobotWorld
from simrobot_sim.world_file import RobotSpec, SensorSpec, WorldSpec
from simrobot_sim.world_node import SimrobotWorldNode


def reading(matrix: np.ndarray, cell: tuple[int, int], direction: tuple[float, float], reach: float):
    """The original model's reading of one ray from the centre of ``cell``."""
    norm = math.hypot(*direction)
    unit = np.array([[direction[0] / norm, direction[1] / norm]])
    fan = raycast.Fan(cell[0] + 0.5, cell[1] + 0.5, unit, math.atan2(direction[1], direction[0]), 0.0, reach, 0)
    t, v = np.empty(1), np.empty(1, dtype=np.int64)
    raycast.cast_scan_original(matrix, fan, t, v)
    return float(t[0]), int(v[0])


@pytest.mark.parametrize(
    ("cell", "reach", "end"),
    [
        (10, 4.4, 14),  # original 15.4 -> 15: down below a half
        (10, 4.5, 15),  # original 15.5 -> 16: a half goes up
        (2, -3.3, -2),  # original -0.3 -> -1: a negative coordinate goes down (halves-up: 0)
        (2, -3.7, -2),  # original -0.7 -> -1: as halves-up
        (2, -3.5, -2),  # original -0.5 -> -1 (halves-up: 0)
        (2, -4.0, -2),  # original -1.0 stays -1
        (195, -234.3, -40),  # original -38.3 -> -39 (halves-up: -38)
    ],
)
def test_an_end_point_rounds_like_the_originals_c_code_so_negative_coordinates_round_down(cell, reach, end):
    assert raycast.original_end_cell(cell, reach) == end


def test_a_ray_ending_beyond_the_bottom_edge_takes_the_line_to_the_rounded_down_end_cell():
    grid = np.zeros((30, 10), dtype=np.uint8)
    grid[11, 2] = 1
    # from cell (10, 3) at range 10 towards (0.9028, -0.43): the original's end is (11 + 9.03,
    # 4 - 4.3) = (20.03, -0.3), rounded to (20, -1): our cell (19, -2). Its line (dx 9, dy 5)
    # steps first to (11, 2), the wall, one diagonal step away.
    direction = (math.sqrt(1.0 - 0.43**2), -0.43)
    assert reading(grid, (10, 3), direction, 10.0) == (pytest.approx(math.sqrt(2.0)), 1)
    # rounding halves up would end at (19, -1): that line (dx 9, dy 4) starts (11, 3), (12, 2) ...
    # and its cells and their neighbours along x never include (11, 2)
    assert raycast.cast_ray_original(grid, 10, 3, 19, -1, 0) == (math.inf, 0)


def test_at_an_exact_midpoint_an_x_major_line_steps_along_x_only():
    grid = np.zeros((30, 30), dtype=np.uint8)
    grid[6, 5] = 1
    # (5, 5) to (9, 7): dx 4, dy 2, the decision 2·dy - dx is 0 at the first step (a tie): the
    # original goes to (6, 5), straight along x, and finds the wall at distance 1
    assert raycast.cast_ray_original(grid, 5, 5, 9, 7, 0) == (1.0, 1)
    assert reading(grid, (5, 5), (4.0, 2.0), math.hypot(4.0, 2.0)) == (1.0, 1)
    # then (7, 6), a tie again at (8, 6), and (9, 7): cells and their neighbours along x
    path = np.zeros((30, 30), dtype=np.uint8)
    for x, y in ((7, 6), (8, 6), (9, 7)):
        path[:] = 0
        path[x, y] = 1
        assert raycast.cast_ray_original(path, 5, 5, 9, 7, 0) == (pytest.approx(math.hypot(x - 5, y - 5)), 1)


def test_at_an_exact_midpoint_a_y_major_line_steps_along_y_only():
    grid = np.zeros((30, 30), dtype=np.uint8)
    grid[5, 6] = 1
    # (5, 5) to (7, 9): dx 2, dy 4, a tie at the first step: (5, 6), straight up
    assert raycast.cast_ray_original(grid, 5, 5, 7, 9, 0) == (1.0, 1)
    diagonal = np.zeros((30, 30), dtype=np.uint8)
    diagonal[6, 6] = 1  # where a diagonal first step would land: now only the neighbour along x
    assert raycast.cast_ray_original(diagonal, 5, 5, 7, 9, 0) == (pytest.approx(math.hypot(1, 1)), 1)
    diagonal[6, 6] = 0
    diagonal[7, 6] = 1  # the diagonal step's neighbour along x is never tested
    assert raycast.cast_ray_original(diagonal, 5, 5, 7, 9, 0)[1] == 0


def test_a_45_degree_line_steps_diagonally_every_time():
    grid = np.zeros((30, 30), dtype=np.uint8)
    grid[8, 8] = 1
    grid[6, 5] = grid[5, 6] = 1  # beside the first diagonal step: never tested
    assert raycast.cast_ray_original(grid, 5, 5, 10, 10, 0) == (pytest.approx(math.hypot(3, 3)), 1)


def test_an_outline_is_every_vertex_cell_joined_by_the_originals_midpoint_lines():
    out = np.empty(100, dtype=np.int64)
    # a square of cells (2..6, 2..6): 16 outline cells, none of the 9 inside
    n, outside = raycast.polygon_outline_cells(
        np.array([2.5, 6.5, 6.5, 2.5]), np.array([2.5, 2.5, 6.5, 6.5]), 30, 30, out
    )
    cells = {(int(c) // 30, int(c) % 30) for c in out[:n]}
    assert not outside
    assert cells == {(x, y) for x in range(2, 7) for y in range(2, 7)} - {
        (x, y) for x in range(3, 6) for y in range(3, 6)
    }
    # a triangle whose edge (0, 0)-(4, 2) has ties: along x to (1, 0), then (2, 1), along x to (3, 1), (4, 2)
    n, _ = raycast.polygon_outline_cells(np.array([0.5, 4.5, 0.5]), np.array([0.5, 2.5, 2.5]), 30, 30, out)
    cells = {(int(c) // 30, int(c) % 30) for c in out[:n]}
    assert {(1, 0), (2, 1), (3, 1), (4, 2)} <= cells
    assert (1, 1) not in cells  # where a symmetric line would step first, diagonally at the tie


def walled(nx: int = 200, ny: int = 100) -> np.ndarray:
    walls = np.zeros((nx, ny), dtype=bool)
    walls[0, :] = walls[-1, :] = walls[:, 0] = walls[:, -1] = True
    return walls


def two_robots(**options) -> SimrobotWorld:
    """Robot a (pivot in cell (50, 50), the default shape: nose at x = 54.3) with a laser at its pivot
    and a sonar at its nose, and robot b further along +x (its back edge in cell 73)."""
    laser = SensorSpec("scan", "laser", position=(0.0, 0.0), beamwidth=0.0, range=0.30, rays=1)
    nose = SensorSpec("nose", "ultrasonic", position=(0.04, 0.0), beamwidth=0.0, range=0.30, rays=1)
    a = RobotSpec("a", (0.503, 0.506), sensors=(laser, nose))
    b = RobotSpec("b", (0.755, 0.505))
    return SimrobotWorld(WorldSpec(walls=walled(), robots=(a, b), sensor_model="original"), **options)


def test_outline_bodies_occupy_their_outline_only_and_sensors_see_through_the_inside():
    filled = two_robots()
    outline = two_robots(outline_bodies=True)
    assert filled.grid[50, 50] == 2 and outline.grid[50, 50] == 0  # a's pivot cell, inside its body
    assert outline.grid[54, 50] == 2  # the nose vertex's cell
    assert 0 < np.count_nonzero(outline.grid == 2) < np.count_nonzero(filled.grid == 2)
    # from inside the outline a's laser reaches b (never its own robot, by default)
    distance, value = outline.read("a", "scan")
    assert (distance[0], value[0]) == (pytest.approx((73 - 50) * 0.01), 3)


def test_a_sensor_that_sees_its_own_robot_reads_its_outline_and_zero_on_it():
    world = two_robots(outline_bodies=True, see_own_robot=True)
    distance, value = world.read("a", "scan")  # from the pivot's cell to the nose's: the own outline
    assert (distance[0], value[0]) == (pytest.approx((54 - 50) * 0.01), 2)
    assert world.read("a", "nose") == (0.0, 2)  # the sensor's own cell is on the outline
    world.step()  # robots still move: their own outline is no obstacle to themselves


def test_seeing_the_own_robot_needs_the_original_sensor_model():
    robot = RobotSpec("a", (0.5, 0.5))
    with pytest.raises(InputError, match="sensor_model: original"):
        SimrobotWorld(WorldSpec(walls=walled(), robots=(robot,)), see_own_robot=True)


def test_the_world_nodes_parameters_choose_outline_bodies_and_seeing_the_own_robot(ros):
    robot = RobotSpec("a", (0.5, 0.5))
    original = WorldSpec(walls=walled(), robots=(robot,), sensor_model="original")
    on = [Parameter("outline_bodies", value=True), Parameter("see_own_robot", value=True)]
    node = SimrobotWorldNode(original, parameter_overrides=on)
    try:
        assert node.model.outline_bodies and node.model.see_own_robot
    finally:
        node.destroy_node()
    exact = WorldSpec(walls=walled(), robots=(robot,))
    with pytest.raises(InputError, match="see_own_robot"):
        SimrobotWorldNode(exact, parameter_overrides=[Parameter("see_own_robot", value=True)])
