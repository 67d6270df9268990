"""The Create world's walls as a latched nav_msgs/OccupancyGrid on ``map`` (and the rasteriser behind it)."""

from __future__ import annotations

import math

import numpy as np
import pytest
from nav_msgs.msg import OccupancyGrid
from rclpy.parameter import Parameter

from create_sim.geometry import MAX_MAP_CELLS, WALL_THICKNESS_M, rasterise_walls
from create_sim.world_node import CreateWorldNode
from sim_runtime.errors import InputError
from sim_runtime.qos import LATCHED_QOS
from sim_runtime.testing import Collector, spin_until, wait_for_match

ROOM = "wall -2 -2 2 -2\nwall 2 -2 2 2\nwall 2 2 -2 2\nwall -2 2 -2 -2\n"


def cell_value(grid: OccupancyGrid, x: float, y: float) -> int:
    """The grid's value at point (x, y) of ``map``, by map_server's conventions."""
    info = grid.info
    column = math.floor((x - info.origin.position.x) / info.resolution)
    row = math.floor((y - info.origin.position.y) / info.resolution)
    assert 0 <= column < info.width and 0 <= row < info.height, (x, y)
    return grid.data[row * info.width + column]


@pytest.fixture
def world(executor, tmp_path):
    map_file = tmp_path / "room.map"
    map_file.write_text(ROOM)
    node = CreateWorldNode(parameter_overrides=[Parameter("map_file", value=str(map_file))])
    executor.add_node(node)
    return node


def latest_grid(executor, make_node) -> Collector:
    """A late subscriber (transient local), waiting for the latched grid."""
    grids = Collector(make_node("map_probe"), OccupancyGrid, "map", LATCHED_QOS)
    assert wait_for_match(executor, grids.subscription)
    assert spin_until(executor, lambda: grids.last is not None), "no latched map"
    return grids


def test_a_late_subscriber_gets_the_walls_as_an_occupancy_grid_in_the_map_frame(world, executor, make_node):
    world.step(5)
    grid = latest_grid(executor, make_node).last
    info = grid.info
    assert grid.header.frame_id == "map"
    assert info.resolution == pytest.approx(0.05)
    # origin: the lower-left corner of the cell holding the lowest wall (grown by half its thickness)
    assert (info.origin.position.x, info.origin.position.y) == pytest.approx((-2.05, -2.05))
    assert (info.width, info.height) == (82, 82)
    assert len(grid.data) == info.width * info.height
    assert set(grid.data) == {0, 100}
    assert cell_value(grid, 0.0, 0.0) == 0
    assert cell_value(grid, 1.97, 0.3) == 100  # the cell [1.95, 2.0) meets the 3 cm thick wall x = 2
    assert cell_value(grid, 1.93, 0.3) == 0
    assert cell_value(grid, 0.3, -2.02) == 100  # row-major from the bottom: the lowest wall
    assert cell_value(grid, 0.3, 1.99) == 100


def test_setting_map_resolution_or_map_file_republishes_the_grid(world, executor, make_node, tmp_path):
    grids = latest_grid(executor, make_node)
    result = world.set_parameters([Parameter("map_resolution", value=0.1)])[0]
    assert result.successful, result.reason
    assert spin_until(executor, lambda: grids.last.info.resolution == pytest.approx(0.1))
    assert (grids.last.info.width, grids.last.info.height) == (42, 42)
    one_wall = tmp_path / "one.map"
    one_wall.write_text("wall 1 -1 1 1\n")
    assert world.set_parameters([Parameter("map_file", value=str(one_wall))])[0].successful
    assert spin_until(executor, lambda: grids.last.info.height == 22), grids.last.info
    assert cell_value(grids.last, 1.0, 0.0) == 100


@pytest.mark.parametrize("bad", [0.0, -0.05, 11.0])
def test_a_map_resolution_outside_its_range_is_refused_naming_the_parameter(ros, bad):
    with pytest.raises(InputError, match="map_resolution"):
        CreateWorldNode(parameter_overrides=[Parameter("map_resolution", value=bad)])


def test_a_diagonal_wall_has_no_gap_and_no_cell_beyond_its_thickness():
    wall = np.array([[0.013, -0.21, 1.37, 0.58]])
    raster = rasterise_walls(wall, 0.05)
    occupied = raster.occupied
    res = raster.resolution_m
    # every point of the line lies in an occupied cell
    for u in np.linspace(0.0, 1.0, 2001):
        x, y = wall[0, :2] + u * (wall[0, 2:] - wall[0, :2])
        assert occupied[math.floor((y - raster.origin_y_m) / res), math.floor((x - raster.origin_x_m) / res)]
    # every occupied cell comes within half the thickness of the line
    rows, columns = np.nonzero(occupied)
    cx = raster.origin_x_m + (columns + 0.5) * res
    cy = raster.origin_y_m + (rows + 0.5) * res
    (x1, y1, x2, y2) = wall[0]
    u = np.clip(((cx - x1) * (x2 - x1) + (cy - y1) * (y2 - y1)) / ((x2 - x1) ** 2 + (y2 - y1) ** 2), 0.0, 1.0)
    centre_gap = np.hypot(cx - (x1 + u * (x2 - x1)), cy - (y1 + u * (y2 - y1)))
    assert centre_gap.max() <= WALL_THICKNESS_M / 2 + res / math.sqrt(2.0) + 1e-12


def test_a_cell_touching_only_the_walls_thickness_is_occupied_and_its_neighbour_is_not():
    # wall along y = 0.112: thickness reaches 0.097 and 0.127, so rows [0.05, 0.1) and [0.1, 0.15) only
    raster = rasterise_walls(np.array([[0.0, 0.112, 1.0, 0.112]]), 0.05)
    rows_used = np.nonzero(raster.occupied.any(axis=1))[0]
    assert [raster.origin_y_m + r * 0.05 for r in rows_used] == pytest.approx([0.05, 0.1])


def test_an_empty_map_is_a_zero_sized_grid_and_a_huge_one_gets_coarser_cells():
    assert rasterise_walls(np.zeros((0, 4)), 0.05).occupied.shape == (0, 0)
    raster = rasterise_walls(np.array([[-50_000.0, 0.0, 50_000.0, 1000.0]]), 0.05)
    assert raster.occupied.size <= MAX_MAP_CELLS
    assert raster.resolution_m == pytest.approx(0.05 * 2 ** round(math.log2(raster.resolution_m / 0.05)))
    assert raster.occupied.any()


@pytest.mark.parametrize("seed", range(6))
def test_the_raster_kernel_marks_the_same_cells_as_the_numpy_rasteriser_on_random_walls(seed):
    from create_sim.geometry import _rasterise_reference

    rng = np.random.default_rng(seed)
    n = int(rng.integers(1, 200))
    start = rng.uniform(-5.0, 5.0, (n, 2))
    walls = np.hstack([start, start + rng.normal(0.0, [0.05, 0.5, 3.0][seed % 3], (n, 2))])
    walls[: n // 4, 3] = walls[: n // 4, 1]  # some exactly horizontal, some of zero length
    walls[n // 4 : n // 3, 2:] = walls[n // 4 : n // 3, :2]
    resolution = float(rng.choice([0.01, 0.037, 0.05, 0.1]))
    kernel, reference = rasterise_walls(walls, resolution), _rasterise_reference(walls, resolution)
    assert kernel.occupied.shape == reference.occupied.shape
    assert (kernel.resolution_m, kernel.origin_x_m, kernel.origin_y_m) == (
        reference.resolution_m,
        reference.origin_x_m,
        reference.origin_y_m,
    )
    assert np.array_equal(kernel.occupied, reference.occupied)


def test_the_rasteriser_reports_progress_chunk_by_chunk_and_stops_when_told():
    from create_sim.geometry import RASTER_CHUNK_WALLS

    walls = np.tile([[0.0, 0.0, 1.0, 1.0]], (2 * RASTER_CHUNK_WALLS + 5, 1))
    seen: list[tuple[int, int]] = []
    rasterise_walls(walls, 0.05, progress=lambda done, total: seen.append((done, total)))
    assert seen == [(RASTER_CHUNK_WALLS, len(walls)), (2 * RASTER_CHUNK_WALLS, len(walls)), (len(walls), len(walls))]

    def stop(done: int, total: int) -> None:
        raise KeyboardInterrupt

    with pytest.raises(KeyboardInterrupt):
        rasterise_walls(walls, 0.05, progress=stop)
