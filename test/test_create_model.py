"""The pure Create model: kinematics, wall physics, every sensor, odometry, bad input."""

from __future__ import annotations

import math

import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from create_sim.configfile import NoiseConfig, load_config
from create_sim.geometry import (
    MAX_GRID_CELLS,
    SegmentGrid,
    brute_cast_fan,
    grid_contacts,
    new_contacts,
    numpy_cast_fan,
)
from create_sim.mapfile import CreateMap, load_map
from create_sim.model import CreateModel
from sim_runtime.errors import InputError
from sim_runtime.paths import config_path

R = CreateModel.RADIUS
MU = CreateModel.FRICTION


def world(walls=(), lines=(), beacons=(), virtwalls=()) -> CreateMap:
    return CreateMap(
        walls=np.array(walls, dtype=float).reshape(-1, 4),
        lines=np.array(lines, dtype=float).reshape(-1, 4),
        beacon_xy=np.array([b[:2] for b in beacons], dtype=float).reshape(-1, 2),
        beacon_rgb=np.array([b[2] for b in beacons], dtype=float).reshape(-1, 3),
        beacon_ids=[b[3] for b in beacons],
        virtwalls=np.array(virtwalls, dtype=float).reshape(-1, 4),
    )


def drive(robot: CreateModel, v: float, w: float, seconds: float, dt: float = 0.01) -> None:
    robot.set_velocity(v, w)
    for _ in range(round(seconds / dt)):
        robot.step(dt)


def noisy(**noise) -> NoiseConfig:
    return NoiseConfig(noise=dict(noise))


def tangent_wall(angle: float, gap: float = 0.0005, half_length: float = 1.0) -> list[float]:
    """A wall touching the robot at the origin (heading 0) at body angle ``angle``."""
    cx, cy = (R + gap) * math.cos(angle), (R + gap) * math.sin(angle)
    tx, ty = -math.sin(angle) * half_length, math.cos(angle) * half_length
    return [cx - tx, cy - ty, cx + tx, cy + ty]


# ------------------------------------------------------------------------------------------ motion
def test_straight_line_distance_is_exact():
    robot = CreateModel(world())
    drive(robot, 0.2, 0.0, 1.5)
    np.testing.assert_allclose(robot.pose, [0.3, 0.0, 0.0], atol=1e-12)
    assert robot.velocity == pytest.approx((0.2, 0.0))


@pytest.mark.parametrize(("w", "expected_y", "expected_theta"), [(0.5, 0.4, math.pi / 2), (-0.5, -0.4, -math.pi / 2)])
def test_arc_radius_and_direction(w, expected_y, expected_theta):
    """v = 0.2, |w| = 0.5: a quarter circle of radius 0.4 to the left (CCW) or right (CW)."""
    robot = CreateModel(world())
    robot.set_velocity(0.2, w)
    for _ in range(100):
        robot.step(math.pi / 100)
    np.testing.assert_allclose(robot.pose, [0.4, expected_y, expected_theta], atol=1e-9)


def test_turning_in_place_keeps_position_and_wraps_heading():
    robot = CreateModel(world(), pose=(1.0, 2.0, 3.0))
    drive(robot, 0.0, 1.0, 1.0)
    x, y, theta = robot.pose
    assert (x, y) == (1.0, 2.0)
    assert theta == pytest.approx(4.0 - 2 * math.pi)


@pytest.mark.parametrize(
    ("command", "applied"),
    [
        ((0.3, 1.0), (0.3, 1.0)),  # within limits: unchanged
        ((1.0, 0.0), (0.5, 0.0)),
        ((-1.0, 0.0), (-0.5, 0.0)),
        ((0.0, 5.0), (0.0, 0.5 / 0.129)),  # the original turned this into 0.5 m/s straight ahead
        ((0.5, 1.0), ((0.5 + 0.5 - 0.129) / 2, (0.5 - (0.5 - 0.129)) / 0.258)),
        ((1e9, -1e10), (0.0, -0.5 / 0.129)),
    ],
)
def test_each_wheel_is_clamped_on_its_own(command, applied):
    robot = CreateModel(world())
    assert robot.set_velocity(*command) == pytest.approx(applied)
    assert robot.command == pytest.approx(applied)


@pytest.mark.parametrize("bad", [(math.nan, 0.0), (0.0, math.inf), (-math.inf, 1.0)])
def test_non_finite_command_is_refused_and_state_unchanged(bad):
    robot = CreateModel(world())
    robot.set_velocity(0.1, 0.2)
    with pytest.raises(ValueError, match="not finite"):
        robot.set_velocity(*bad)
    assert robot.command == pytest.approx((0.1, 0.2))


@pytest.mark.parametrize("dt", [-0.01, math.nan, math.inf])
def test_bad_time_step_is_refused(dt):
    robot = CreateModel(world())
    robot.set_velocity(0.2, 0.0)
    with pytest.raises(ValueError, match="time step"):
        robot.step(dt)
    np.testing.assert_array_equal(robot.pose, [0, 0, 0])


def test_stops_at_a_wall_ahead():
    robot = CreateModel(world(walls=[[1, -1, 1, 1]]))
    drive(robot, 0.5, 0.0, 4.0)
    x, y, theta = robot.pose
    assert x == pytest.approx(1 - R, abs=1e-6) and y == 0 and theta == 0
    assert robot.velocity == pytest.approx((0.0, 0.0), abs=1e-6)
    assert robot.bumps() == (True, True)


def test_slides_along_a_wall_with_friction():
    """Heading 45° into a vertical wall: the robot keeps v·sin45 − μ·v·cos45 along it."""
    v = 0.2
    robot = CreateModel(world(walls=[[1, -5, 1, 5]]), pose=(1 - R - 0.01, 0.0, math.pi / 4))
    drive(robot, v, 0.0, 0.5)  # reach the wall
    x0, y0, _ = robot.pose
    drive(robot, v, 0.0, 1.0)
    x1, y1, theta = robot.pose
    assert x0 == pytest.approx(1 - R, abs=1e-6) and x1 == pytest.approx(1 - R, abs=1e-6)
    expected = v * math.sqrt(0.5) * (1 - MU)
    assert y1 - y0 == pytest.approx(expected, rel=1e-6)
    assert theta == pytest.approx(math.pi / 4)
    assert robot.bumps() == (False, True)  # the wall is 45° to the right of the heading


@pytest.mark.parametrize("walls", [[[-1, 1, 3, 1]], [[-1, 1, 1, 1], [1, 1, 3, 1]], [[-1, 1, 1, 1], [1, 1, 3, 0.999]]])
def test_slides_past_the_joint_of_a_wall_made_of_segments(walls):
    """A joint between wall segments is not an obstacle: same slide as along one long wall."""
    heading, v, gap = math.radians(20), 0.3, 0.01
    robot = CreateModel(world(walls=walls), pose=(-0.5, 1 - R - gap, heading))
    drive(robot, v, 0.0, 10.0)
    x, y, _ = robot.pose
    # Free until it touches, then sliding at v·cosθ less friction μ·v·sinθ (the press into the wall).
    approach = gap / (v * math.sin(heading))
    slide = v * (math.cos(heading) - MU * math.sin(heading))
    expected_x = -0.5 + v * math.cos(heading) * approach + slide * (10.0 - approach)
    assert x == pytest.approx(expected_x, abs=2e-3) and y == pytest.approx(1 - R, abs=1e-3)


def test_corner_stops_the_robot_touching_both_walls():
    robot = CreateModel(world(walls=[[1, -2, 1, 1], [-2, 1, 1, 1]]), pose=(0, 0, math.pi / 4))
    drive(robot, 0.3, 0.0, 5.0)
    x, y, _ = robot.pose
    assert x == pytest.approx(1 - R, abs=1e-6) and y == pytest.approx(1 - R, abs=1e-6)
    assert robot.velocity[0] == pytest.approx(0.0, abs=1e-6)
    assert robot.bumps() == (True, True)


def test_obtuse_corner_lets_the_robot_slide_on_along_the_next_wall():
    """Sliding up a wall into a 120° bend: the robot follows the bend instead of stopping."""
    bend = [1 - 3 * math.cos(math.radians(60)), 3 * math.sin(math.radians(60))]
    walls = [[1, -3, 1, 0], [1, 0, *bend]]
    robot = CreateModel(world(walls=walls), pose=(0.5, -1.0, math.pi / 3))
    drive(robot, 0.4, 0.0, 8.0)
    x, y, _ = robot.pose
    assert y > 0.2 and x < 0.7  # went round the bend, up the second wall
    assert robot.clearance() == pytest.approx(0.0, abs=1e-6)  # still pressed against it
    # Heading 60° against a wall at 120°: v_t = v·cos60°, less μ·v·sin60°, seen along the heading.
    sliding = 0.4 * (math.cos(math.pi / 3) - MU * math.sin(math.pi / 3))
    assert robot.velocity[0] == pytest.approx(sliding * math.cos(math.pi / 3))


def test_rolls_round_a_free_standing_corner():
    """A wall end hit off-centre deflects the robot round it instead of stopping it."""
    robot = CreateModel(world(walls=[[1, 0.1, 1, 3]]))
    drive(robot, 0.3, 0.0, 6.0)
    x, y, _ = robot.pose
    assert x > 1.2 and y < 0.1 - R  # passed the wall's end on the right side
    assert robot.clearance() >= -1e-9


def test_backing_away_from_a_wall_is_free():
    robot = CreateModel(world(walls=[[1, -1, 1, 1]]), pose=(1 - R, 0.0, 0.0))
    drive(robot, -0.2, 0.0, 1.0)
    assert robot.pose[0] == pytest.approx(1 - R - 0.2)


def test_driving_off_an_open_map_keeps_working():
    robot = CreateModel(
        world(walls=[[1, -1, 1, 1]], beacons=[(2, 0, (1, 0, 0), "b")], lines=[[0, 0, 1, 0]]), pose=(0, 0, math.pi)
    )
    drive(robot, 0.5, 0.0, 200.0, dt=0.1)
    assert robot.pose[0] == pytest.approx(-100.0)
    assert np.isinf(robot.lidar()).all() and np.isinf(robot.sonar()).all()
    assert robot.camera() == [] and robot.bumps() == (False, False)
    assert (robot.cliff_signals() == 21.5).all()


def test_big_time_steps_cannot_tunnel_through_a_wall():
    robot = CreateModel(world(walls=[[1, -1, 1, 1]]))
    robot.set_velocity(0.5, 0.0)
    robot.step(10.0)
    assert robot.pose[0] == pytest.approx(1 - R, abs=1e-6)


def test_initial_pose_inside_a_wall_is_an_input_error():
    walls = world(walls=[[1, -1, 1, 1]])
    with pytest.raises(InputError, match="inside a wall"):
        CreateModel(walls, pose=(0.9, 0.0, 0.0))
    robot = CreateModel(walls)
    with pytest.raises(InputError, match="inside a wall"):
        robot.set_pose(1.0, 0.5, 0.0)
    with pytest.raises(InputError, match="not finite"):
        robot.set_pose(math.nan, 0.0, 0.0)
    np.testing.assert_array_equal(robot.pose, [0, 0, 0])


def test_non_finite_map_built_in_code_is_an_input_error():
    with pytest.raises(InputError, match="map walls contain non-finite values"):
        CreateModel(world(walls=[[0, 0, math.nan, 1]]))


def test_reset_restores_the_initial_state():
    robot = CreateModel(world(), pose=(1.0, 1.0, 0.5))
    drive(robot, 0.3, 0.4, 2.0)
    robot.reset()
    np.testing.assert_array_equal(robot.pose, [1.0, 1.0, 0.5])
    np.testing.assert_array_equal(robot.odometry_pose, [0, 0, 0])
    assert robot.command == (0.0, 0.0) and robot.velocity == (0.0, 0.0)


# ------------------------------------------------------------------------------------------ odometry
def test_odometry_follows_the_true_motion_without_noise():
    robot = CreateModel(world(), pose=(5.0, 5.0, 1.0))
    drive(robot, 0.2, 0.3, 3.0)
    drive(robot, -0.1, -0.5, 2.0)
    x, y, theta = robot.pose
    # The odom frame starts at the initial pose: compare in that frame.
    c, s = math.cos(-1.0), math.sin(-1.0)
    expected = [c * (x - 5) - s * (y - 5), s * (x - 5) + c * (y - 5), theta - 1.0]
    np.testing.assert_allclose(robot.odometry_pose, expected, atol=1e-9)


def test_odometry_counts_the_first_step_and_turns_across_pi():
    robot = CreateModel(world(), pose=(0, 0, 3.0))
    robot.set_velocity(0.0, 2.0)
    robot.step(0.01)
    assert robot.odometry_totals[1] == pytest.approx(0.02)  # no lag behind the previous step
    for _ in range(100):  # the rest of a full turn, crossing ±π
        robot.step((math.pi - 0.01) / 100)
    assert robot.odometry_totals[1] == pytest.approx(2 * math.pi, abs=1e-9)
    drive(robot, -0.2, 0.0, 1.0)
    assert robot.odometry_totals[0] == pytest.approx(-0.2)


def test_odometry_noise_is_proportional_and_seeded():
    robot = CreateModel(world(), noisy(odometry=(0.1, 0.0)))
    drive(robot, 0.2, 0.0, 5.0)
    assert robot.odometry_totals[0] == pytest.approx(1.1)
    runs = []
    for _ in range(2):
        robot = CreateModel(world(), noisy(odometry=(0.0, 0.05)), rng=np.random.default_rng(7))
        drive(robot, 0.2, 0.5, 2.0)
        runs.append(robot.odometry_pose)
    np.testing.assert_array_equal(runs[0], runs[1])
    assert not np.allclose(runs[0], CreateModel(world()).pose)


def test_odometry_distance_stops_when_blocked():
    robot = CreateModel(world(walls=[[0.5, -1, 0.5, 1]]))
    drive(robot, 0.5, 0.0, 3.0)
    assert robot.odometry_totals[0] == pytest.approx(0.5 - R, abs=1e-6)


# ------------------------------------------------------------------------------------------ bumps
@pytest.mark.parametrize(
    ("angle_deg", "expected"),
    [
        (0, (True, True)),
        (20, (True, True)),
        (-20, (True, True)),
        (60, (True, False)),
        (30, (True, False)),
        (-60, (False, True)),
        (-85, (False, True)),
        (95, (False, False)),
        (180, (False, False)),
        (-120, (False, False)),
    ],
)
def test_bumps_by_contact_side(angle_deg, expected):
    robot = CreateModel(world(walls=[tangent_wall(math.radians(angle_deg))]))
    assert robot.bumps() == expected


def test_no_bump_in_free_space_or_a_centimetre_from_a_wall():
    assert CreateModel(world()).bumps() == (False, False)
    assert CreateModel(world(walls=[tangent_wall(0.0, gap=0.01)])).bumps() == (False, False)


def test_bump_follows_the_heading():
    robot = CreateModel(world(walls=[tangent_wall(0.0)]), pose=(0, 0, math.radians(60)))
    assert robot.bumps() == (False, True)  # wall now 60° to the right


# ------------------------------------------------------------------------------------------ cliff
def radial_line(angle_deg: float, heading: float = 0.0) -> list[float]:
    a = math.radians(angle_deg) + heading
    return [0.0, 0.0, 0.3 * math.cos(a), 0.3 * math.sin(a)]


@pytest.mark.parametrize(
    ("angle_deg", "expected"),
    [
        (60, [1.5, 21.5, 21.5, 21.5]),
        (13, [21.5, 1.5, 21.5, 21.5]),
        (-13, [21.5, 21.5, 1.5, 21.5]),
        (-60, [21.5, 21.5, 21.5, 1.5]),
        (0, [21.5, 21.5, 21.5, 21.5]),
        (90, [21.5, 21.5, 21.5, 21.5]),
    ],
)
def test_cliff_reads_a_line_under_each_sensor(angle_deg, expected):
    robot = CreateModel(world(lines=[radial_line(angle_deg)]))
    np.testing.assert_array_equal(robot.cliff_signals(), expected)


def test_cliff_line_across_the_front_and_heading():
    robot = CreateModel(world(lines=[[0.15, -1, 0.15, 1]]))  # crosses the perimeter at ±20.4°
    np.testing.assert_array_equal(robot.cliff_signals(), [21.5] * 4)
    robot = CreateModel(world(lines=[[0.155, -1, 0.155, 1]]))  # at ±14.4°: both front sensors
    np.testing.assert_array_equal(robot.cliff_signals(), [21.5, 1.5, 1.5, 21.5])
    robot.set_pose(0.0, 0.0, math.radians(74.4))  # the +14.4° crossing is now at -60°
    np.testing.assert_array_equal(robot.cliff_signals(), [21.5, 21.5, 21.5, 1.5])


def test_cliff_noise_is_drawn_per_sensor():
    robot = CreateModel(world(), noisy(cliff=(3.0, 6.9)), rng=np.random.default_rng(1))
    readings = np.array([robot.cliff_signals() for _ in range(2000)])
    assert len(set(readings[0])) == 4  # not one shared draw
    np.testing.assert_allclose(readings.mean(axis=0), 24.5, atol=0.5)
    np.testing.assert_allclose(readings.std(axis=0), 6.9, rtol=0.08)


# ------------------------------------------------------------------------------------------ IR wall
@pytest.mark.parametrize(("wall_y", "seen"), [(-0.17, True), (-0.2, True), (-0.21, False), (-0.3, False)])
def test_ir_wall_sensor_looks_right_from_the_front_right(wall_y, seen):
    # The sensor sits 0.104 m right of the centre; its range is 0.1 m.
    robot = CreateModel(world(walls=[[-1, wall_y, 1, wall_y]]))
    assert robot.wall_sensor() is seen


def test_ir_wall_sensor_has_no_false_positives_with_noise():
    robot = CreateModel(world(), noisy(wall=(0.0, 0.01)), rng=np.random.default_rng(2))
    assert not any(robot.wall_sensor() for _ in range(500))
    robot = CreateModel(world(walls=[[-1, 0.3, 1, 0.3]]), noisy(wall=(0.0, 0.01)))
    assert not any(robot.wall_sensor() for _ in range(500))  # a wall on the left


# ------------------------------------------------------------------------------------------ sonar
def test_sonar_reads_from_the_body_edge():
    robot = CreateModel(world(walls=[[2, -5, 2, 5], [-5, 1, 5, 1], [-5, -2.5, 5, -2.5]]))
    front, left, back, right = robot.sonar()
    assert front == pytest.approx(2 - R) and left == pytest.approx(1 - R)
    assert back == math.inf and right == pytest.approx(2.5 - R)


def test_sonar_out_of_range_and_too_close():
    robot = CreateModel(world(walls=[[3.2, -5, 3.2, 5], [-5, R, 5, R]]))
    front, left, _, _ = robot.sonar()
    assert front == math.inf  # 3.04 m from the edge: beyond 3 m
    assert left == -math.inf  # touching


def test_sonar_noise_keeps_in_range_readings_in_range():
    robot = CreateModel(
        world(walls=[[2.9 + R, -5, 2.9 + R, 5], [-5, 0.05 + R, 5, 0.05 + R]]),
        noisy(sonar=(0.0, 1.0)),
        rng=np.random.default_rng(3),
    )
    readings = np.array([robot.sonar()[:2] for _ in range(500)])
    assert ((readings >= 0.02) & (readings <= 3.0)).all()
    assert len(np.unique(readings[:, 0])) > 2


# ------------------------------------------------------------------------------------------ lidar
def test_lidar_against_a_wall_matches_the_analytic_ranges():
    robot = CreateModel(world(walls=[[2, -10, 2, 10]]))
    scan = robot.lidar()
    assert scan.dtype == np.float32 and scan.shape == (681,)
    angles = np.linspace(-math.radians(120), math.radians(120), 681)
    with np.errstate(divide="ignore"):
        expected = (2 - R) / np.cos(angles)
    expected[(expected <= 0) | (expected > 4.0)] = np.inf
    np.testing.assert_allclose(scan, expected.astype(np.float32), rtol=1e-6)
    assert scan[340] == pytest.approx(2 - R) and scan[0] == np.inf and scan[-1] == np.inf


def test_lidar_index_zero_is_the_right_side():
    robot = CreateModel(world(walls=[[-5, -1, 5, -1]]))  # wall on the right only
    scan = robot.lidar()
    assert scan[170] == pytest.approx(1 / math.sin(math.radians(60)), rel=1e-6)  # -60°
    assert np.isinf(scan[341:]).all()


def test_lidar_clamps_close_readings_and_adds_per_beam_noise():
    robot = CreateModel(world(walls=[[R, -1, R, 1]]))
    assert robot.lidar()[340] == pytest.approx(0.02)
    robot = CreateModel(world(walls=[[2, -10, 2, 10]]), noisy(lidar=(0.0, 0.01)), rng=np.random.default_rng(4))
    scan = robot.lidar()
    assert np.isinf(scan[0])
    assert abs(scan[340] - (2 - R)) < 0.05 and len(np.unique(scan[300:380])) == 80


# ------------------------------------------------------------------------------------------ camera
def test_camera_sees_a_beacon_in_front_with_case_kept_id():
    robot = CreateModel(world(beacons=[(2, 0, (1, 0.5, 0), "Red1"), (1, 1, (0, 0, 1), "b2")]))
    seen = {s.id: s for s in robot.camera()}
    assert seen["Red1"].distance == pytest.approx(2 - 0.13) and seen["Red1"].angle == 0
    assert seen["Red1"].rgb == (1.0, 0.5, 0.0)
    assert seen["b2"].angle == pytest.approx(math.atan2(1, 0.87))  # left is positive


def test_camera_does_not_see_behind_walls_out_of_view_or_range():
    robot = CreateModel(
        world(
            walls=[[1, -0.5, 1, 0.5]],
            beacons=[
                (2, 0, (1, 0, 0), "hidden"),
                (2, 1.5, (1, 0, 0), "visible"),
                (0.5, 1.0, (1, 0, 0), "outside_fov"),
                (6.2, 0.0, (1, 0, 0), "far"),
                (-2, 0, (1, 0, 0), "behind"),
            ],
        )
    )
    assert [s.id for s in robot.camera()] == ["visible"]


def test_camera_sees_a_beacon_on_a_wall():
    robot = CreateModel(world(walls=[[2, -1, 2, 1]], beacons=[(2, 0.3, (0, 1, 0), "on_wall")]))
    assert [s.id for s in robot.camera()] == ["on_wall"]


def test_camera_noise_is_proportional():
    robot = CreateModel(world(beacons=[(3, 0.5, (1, 0, 0), "b")]), noisy(camera=(0.1, 0.0)))
    (sighting,) = robot.camera()
    assert sighting.distance == pytest.approx(1.1 * math.hypot(3 - 0.13, 0.5))
    assert sighting.angle == pytest.approx(1.1 * math.atan2(0.5, 3 - 0.13))


# ------------------------------------------------------------------------------------------ virtual wall
@pytest.mark.parametrize(
    ("emitter", "walls", "expected"),
    [
        ([1.0, 0.0, math.pi, 1], [], True),  # in the field, 0.84 m away
        ([1.0, 0.0, math.pi, 1], [[0.5, -1, 0.5, 1]], False),  # a wall between
        ([1.0, 0.0, math.pi / 2, 1], [], False),  # beam points elsewhere, beyond the halo
        ([0.3, 0.3, math.pi / 2, 1], [], True),  # halo (0.33 m)
        ([0.3, 0.3, math.pi / 2, 1], [[0.0, 0.25, 0.6, 0.25]], False),  # halo blocked by a wall
        ([3.0, 0.0, math.pi, 1], [], False),  # 2.84 m: beyond setting 1's 2.13 m
        ([3.0, 0.0, math.pi, 2], [], True),  # within setting 2's 5.56 m
        ([7.0, 0.0, math.pi, 2], [], False),
        ([7.0, 0.0, math.pi, 3], [], True),  # setting 3 reaches 8.08 m
        ([2.0, 0.3, math.pi, 1], [], True),  # 9.3° off the beam: inside setting 1's ±9.45°
        ([2.0, 0.4, math.pi, 1], [], False),  # 12.3° off the beam
    ],
)
def test_virtual_wall_halo_field_and_blocking(emitter, walls, expected):
    robot = CreateModel(world(walls=walls, virtwalls=[emitter]))
    assert robot.virtual_wall() is expected


def test_no_virtual_walls_means_no_detection():
    assert CreateModel(world()).virtual_wall() is False


# ------------------------------------------------------------------------------------------ properties
def random_walls(rng: np.random.Generator, n: int, size: float = 6.0) -> np.ndarray:
    start = rng.uniform(-size / 2, size / 2, (n, 2))
    angle = rng.uniform(0, 2 * math.pi, n)
    length = rng.uniform(0.0, 2.5, n)
    return np.column_stack([start, start + np.column_stack([np.cos(angle), np.sin(angle)]) * length[:, None]])


def free_pose(robot_map: CreateMap, rng: np.random.Generator) -> tuple[float, float, float]:
    """A random pose where the robot overlaps no wall."""
    while True:
        pose = (*rng.uniform(-3, 3, 2), rng.uniform(-math.pi, math.pi))
        try:
            return CreateModel(robot_map, pose=pose).initial_pose
        except InputError:
            continue


commands = st.lists(
    st.tuples(st.floats(-2.0, 2.0), st.floats(-10.0, 10.0), st.sampled_from([0.01, 0.01, 0.05, 0.3])),
    min_size=50,
    max_size=50,
)


@settings(max_examples=200, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(seed=st.integers(0, 2**32 - 1), n_walls=st.integers(1, 25), sequence=commands, room=st.booleans())
def test_never_inside_a_wall(seed, n_walls, sequence, room):
    rng = np.random.default_rng(seed)
    walls = random_walls(rng, n_walls)
    if room:  # a closed box as well, so the robot is often squeezed into corners
        walls = np.vstack([walls, [[-3, -3, 3, -3], [3, -3, 3, 3], [3, 3, -3, 3], [-3, 3, -3, -3]]])
    robot_map = world(walls=walls)
    robot = CreateModel(robot_map, pose=free_pose(robot_map, rng))
    for v, w, dt in sequence:
        robot.set_velocity(v, w)
        robot.step(dt)
        assert robot.clearance() >= -1e-9, (robot.pose, v, w, dt)
        assert np.isfinite(robot.pose).all()


def test_never_inside_a_wall_over_ten_thousand_random_sequences():
    """The issue's bulk form of the property: 10,000 random command sequences (20 commands,
    random dt) from random free poses in 100 random maps, half of them closed rooms."""
    rng = np.random.default_rng(20261122)
    box = [[-3, -3, 3, -3], [3, -3, 3, 3], [3, 3, -3, 3], [-3, 3, -3, -3]]
    for map_index in range(100):
        walls = random_walls(rng, int(rng.integers(1, 25)))
        robot_map = world(walls=np.vstack([walls, box]) if map_index % 2 else walls)
        robot = CreateModel(robot_map, pose=free_pose(robot_map, rng))
        for _ in range(100):
            robot.set_pose(*free_pose(robot_map, rng))
            v = rng.uniform(-2.0, 2.0, 20)
            w = rng.uniform(-10.0, 10.0, 20)
            dt = rng.choice([0.01, 0.05, 0.3], 20)
            for k in range(20):
                robot.set_velocity(v[k], w[k])
                robot.step(dt[k])
                assert robot.clearance() >= -1e-9, (map_index, robot.pose, v[k], w[k], dt[k])


@settings(max_examples=60, deadline=None)
@given(seed=st.integers(0, 2**32 - 1), n_walls=st.integers(0, 120))
def test_grid_culled_lidar_agrees_with_brute_force(seed, n_walls):
    rng = np.random.default_rng(seed)
    walls = random_walls(rng, n_walls, size=rng.uniform(1.0, 20.0))
    if n_walls and rng.random() < 0.3:  # axis-aligned walls on cell boundaries and shared corners
        walls = np.round(walls)
    grid = SegmentGrid.build(walls)
    for _ in range(5):
        ox, oy = rng.uniform(-12, 12, 2)
        angles = rng.uniform(-math.pi, math.pi) + np.linspace(-2.1, 2.1, 681)
        fast = grid.cast(ox, oy, angles, 4.0)
        np.testing.assert_allclose(fast, brute_cast_fan(walls, ox, oy, angles, 4.0), atol=1e-9)
        if n_walls and rng.random() < 0.2:
            np.testing.assert_allclose(fast, numpy_cast_fan(walls, ox, oy, angles, 4.0), atol=1e-9)


def test_example_map_full_run_stays_valid():
    robot = CreateModel(
        load_map(config_path("create/example.map")),
        load_config(config_path("create/example_config.txt")),
        rng=np.random.default_rng(5),
    )
    rng = np.random.default_rng(6)
    for _ in range(40):
        drive(robot, *rng.uniform([-0.5, -2], [0.5, 2]), 0.5)
        assert robot.clearance() >= -1e-9
        robot.bumps(), robot.cliff_signals(), robot.sonar(), robot.lidar(), robot.camera()
        robot.wall_sensor(), robot.virtual_wall()


def _rotate(points: np.ndarray, angle: float) -> np.ndarray:
    c, s = math.cos(angle), math.sin(angle)
    return points @ np.array([[c, s], [-s, c]])


def test_a_robot_meeting_a_free_wall_end_head_on_at_0_052_m_offset_rolls_round_it():
    """Within atan(μ) of head-on, friction used to stop the robot dead on the wall's end."""
    robot = CreateModel(world(walls=[[2.45, 0.55, 2.45, 2.0]]), pose=(1.8, 0.5, 0.0))
    drive(robot, 0.25, 0.0, 5.0)
    x, y, _ = robot.pose
    assert x > 2.45 + R and y < 0.55 - R + 1e-9


@pytest.mark.parametrize("scene_angle", [0.0, 1.1, 2.5, -2.0])
def test_a_robot_meeting_a_free_wall_end_at_any_angle_rolls_round_it(scene_angle):
    """Sweep: contact angles from 2° to 89° off head-on, walls leaning 0–45° away, rotated scenes.

    In the scene's frame the robot drives along +x and the wall's free end sits ``offset`` to
    its left (so the contact is sin⁻¹(offset / r) off head-on), the wall running away to the left.
    It must roll round the end and drive on (never stuck on it), never inside the wall.
    """
    dt, v, seconds = 0.01, 0.3, 5.0
    for lean in np.radians([0.0, -15.0, -30.0, -45.0]):
        for offset in (0.005, 0.02, 0.04, 0.052, 0.054, 0.08, 0.12, 0.159):
            direction = math.pi / 2 + lean
            end = np.array([0.0, offset])
            wall = np.vstack([end, end + 2.0 * np.array([math.cos(direction), math.sin(direction)])])
            robot = CreateModel(
                world(walls=[_rotate(wall, scene_angle).reshape(4)]),
                pose=(*_rotate(np.array([[-0.6, 0.0]]), scene_angle)[0], scene_angle),
            )
            robot.set_velocity(v, 0.0)
            for _ in range(round(seconds / dt)):
                robot.step(dt)
                assert robot.clearance() >= -1e-9, (scene_angle, lean, offset, robot.pose)
            local = _rotate(robot.pose[None, :2], -scene_angle)[0]
            case = (scene_angle, math.degrees(lean), offset, local)
            assert local[0] > 0.3 and local[1] <= offset - R + 1e-6, case
            assert robot.velocity[0] == pytest.approx(v), case


def test_a_map_spanning_the_coordinate_limit_builds_and_steps():
    """Walls ±1,000 km apart: the grid coarsens within its cell cap and the robot still moves."""
    robot = CreateModel(world(walls=[[1e6, 0, -1e6, 0], [-1e6, -1e6, 1e6, 1e6], [1, -1, 1, 1]]), pose=(0.5, -0.5, 0))
    assert robot.grid.nx * robot.grid.ny <= MAX_GRID_CELLS
    drive(robot, 0.5, 0.0, 2.0)
    assert np.isfinite(robot.pose).all() and robot.clearance() >= -1e-9
    assert np.isfinite(robot.lidar()).any()


def test_a_programmatic_map_beyond_the_coordinate_limit_is_refused():
    with pytest.raises(InputError, match=r"walls have coordinates beyond"):
        CreateModel(world(walls=[[1e300, 0, -1e300, 0]]))


@pytest.mark.filterwarnings("ignore:invalid value encountered")
@pytest.mark.parametrize("bad", [np.nan, np.inf, -np.inf, 1e300, -1e300, 1e18])
def test_grid_kernels_answer_any_query_point_without_reading_outside_the_grid(bad):
    """Rays and contact queries from NaN, infinite and far-off points: no hit, no crash."""
    grid = SegmentGrid.build(np.array([[0.0, 0.0, 1.0, 1.0], [0.0, 1.0, 1.0, 0.0]]))
    contacts = new_contacts(grid.segments.shape[0])
    for x, y in ((bad, 0.5), (0.5, bad), (bad, bad)):
        assert grid_contacts(grid, x, y, 0.5, contacts) == 0
        out = grid.cast(x, y, np.array([0.0, 1.0, math.pi, bad]), 4.0)
        assert np.isinf(out).all()
    ray = grid.cast(0.5, 0.2, np.array([bad]), 4.0)  # any direction: a hit or nothing, never NaN
    assert np.isinf(ray).all() if not math.isfinite(bad) else (ray >= 0.0).all()
    assert grid_contacts(grid, 0.5, 0.5, bad, contacts) in (0, 2)


def test_a_step_longer_than_an_hour_is_refused():
    robot = CreateModel(world())
    robot.set_velocity(0.5, 0.0)
    with pytest.raises(ValueError, match="time step"):
        robot.step(1e300)
