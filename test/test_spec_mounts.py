"""Every sensor measures from where ``/tf_static`` (and so the URDF and RViz) says it is mounted.

The mounts are taken from the transforms the world nodes publish on ``/tf_static``
(``create_sim.world_node.sensor_transforms``, ``simrobot_sim.world_node.static_transforms``), put
on the robot at random poses (seeded), and the model's own readings are checked against targets
placed relative to that frame: a wall at a known distance along the sensor's axis, a line under
a cliff sensor, an emitter just inside or outside the halo of the virtual-wall receiver, a beacon
at a known bearing from the camera.
"""

from __future__ import annotations

import math

import numpy as np
import pytest

from create_sim.mapfile import parse_map
from create_sim.model import CreateModel
from create_sim.physics import CONTACT_SKIN
from create_sim.spec import CLIFF_NAMES, SONAR_NAMES, VWALL_HALO_M
from create_sim.world_node import sensor_transforms
from sim_runtime.msgs import yaw_from_quaternion
from simrobot_sim.model import SimrobotWorld
from simrobot_sim.world_file import RobotSpec, SensorSpec, WorldSpec
from simrobot_sim.world_node import static_transforms

POSES = 12
"""Random robot poses per sensor."""


def _mounts(transforms) -> dict[str, tuple[float, float, float]]:
    """Child frame → (x, y, yaw) of its transform."""
    out = {}
    for t in transforms:
        tr = t.transform
        out[t.child_frame_id] = (tr.translation.x, tr.translation.y, yaw_from_quaternion(tr.rotation))
    return out


CREATE_MOUNTS = _mounts(sensor_transforms(""))


def _in_world(pose, mount) -> tuple[float, float, float]:
    """A frame mounted on a robot at ``pose`` (x, y, heading), in the world: x, y and yaw."""
    x, y, h = pose
    mx, my, myaw = mount
    c, s = math.cos(h), math.sin(h)
    return x + c * mx - s * my, y + s * mx + c * my, h + myaw


def _poses(seed: int, n: int = POSES):
    rng = np.random.default_rng(seed)
    for _ in range(n):
        yield float(rng.uniform(-2.0, 2.0)), float(rng.uniform(-2.0, 2.0)), float(rng.uniform(-math.pi, math.pi))


def _wall_across(x: float, y: float, yaw: float, distance: float, half_length: float = 0.5) -> str:
    """A map line ``wall`` across the ray from (x, y) along ``yaw``, ``distance`` ahead."""
    cx, cy = x + distance * math.cos(yaw), y + distance * math.sin(yaw)
    nx, ny = -math.sin(yaw) * half_length, math.cos(yaw) * half_length
    return f"wall {cx - nx!r} {cy - ny!r} {cx + nx!r} {cy + ny!r}"


def _create(map_text: str, pose) -> CreateModel:
    return CreateModel(parse_map(map_text, "mounts.map"), pose=pose)


def test_every_create_sensor_frame_is_on_tf_static():
    sensors = {"laser", "camera", "wall_ir", "virtual_wall_ir", "bump_left", "bump_right"}
    sensors |= {f"sonar_{n}" for n in SONAR_NAMES} | {f"cliff_{n}" for n in CLIFF_NAMES}
    assert set(CREATE_MOUNTS) == sensors
    assert {t.header.frame_id for t in sensor_transforms("robot1/")} == {"robot1/base_link"}


def test_the_lidar_measures_from_its_mount():
    rng = np.random.default_rng(1)
    centre_beam = CreateModel.LIDAR_BEAMS // 2  # straight along the laser frame's x axis
    for pose in _poses(1):
        mx, my, yaw = _in_world(pose, CREATE_MOUNTS["laser"])
        distance = float(rng.uniform(0.3, 3.5))
        scan = _create(_wall_across(mx, my, yaw, distance), pose).lidar()
        assert scan[centre_beam] == pytest.approx(distance, rel=1e-6)


@pytest.mark.parametrize(("k", "name"), list(enumerate(SONAR_NAMES)))
def test_each_sonar_measures_from_its_mount(k, name):
    rng = np.random.default_rng(10 + k)
    for pose in _poses(10 + k):
        mx, my, yaw = _in_world(pose, CREATE_MOUNTS[f"sonar_{name}"])
        distance = float(rng.uniform(0.05, 2.5))
        ranges = _create(_wall_across(mx, my, yaw, distance), pose).sonar()
        assert ranges[k] == pytest.approx(distance, abs=1e-9)


def test_the_ir_wall_sensor_sees_a_wall_within_its_range_of_its_mount_along_its_axis():
    reach = CreateModel.IR_RANGE
    for pose in _poses(2):
        mx, my, yaw = _in_world(pose, CREATE_MOUNTS["wall_ir"])
        assert _create(_wall_across(mx, my, yaw, 0.9 * reach, 0.05), pose).wall_sensor()
        assert not _create(_wall_across(mx, my, yaw, 1.1 * reach, 0.05), pose).wall_sensor()


@pytest.mark.parametrize(("side", "pressed"), [("left", (True, False)), ("right", (False, True))])
def test_a_wall_touching_the_body_at_a_bumpers_mount_presses_that_bumper(side, pressed):
    for pose in _poses(3):
        mx, my, _ = _in_world(pose, CREATE_MOUNTS[f"bump_{side}"])
        outward = math.atan2(my - pose[1], mx - pose[0])  # the contact's bearing from the centre
        wall = _wall_across(mx, my, outward, 0.5 * CONTACT_SKIN, 0.05)
        assert _create(wall, pose).bumps() == pressed


@pytest.mark.parametrize(("k", "name"), list(enumerate(CLIFF_NAMES)))
def test_a_line_under_a_cliff_sensors_mount_darkens_that_sensor_alone(k, name):
    for pose in _poses(20 + k):
        mx, my, _ = _in_world(pose, CREATE_MOUNTS[f"cliff_{name}"])
        ux, uy = mx - pose[0], my - pose[1]  # the body's edge at the mount, from the centre
        line = f"line {pose[0] + 0.8 * ux!r} {pose[1] + 0.8 * uy!r} {pose[0] + 1.2 * ux!r} {pose[1] + 1.2 * uy!r}"
        signals = _create(line, pose).cliff_signals()
        expected = np.full(4, CreateModel.CLIFF_FLOOR)
        expected[k] = CreateModel.CLIFF_LINE
        assert signals.tolist() == expected.tolist()


def test_the_virtual_wall_receiver_is_in_an_emitters_halo_exactly_when_its_mount_is():
    rng = np.random.default_rng(4)
    for pose in _poses(4):
        mx, my, _ = _in_world(pose, CREATE_MOUNTS["virtual_wall_ir"])
        away = float(rng.uniform(-math.pi, math.pi))
        for distance, seen in ((0.98 * VWALL_HALO_M, True), (1.02 * VWALL_HALO_M, False)):
            ex, ey = mx + distance * math.cos(away), my + distance * math.sin(away)
            # the emitter's field points away from the receiver: only its halo can reach it
            emitter = f"virtwall {ex!r} {ey!r} {away!r} 1"
            assert _create(emitter, pose).virtual_wall() is seen, (pose, distance)


def test_the_camera_measures_beacons_from_its_mount():
    rng = np.random.default_rng(5)
    for pose in _poses(5):
        mx, my, yaw = _in_world(pose, CREATE_MOUNTS["camera"])
        distance, bearing = float(rng.uniform(0.5, 5.0)), float(rng.uniform(-1.0, 1.0))
        bx, by = mx + distance * math.cos(yaw + bearing), my + distance * math.sin(yaw + bearing)
        (sighting,) = _create(f"beacon {bx!r} {by!r} [1 0 0] b", pose).camera()
        assert sighting.distance == pytest.approx(distance, abs=1e-9)
        assert sighting.angle == pytest.approx(bearing, abs=1e-9)


# ---------------------------------------------------------------------------------- SIMROBOT
RESOLUTION = 0.01
FREE_CELLS = 400
"""An empty square map this many cells wide (4 m), a wall column at :data:`WALL_X_CELL`."""
WALL_X_CELL = 350


def _simrobot_world(seed: int) -> tuple[WorldSpec, SimrobotWorld]:
    """One robot at a random pose and scale with three sensors at random mounts, in a room whose
    only obstacle is a wall column at x = WALL_X_CELL cells."""
    rng = np.random.default_rng(seed)
    sensors = tuple(
        SensorSpec(
            f"s{j}",
            "laser",
            position=(float(rng.uniform(-0.03, 0.04)), float(rng.uniform(-0.03, 0.03))),
            axis=float(rng.uniform(-0.5, 0.5)),
            beamwidth=0.0,
            range=3.0,
            rays=1,
        )
        for j in range(3)
    )
    robot = RobotSpec(
        "r1",
        (float(rng.uniform(2.0, 2.8)), float(rng.uniform(1.0, 3.0))),
        heading=float(rng.uniform(-0.5, 0.5)),
        scale=float(rng.uniform(0.8, 1.5)),
        sensors=sensors,
    )
    walls = np.zeros((FREE_CELLS, FREE_CELLS), dtype=np.uint8)
    walls[WALL_X_CELL, :] = 1
    spec = WorldSpec(walls=walls, resolution=RESOLUTION, robots=(robot,))
    return spec, SimrobotWorld(spec)


@pytest.mark.parametrize("seed", range(4))
def test_simrobot_sensor_origins_are_their_tf_static_mounts(seed):
    spec, world = _simrobot_world(seed)
    mounts = _mounts(static_transforms(spec, "sim1/"))
    pose = world.poses()[0]
    for k, sensor in enumerate(world.sensors):
        expected = _in_world(pose, mounts[f"sim1/r1/{sensor.name}"])
        assert world.sensor_origin(k) == pytest.approx(expected, abs=1e-9)


@pytest.mark.parametrize("seed", range(4))
def test_simrobot_rays_start_at_their_tf_static_mounts(seed):
    spec, world = _simrobot_world(seed)
    mounts = _mounts(static_transforms(spec, ""))
    pose = world.poses()[0]
    wall_x = WALL_X_CELL * RESOLUTION  # the wall column's near edge
    for k, sensor in enumerate(world.sensors):
        mx, _my, yaw = _in_world(pose, mounts[f"r1/{sensor.name}"])
        distances, obstacles = world.ranges(k)
        assert obstacles.tolist() == [1]
        assert distances[0] == pytest.approx((wall_x - mx) / math.cos(yaw), abs=1e-9)
