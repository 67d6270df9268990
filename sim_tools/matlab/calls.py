"""The Create toolbox's functions as the bridge serves them: name → a call on :class:`CreateRobot`.

Each entry takes the robot and the numeric arguments that followed ``serPort`` in the program and
returns the function's outputs in the toolbox's order, as the m-files hand them back: numbers
(booleans as 0/1, as the toolbox's serial bytes were), vectors and, for ``ReadBeacon``, text. A
sensor with nothing in range reads its range limit, as the original's saturated readings did
(the Python client says ``None``/``inf`` instead).
"""

from __future__ import annotations

import math
from collections.abc import Callable, Sequence
from dataclasses import dataclass
from typing import Any

from create_sim.client import CreateRobot
from create_sim.model import CreateModel

SONAR_LIMIT = CreateModel.SONAR_RANGE[1]  # m, what ReadSonar says when no echo comes back
LIDAR_LIMIT = CreateModel.LIDAR_RANGE[1]  # m, likewise for each LIDAR ray


@dataclass(frozen=True)
class Call:
    """One toolbox function: how many numeric arguments it takes and what it does with them."""

    run: Callable[..., Sequence[Any]]
    min_args: int
    max_args: int
    arg_names: str  # for the error when the count is wrong


def _flags(*values: bool) -> list[float]:
    return [float(v) for v in values]


def _sonar(value: float | None) -> float:
    return SONAR_LIMIT if value is None else value


def _lidar(robot: CreateRobot) -> list[Any]:
    return [[r if math.isfinite(r) else LIDAR_LIMIT for r in robot.lidar().tolist()]]


def _camera(robot: CreateRobot) -> list[Any]:
    angles, distances, colours = robot.camera()
    return [angles.tolist(), distances.tolist(), colours.tolist()]


def _beacons(robot: CreateRobot) -> list[Any]:
    return [[list(beacon) for beacon in robot.read_beacon()]]


def _none(function: Callable[..., Any]) -> Callable[..., list[Any]]:
    """A command: the toolbox function returns nothing."""
    return lambda robot, *args: (function(robot, *args), [])[1]


def _one(function: Callable[..., Any]) -> Callable[..., list[Any]]:
    """A reading with one output."""
    return lambda robot, *args: [float(function(robot, *args))]


R = CreateRobot
CLIFFS = {"Left": "left", "FrontLeft": "front_left", "FrontRight": "front_right", "Right": "right"}

CALLS: dict[str, Call] = {
    "SetFwdVelAngVelCreate": Call(_none(R.set_fwd_vel_ang_vel), 2, 2, "FwdVel, AngVel"),
    "SetFwdVelRadiusRoomba": Call(_none(R.set_fwd_vel_radius), 2, 2, "FwdVel, Radius"),
    "SetDriveWheelsCreate": Call(_none(R.set_drive_wheels), 2, 2, "rightWheelVel, leftWheelVel"),
    "travelDist": Call(_none(R.travel_dist), 2, 2, "roombaSpeed, distance"),
    "turnAngle": Call(_none(R.turn_angle), 2, 2, "roombaSpeed, turnAngle"),
    "BeepRoomba": Call(_none(lambda robot: None), 0, 0, ""),  # the m-file beeps; nothing to do here
    "SetLEDsRoomba": Call(_none(lambda robot, led, *a: robot.set_leds(int(led), *a)), 3, 3, "LED, Color, Intensity"),
    "BumpsWheelDropsSensorsRoomba": Call(lambda robot: _flags(*robot.bumps_wheel_drops()), 0, 0, ""),
    "WallSensorReadRoomba": Call(_one(R.wall_sensor), 0, 0, ""),
    "VirtualWallSensorCreate": Call(_one(R.virtual_wall_sensor), 0, 0, ""),
    **{
        f"Cliff{name}SignalStrengthRoomba": Call(_one(getattr(R, f"cliff_{attr}_signal_strength")), 0, 0, "")
        for name, attr in CLIFFS.items()
    },
    **{
        f"Cliff{name}SensorRoomba": Call(_one(getattr(R, f"cliff_{attr}_sensor")), 0, 0, "")
        for name, attr in CLIFFS.items()
    },
    "ReadSonar": Call(lambda robot, n=2: [_sonar(robot.read_sonar(int(n)))], 0, 1, "sonarNum"),
    "ReadSonarMultiple": Call(
        lambda robot, *n: [[_sonar(v) for v in robot.read_sonar_multiple(*(int(k) for k in n))]], 0, 4, "sonarNums"
    ),
    "LidarSensorCreate": Call(_lidar, 0, 0, ""),
    "CameraSensorCreate": Call(_camera, 0, 0, ""),
    "ReadBeacon": Call(_beacons, 0, 0, ""),
    "OverheadLocalizationCreate": Call(lambda robot: list(robot.overhead_localization()), 0, 0, ""),
    "DistanceSensorRoomba": Call(_one(R.distance_sensor), 0, 0, ""),
    "AngleSensorRoomba": Call(_one(R.angle_sensor), 0, 0, ""),
    "ButtonsSensorRoomba": Call(lambda robot: _flags(*robot.buttons()), 0, 0, ""),
    "BatteryChargeReaderRoomba": Call(lambda robot: list(robot.battery_charge()), 0, 0, ""),
    "BatteryVoltageRoomba": Call(_one(R.battery_voltage), 0, 0, ""),
    "CurrentTesterRoomba": Call(_one(R.current_tester), 0, 0, ""),
    "AllSensorsReadRoomba": Call(lambda robot: [float(v) for v in robot.all_sensors_read()], 0, 0, ""),
}


def run_call(robot: CreateRobot, name: str, args: Sequence[float]) -> list[Any]:
    """The outputs of toolbox function ``name`` called with ``args``; ValueError for a bad call."""
    call = CALLS.get(name)
    if call is None:
        raise ValueError(f"{name} is not a function of the Create toolbox on this bridge")
    if not call.min_args <= len(args) <= call.max_args:
        expected = f"({call.arg_names})" if call.arg_names else "no arguments"
        raise ValueError(f"{name} takes serPort and {expected}, got {len(args)} more argument(s)")
    return list(call.run(robot, *args))
