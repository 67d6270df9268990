"""The Create toolbox's functions as the bridge serves them: name → a call on :class:`CreateRobot`.

Each entry takes the robot and the numeric arguments that followed ``serPort`` in the program and
returns the function's outputs in the toolbox's order, as the m-files hand them back: numbers
(booleans as 0/1, as the toolbox's serial bytes were), vectors, ``[]`` (a JSON empty list) where
the original returns an empty matrix. Out-of-range behaviour is the original toolbox's at its
latest version: ``ReadSonar`` says ``[]`` when nothing is in range, ``turnAngle`` takes the short
way round, a LIDAR ray with nothing in range reads the range limit.

:func:`call_text` writes a call the way the original simulator wrote it into its saved data
(``travelDist(0.200,0.500)``, ``0.412= ReadSonar``): the bridge publishes it on ``matlab_calls``,
and ``bag_to_mat`` puts it into ``datahistory``'s fifth column.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np

from create_sim import spec
from create_sim.client import CreateRobot
from create_sim.model import CreateModel

SONAR_LIMIT = CreateModel.SONAR_RANGE[1]  # m: the original's sonars say [] at and beyond it
# m: the original's latest toolbox says [] for an echo this close or closer (it raised its sonar's
# minimum from 0.02 m to the real sensor's 0.17 m).
SONAR_MIN_TOOLBOX = 0.17
LIDAR_LIMIT = CreateModel.LIDAR_RANGE[1]  # m, what each LIDAR ray reads with nothing in range

# The original's RealSense depth camera: 9 rays over 54°, left-most first, depths (the distance
# along the heading, not along the ray) of 0.175-10 m; 0 closer than that, 10 beyond.
DEPTH_RAYS = 9
DEPTH_FOV = math.radians(54.0)
DEPTH_MIN = 0.175
DEPTH_MAX = 10.0
# Our depth readings come from the LIDAR (the only range model that looks ahead): the ray of its
# 681 nearest each depth ray's bearing, measured from the LIDAR's place at the front edge. Adding
# the body's radius gives the depth from the plane through the robot's centre, where the
# original's camera is (it also sits 0.08 m to the left; we do not model that).
_LIDAR_BEARINGS = np.linspace(-0.5 * CreateModel.LIDAR_FOV, 0.5 * CreateModel.LIDAR_FOV, CreateModel.LIDAR_BEAMS)
_DEPTH_BEARINGS = np.linspace(0.5 * DEPTH_FOV, -0.5 * DEPTH_FOV, DEPTH_RAYS)  # left-most first
_DEPTH_BEAMS = np.abs(_LIDAR_BEARINGS[None, :] - _DEPTH_BEARINGS[:, None]).argmin(axis=1)


@dataclass(frozen=True)
class Call:
    """One toolbox function: how many numeric arguments it takes and what it does with them."""

    run: Callable[..., Sequence[Any]]
    min_args: int
    max_args: int
    arg_names: str  # for the error when the count is wrong


def _flags(*values: bool) -> list[float]:
    return [float(v) for v in values]


def _sonar(value: float | None, closed: bool) -> float | list[Any]:
    """The original's ReadSonar (``closed``: its limits count as out of range) and
    ReadSonarMultiple: ``[]`` when nothing is in range."""
    if value is None:
        return []
    if value < SONAR_MIN_TOOLBOX or value > SONAR_LIMIT or (closed and value in (SONAR_MIN_TOOLBOX, SONAR_LIMIT)):
        return []
    return value


def _read_sonar(robot: CreateRobot, n: float = 2) -> list[Any]:
    return [_sonar(robot.read_sonar(int(n)), closed=True)]


def _read_sonar_multiple(robot: CreateRobot, *numbers: float) -> list[Any]:
    """One sonar as the original (a number or ``[]``); none or several (our extension): a row with
    NaN where nothing is in range."""
    if len(numbers) == 1:
        return [_sonar(robot.read_sonar(int(numbers[0])), closed=False)]
    values = [_sonar(v, closed=False) for v in robot.read_sonar_multiple(*(int(k) for k in numbers))]
    return [[math.nan if v == [] else v for v in values]]


def toolbox_turn(angle_deg: float) -> float:
    """The turn (degrees) the original's turnAngle makes for ``angle_deg``: wrapped into
    [-180, 180] the short way round (270 turns -90, 360 does not turn, ±180 stays)."""
    angle = math.pi * angle_deg / 180.0
    while angle < -math.pi:  # as the original's wrap2pi: ±pi stay as they are
        angle += 2 * math.pi
    while angle > math.pi:
        angle -= 2 * math.pi
    return math.degrees(angle)


def _turn_angle(robot: CreateRobot, speed: float, angle: float) -> list[Any]:
    if not math.isfinite(angle):
        raise ValueError(f"angle must be a finite number, got {angle!r}")
    robot.turn_angle(speed, toolbox_turn(angle))
    return []


def _lidar(robot: CreateRobot) -> list[Any]:
    return [[r if math.isfinite(r) else LIDAR_LIMIT for r in robot.lidar().tolist()]]


def _camera(robot: CreateRobot) -> list[Any]:
    angles, distances, colours = robot.camera()
    return [angles.tolist(), distances.tolist(), colours.tolist()]


def tag_number(beacon_id: str) -> float:
    """A map's beacon id as the original's number (it read ids with str2num); NaN if not a number."""
    try:
        return float(beacon_id)
    except ValueError:
        return math.nan


def _read_beacon(robot: CreateRobot) -> list[Any]:
    """[X, Y, Z, ROT, Ntag], a column each: X right, Y down, Z ahead of the camera (m)."""
    beacons = robot.beacons()
    x = [-d * math.sin(a) for _id, d, a, _c in beacons]
    z = [d * math.cos(a) for _id, d, a, _c in beacons]
    zeros = [0.0] * len(beacons)
    return [x, zeros, z, zeros, [tag_number(b[0]) for b in beacons]]


def _real_sense_tag(robot: CreateRobot) -> list[Any]:
    """One row [dt id x y rot] per tag: x ahead of the camera, y left (m); dt the reading's age (s)."""
    beacons = robot.beacons()
    if not beacons:
        return [[]]
    age = robot.reading_age(spec.CAMERA_BEACONS_TOPIC)
    return [[[age, tag_number(i), d * math.cos(a), d * math.sin(a), 0.0] for i, d, a, _c in beacons]]


def depths(ranges: np.ndarray) -> list[float]:
    """The 9 RealSense depths (m, left-most first) from a LIDAR scan (681 ranges, inf = no return)."""
    r = ranges[_DEPTH_BEAMS].astype(float)
    depth = CreateModel.RADIUS + r * np.cos(_LIDAR_BEARINGS[_DEPTH_BEAMS])
    depth[~np.isfinite(r) | (depth > DEPTH_MAX)] = DEPTH_MAX
    depth[depth < DEPTH_MIN] = 0.0
    return depth.tolist()


def _real_sense_dist(robot: CreateRobot) -> list[Any]:
    """[dt; 9 depths], a column: dt the reading's age (s)."""
    return [[robot.reading_age(spec.SCAN_TOPIC), *depths(robot.lidar())]]


def _demo(robot: CreateRobot, number: float) -> list[Any]:
    if not (math.isfinite(number) and -1 <= number <= 9):
        raise ValueError(f"DemoNum must be between -1 and 9 to select valid demos, got {number!r}")
    return []  # the original has no demo either: the m-file prints its message


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
    "TravelDistCreate": Call(_none(R.travel_dist), 2, 2, "speed, distance"),
    "turnAngle": Call(_turn_angle, 2, 2, "roombaSpeed, turnAngle"),
    "TurnCreate": Call(_turn_angle, 2, 2, "speed, angle"),
    "BeepRoomba": Call(_none(lambda robot: None), 0, 0, ""),  # the m-file beeps; nothing to do here
    "BeepCreate": Call(_none(lambda robot: None), 0, 0, ""),
    "DemoCmdsCreate": Call(_demo, 1, 1, "DemoNum"),
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
    "ReadSonar": Call(_read_sonar, 0, 1, "sonarNum"),
    "ReadSonarMultiple": Call(_read_sonar_multiple, 0, 4, "sonarNum"),
    "LidarSensorCreate": Call(_lidar, 0, 0, ""),
    "CameraSensorCreate": Call(_camera, 0, 0, ""),
    "ReadBeacon": Call(_read_beacon, 0, 0, ""),
    "RealSenseDist": Call(_real_sense_dist, 0, 0, ""),
    "RealSenseTag": Call(_real_sense_tag, 0, 0, ""),
    "OverheadLocalizationCreate": Call(lambda robot: list(robot.overhead_localization()), 0, 0, ""),
    "DistanceSensorRoomba": Call(_one(R.distance_sensor), 0, 0, ""),
    "AngleSensorRoomba": Call(_one(R.angle_sensor), 0, 0, ""),
    "ButtonsSensorRoomba": Call(lambda robot: _flags(*robot.buttons()), 0, 0, ""),
    "BatteryChargeReaderRoomba": Call(lambda robot: list(robot.battery_charge()), 0, 0, ""),
    "BatteryVoltageRoomba": Call(_one(R.battery_voltage), 0, 0, ""),
    "CurrentTesterRoomba": Call(_one(R.current_tester), 0, 0, ""),
    "AllSensorsReadRoomba": Call(lambda robot: [float(v) for v in robot.all_sensors_read()], 0, 0, ""),
}


#: The commands (no outputs): the original wrote them into its saved data as they began.
COMMANDS = frozenset(
    {
        "SetFwdVelAngVelCreate",
        "SetFwdVelRadiusRoomba",
        "SetDriveWheelsCreate",
        "travelDist",
        "TravelDistCreate",
        "turnAngle",
        "TurnCreate",
        "BeepRoomba",
        "BeepCreate",
        "DemoCmdsCreate",
        "SetLEDsRoomba",
    }
)


def run_call(robot: CreateRobot, name: str, args: Sequence[float]) -> list[Any]:
    """The outputs of toolbox function ``name`` called with ``args``; ValueError for a bad call."""
    call = CALLS.get(name)
    if call is None:
        raise ValueError(f"{name} is not a function of the Create toolbox on this bridge")
    if not call.min_args <= len(args) <= call.max_args:
        expected = f"({call.arg_names})" if call.arg_names else "no arguments"
        raise ValueError(f"{name} takes serPort and {expected}, got {len(args)} more argument(s)")
    return list(call.run(robot, *args))


# ---------------------------------------------------------------- the original's saved-data text
# Arguments the original printed as integers; the rest with three decimals.
_WHOLE_ARGS = {"DemoCmdsCreate", "SetLEDsRoomba", "ReadSonarMultiple"}
# Outputs the original printed as integers (flags); AllSensorsReadRoomba: its first 15.
_WHOLE_OUTPUTS = {
    "BumpsWheelDropsSensorsRoomba",
    "ButtonsSensorRoomba",
    "VirtualWallSensorCreate",
    "WallSensorReadRoomba",
    *(f"Cliff{name}SensorRoomba" for name in CLIFFS),
}
# The wrappers the original wrote as the function they call.
_SAVED_AS = {"TravelDistCreate": "travelDist", "TurnCreate": "turnAngle", "BeepCreate": "BeepRoomba"}


def _number(value: Any, whole: bool) -> str:
    if value is None or (isinstance(value, float) and math.isnan(value)):
        return "NaN"
    return f"{value:.0f}" if whole else f"{value:.3f}"


def _samples(values: list[Any], count: int) -> list[Any]:
    """The original's five samples of a long reading: first, ¼, ½, ¾ (MATLAB's ceil, 1-based), last."""
    return [values[0], *(values[math.ceil(k * count / 4) - 1] for k in (1, 2, 3)), values[-1]]


def _outputs_text(name: str, outputs: list[Any]) -> str:
    if name in ("LidarSensorCreate", "RealSenseDist"):
        values = outputs[0]
        count = len(values) if name == "LidarSensorCreate" else DEPTH_RAYS
        return "[" + " ".join(_number(v, False) for v in _samples(values, count)) + "]"
    if name in ("ReadBeacon", "RealSenseTag"):
        if name == "ReadBeacon":
            first = [column[0] for column in outputs] if outputs[0] else []
        else:  # the original printed x, y, z (0), rot, id of the first tag
            first = [outputs[0][0][2], outputs[0][0][3], 0.0, outputs[0][0][4], outputs[0][0][1]] if outputs[0] else []
        return "[" + " ".join(_number(v, False) for v in first) + "]" if first else "[]"
    if name == "CameraSensorCreate":
        angles, dists, colours = outputs
        if not angles:
            return "[]"
        colour = " ".join(_number(c, False) for c in colours[0])
        return f"[{_number(angles[0], False)} {_number(dists[0], False)} [{colour}]]"
    if name == "AllSensorsReadRoomba":
        return "[" + " ".join(_number(v, k < 15) for k, v in enumerate(outputs)) + "]"
    flat = outputs[0] if len(outputs) == 1 and isinstance(outputs[0], list) else outputs
    if not flat:
        return "[]"
    text = " ".join(_number(v, name in _WHOLE_OUTPUTS) for v in flat)
    return text if len(flat) == 1 and not isinstance(outputs[0], list) else f"[{text}]"


def call_text(name: str, args: Sequence[float], outputs: list[Any]) -> str:
    """``name`` called with ``args`` and answering ``outputs``, as the original's saved data writes it."""
    saved = _SAVED_AS.get(name, name)
    if not outputs or name in ("travelDist", "TravelDistCreate", "turnAngle", "TurnCreate"):
        arguments = ",".join(_number(a, saved in _WHOLE_ARGS) for a in args)
        return f"{saved}({arguments})" if args else saved
    outputs_text = _outputs_text(name, outputs)
    # (the original's ReadBeacon and RealSenseTag wrote " = " after a tag, "= " after none)
    separator = " = " if name in ("ReadBeacon", "RealSenseTag") and outputs_text != "[]" else "= "
    # (the original's OverheadLocalizationCreate wrote a stray second bracket; so do we)
    closing = "]" if name == "OverheadLocalizationCreate" else ""
    suffix = f"({_number(args[0], True)})" if name == "ReadSonarMultiple" and len(args) == 1 else ""
    return f"{outputs_text}{closing}{separator}{saved}{suffix}"
