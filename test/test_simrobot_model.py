"""SIMROBOT model: kinematics, sensors, painting, crashes, power, history, tracks (no ROS)."""

from __future__ import annotations

import math

import numpy as np
import pytest
from PIL import Image

from sim_runtime.track_plot import draw_tracks
from simrobot_sim import raycast
from simrobot_sim.model import PoseHistory, SimrobotWorld
from simrobot_sim.world_file import RobotSpec, SensorSpec, WorldSpec

CELL = 0.01


def box_walls(nx: int = 200, ny: int = 100, wall_from_x: int | None = 150) -> np.ndarray:
    """``walls[x, y]``: a border one cell thick, plus everything from ``wall_from_x`` on."""
    walls = np.zeros((nx, ny), dtype=bool)
    walls[0, :] = walls[-1, :] = walls[:, 0] = walls[:, -1] = True
    if wall_from_x is not None:
        walls[wall_from_x:, :] = True
    return walls


def world(*robots: RobotSpec, walls: np.ndarray | None = None, **kw) -> SimrobotWorld:
    return SimrobotWorld(WorldSpec(walls=box_walls() if walls is None else walls, robots=robots, **kw))


def footprint(w: SimrobotWorld, i: int) -> set[int]:
    """Flat matrix indices of every cell robot ``i``'s polygon overlaps now (from the model's own
    outline in cells: one through metres can land an ulp off a cell border)."""
    vx, vy = w._outline(i)
    out = np.empty(w.grid.size, dtype=np.int64)
    n, _ = raycast.polygon_cells(np.ascontiguousarray(vx), np.ascontiguousarray(vy), *w.grid.shape, out)
    return set(out[:n].tolist())


def painted(w: SimrobotWorld, i: int) -> set[int]:
    return set(np.flatnonzero(w.grid.ravel() == w.ids[i]).tolist())


# -- kinematics (the original's figures: [0.5 0.5] = 0.5 cell/step, [0 0.5] = 0.25 cell + 4.77 deg, [1 1] = 1 cell)
@pytest.mark.parametrize(
    ("wheels", "dx_cells", "dtheta_deg"),
    [((0.5, 0.5), 0.5, 0.0), ((1.0, 1.0), 1.0, 0.0), ((0.0, 0.5), 0.25, 4.7746), ((0.5, 0.0), 0.25, -4.7746)],
)
def test_seed_kinematics_examples(wheels, dx_cells, dtheta_deg):
    w = world(RobotSpec("a", (0.5, 0.5)))
    w.set_wheel_speeds(0, *wheels)
    w.step()
    x, y, h = w.poses()[0]
    assert x == pytest.approx(0.5 + dx_cells * CELL, abs=1e-12)
    assert y == pytest.approx(0.5, abs=1e-12)  # the step uses the heading before it, as the original
    assert math.degrees(h) == pytest.approx(dtheta_deg, abs=1e-3)


def test_heading_is_counter_clockwise_from_east():
    w = world(RobotSpec("a", (0.5, 0.5), heading=math.radians(90)))
    w.set_wheel_speeds(0, 1.0, 1.0)
    for _ in range(10):
        w.step()
    x, y, _ = w.poses()[0]
    assert (x, y) == pytest.approx((0.5, 0.6), abs=1e-9)


def test_lateral_offset_lb_is_rotated_into_the_world_frame():
    # Facing north, left wheel stopped: yaw rate R*0.5/(2 la), sideways drift lb*omega points west.
    w = world(RobotSpec("a", (0.5, 0.5), heading=math.radians(90), lb=0.01))
    w.set_wheel_speeds(0, 0.0, 0.5)
    w.step()
    x, y, h = w.poses()[0]
    omega = 0.01 * 0.5 / 0.06
    assert x == pytest.approx(0.5 - 0.01 * omega, abs=1e-12)  # the original added this along the heading
    assert y == pytest.approx(0.5 + 0.0025, abs=1e-12)
    assert h == pytest.approx(math.pi / 2 + omega)


def test_cmd_vel_inverse_model_is_exact():
    w = world(RobotSpec("a", (0.5, 0.5)))
    w.set_cmd_vel(0, 0.02, 0.1)
    assert tuple(w.vel[0]) == pytest.approx(((0.02 - 0.03 * 0.1) / 0.01, (0.02 + 0.03 * 0.1) / 0.01))
    v, v_lat, omega = w.body_velocity(0)
    assert (v, v_lat, omega) == pytest.approx((0.02, 0.0, 0.1))


def test_wheel_accelerations_add_to_speeds_each_step_before_moving():
    w = world(RobotSpec("a", (0.5, 0.5)))
    w.set_wheel_accels(0, 0.5, 0.5)
    w.step()  # speed 0.5 -> 0.5 cell
    w.step()  # speed 1.0 -> 1 cell
    assert w.poses()[0, 0] == pytest.approx(0.5 + 1.5 * CELL)
    assert tuple(w.vel[0]) == (1.0, 1.0)


def test_non_finite_commands_are_rejected_and_leave_state():
    w = world(RobotSpec("a", (0.5, 0.5)))
    w.set_wheel_speeds(0, 0.5, 0.5)
    for bad in ((math.nan, 0.0), (0.0, math.inf)):
        with pytest.raises(ValueError, match="finite"):
            w.set_wheel_speeds(0, *bad)
        with pytest.raises(ValueError, match="finite"):
            w.set_cmd_vel(0, *bad)
    with pytest.raises(ValueError, match="wheel speeds"):  # finite, but overflows the inverse model
        w.set_cmd_vel(0, 1e308, 1e308)
    assert tuple(w.vel[0]) == (0.5, 0.5)


# -- sensors
def test_ultrasonic_distance_to_a_known_wall():
    sonar = SensorSpec("front", "ultrasonic", position=(0.05, 0.0), range=0.6, rays=1)
    w = world(RobotSpec("a", (1.0, 0.5), sensors=(sonar,)))
    d, obstacle = w.read("a", "front")
    assert d == pytest.approx(1.5 - 1.05, abs=1e-9)  # wall cells start at x = 150 cells
    assert obstacle == 1


def test_ultrasonic_nearest_of_a_beam_and_no_hit_is_inf():
    sonar = SensorSpec("front", "ultrasonic", position=(0.05, 0.0), range=0.6, rays=30)
    short = SensorSpec("short", "ultrasonic", position=(0.05, 0.0), range=0.3, rays=30)
    w = world(RobotSpec("a", (1.0, 0.5), sensors=(sonar, short)))
    d, obstacle = w.read("a", "front")
    # 30 rays over 60 degrees, symmetric: the nearest ray is 1.03 degrees off the axis
    assert d == pytest.approx(0.45 / math.cos(math.radians(30 / 29)), abs=1e-9)
    assert obstacle == 1
    assert w.read("a", "short") == (math.inf, 0)


def test_sensor_sees_another_robot_with_its_id():
    sonar = SensorSpec("front", "ultrasonic", position=(0.05, 0.0), range=0.6, rays=1)
    w = world(RobotSpec("a", (1.0, 0.5), sensors=(sonar,)), RobotSpec("b", (1.3, 0.5)))
    d, obstacle = w.read("a", "front")
    assert obstacle == 3  # robot b: second robot, id 3
    assert d == pytest.approx(1.28 - 1.05, abs=1e-9)  # b's rear edge at x = 1.28 starts a cell


def test_sensor_never_sees_its_own_robot():
    inside = SensorSpec("inside", "ultrasonic", position=(0.0, 0.0), range=0.2, rays=5)
    w = world(RobotSpec("a", (0.5, 0.5), sensors=(inside,)))
    assert w.read("a", "inside") == (math.inf, 0)


def test_laser_rays_counter_clockwise_from_the_rightmost():
    laser = SensorSpec("scan", "laser", position=(0.05, 0.0), beamwidth=math.radians(90), range=2.0, rays=3)
    w = world(RobotSpec("a", (1.0, 0.3), sensors=(laser,)))
    ranges, obstacles = w.read("a", "scan")
    # right ray (-45 deg) meets the bottom border (y = 0.01), left ray (+45) the wall at x = 1.5
    assert ranges[0] == pytest.approx((0.3 - 0.01) * math.sqrt(2), abs=1e-9)
    assert ranges[1] == pytest.approx(0.45, abs=1e-9)
    assert ranges[2] == pytest.approx(0.45 * math.sqrt(2), abs=1e-9)
    assert list(obstacles) == [1, 1, 1]


def test_sensors_see_robots_at_their_new_positions():
    sonar = SensorSpec("front", "ultrasonic", position=(0.05, 0.0), range=0.6, rays=1)
    w = world(RobotSpec("a", (1.0, 0.5), sensors=(sonar,)), RobotSpec("b", (1.3, 0.5)))
    w.set_wheel_speeds(1, -1.0, -1.0)  # b backs towards a, 1 cm per step
    for _ in range(3):
        w.step()
    d, obstacle = w.read("a", "front")
    assert obstacle == 3
    assert d == pytest.approx(1.25 - 1.05, abs=1e-9)


# -- painting, collisions, power
def test_robots_are_painted_with_their_id_and_moved():
    w = world(RobotSpec("a", (0.5, 0.5)), RobotSpec("b", (1.0, 0.5)))
    assert w.grid[50, 50] == 2 and w.grid[100, 50] == 3
    w.set_wheel_speeds(0, 1.0, 1.0)
    for _ in range(10):
        w.step()
    assert w.grid[48, 50] == 0 and w.grid[60, 50] == 2
    assert painted(w, 0) == footprint(w, 0)


def test_crash_on_wall_stops_at_last_free_pose():
    w = world(RobotSpec("a", (1.40, 0.5)))
    w.set_wheel_speeds(0, 1.0, 1.0)
    crashed_at = None
    for k in range(20):
        if len(w.step()) and crashed_at is None:
            crashed_at = k
    assert w.crashed[0]
    x = w.poses()[0, 0]
    assert x + 0.04 <= 1.5  # the nose never entered the wall
    assert crashed_at is not None and x == pytest.approx(1.40 + crashed_at * CELL)
    assert np.all(w.grid[150:, :] == 1)


def test_crash_between_robots_crashes_both():
    w = world(RobotSpec("a", (0.9, 0.5)), RobotSpec("b", (1.0, 0.5), heading=math.pi))
    w.set_wheel_speeds(0, 1.0, 1.0)
    w.set_wheel_speeds(1, 1.0, 1.0)
    for _ in range(10):
        w.step()
    assert list(w.crashed) == [True, True]
    xa, xb = w.poses()[:, 0]
    assert xa + 0.04 < xb - 0.04 + 2 * CELL  # noses meet, bodies do not overlap
    assert painted(w, 0) == footprint(w, 0) and painted(w, 1) == footprint(w, 1)


def test_leaving_an_open_map_is_a_crash():
    w = world(RobotSpec("a", (0.5, 0.5)), walls=np.zeros((100, 100), dtype=bool))
    w.set_wheel_speeds(0, 2.0, 2.0)
    for _ in range(40):
        w.step()
    assert w.crashed[0]
    assert 0.0 < w.poses()[0, 0] < 1.0


def test_power_off_robot_does_not_move_and_clear_crash_lets_it_go():
    w = world(RobotSpec("a", (0.5, 0.5), power=False))
    w.set_wheel_speeds(0, 1.0, 1.0)
    w.step()
    assert w.poses()[0, 0] == 0.5
    w.set_power(0, True)
    w.step()
    assert w.poses()[0, 0] == pytest.approx(0.51)
    w.crashed[0] = True
    w.step()
    assert w.poses()[0, 0] == pytest.approx(0.51)
    w.clear_crash(0)
    w.step()
    assert w.poses()[0, 0] == pytest.approx(0.52)


def test_crashed_robot_backs_out_after_clear_crash():
    w = world(RobotSpec("a", (1.40, 0.5)))
    w.set_wheel_speeds(0, 1.0, 1.0)
    for _ in range(20):
        w.step()
    x = w.poses()[0, 0]
    w.clear_crash(0)
    w.set_wheel_speeds(0, -1.0, -1.0)
    w.step()
    assert not w.crashed[0]
    assert w.poses()[0, 0] == pytest.approx(x - CELL)


# -- map orientation
def test_image_top_row_is_max_y(tmp_path):
    from simrobot_sim.world_file import load_bitmap

    img = np.full((40, 60), 255, dtype=np.uint8)  # 40 rows (y), 60 columns (x)
    img[0, :] = 0  # top row black
    img[:, 0] = 0  # left column black
    Image.fromarray(img).convert("1").save(tmp_path / "m.png")
    walls = load_bitmap(tmp_path / "m.png")
    assert walls.shape == (60, 40)
    assert walls[:, 39].all() and not walls[1:, 38].any()
    assert walls[0, :].all()


# -- history and tracks
def test_history_is_bounded_and_keeps_the_newest_rows():
    h = PoseHistory(3, capacity=100, chunk=16)
    for k in range(1000):
        h.append(np.full((3, 3), k, dtype=float))
        if k == 200:
            size = h.nbytes()
    assert h.nbytes() == size
    rows = h.array()
    assert 100 <= len(rows) <= 100 + 16
    assert rows[-1, 0, 0] == 999 and np.all(np.diff(rows[:, 0, 0]) == 1)


def test_world_history_has_a_row_per_step():
    w = world(RobotSpec("a", (0.5, 0.5)))
    w.set_wheel_speeds(0, 1.0, 1.0)
    for _ in range(5):
        w.step()
    track = w.tracks()["a"]
    assert track.shape == (6, 2)
    assert track[:, 0] == pytest.approx([0.5 + k * CELL for k in range(6)], abs=1e-6)


def test_draw_tracks_writes_the_map_and_coloured_tracks(tmp_path):
    occupancy = np.zeros((100, 200), dtype=np.int8)
    occupancy[:, 150:] = 100
    tracks = {"a": np.array([[0.2, 0.5], [1.2, 0.5]]), "b": np.array([[0.5, 0.2], [0.5, 0.8]])}
    out = draw_tracks(occupancy, 0.01, (0.0, 0.0), tracks, {"a": (1, 0, 0), "b": (0, 0, 1)}, tmp_path / "t.png")
    img = np.asarray(Image.open(out).convert("RGB")).reshape(-1, 3).astype(int)
    assert np.any((img[:, 0] > 200) & (img[:, 1] < 60) & (img[:, 2] < 60))  # red track
    assert np.any((img[:, 2] > 200) & (img[:, 0] < 60) & (img[:, 1] < 60))  # blue track
    assert np.any(img.sum(axis=1) < 30)  # black wall
