"""``sensor_model: original``: the end-point rounding and the Bresenham tie rule of the original's C
code, each on a hand-made case where the rule changes the reading (cell indices: ours count from 0,
the original's from 1, so the original's coordinate is ours + 1)."""

from __future__ import annotations

import math

import numpy as np
import pytest

from simrobot_sim import raycast


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
