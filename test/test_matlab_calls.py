"""The toolbox rules the bridge applies, as the original toolbox applies them (no ROS, no Octave):
turnAngle's wrap, the RealSense depths from a LIDAR scan, the saved data's call texts."""

from __future__ import annotations

import math

import numpy as np
import pytest

from create_sim.model import CreateModel
from sim_tools.matlab.calls import CALLS, DEPTH_MAX, call_text, depths, tag_number, toolbox_turn


@pytest.mark.parametrize(
    ("asked", "turned"),
    [(90, 90), (270, -90), (-270, 90), (360, 0), (-360, 0), (180, 180), (-180, -180), (540, 180), (725, 5)],
)
def test_turn_angle_wraps_the_angle_the_short_way_round_as_the_originals_wrap2pi(asked, turned):
    assert toolbox_turn(asked) == pytest.approx(turned, abs=1e-9)


def test_realsense_depths_are_the_lidars_rays_measured_along_the_heading_from_the_centre():
    bearings = np.linspace(-0.5 * CreateModel.LIDAR_FOV, 0.5 * CreateModel.LIDAR_FOV, CreateModel.LIDAR_BEAMS)
    # A wall square to the robot 1.2 m from its centre: each ray from the front edge reads
    # (1.2 - radius) / cos(bearing); every depth is 1.2.
    wall = (1.2 - CreateModel.RADIUS) / np.cos(bearings)
    assert depths(wall) == pytest.approx([1.2] * 9, abs=1e-9)
    # Nothing within the LIDAR's reach: the original's "too far" value; too close: 0.
    assert depths(np.full(CreateModel.LIDAR_BEAMS, np.inf)) == [DEPTH_MAX] * 9
    close = np.full(CreateModel.LIDAR_BEAMS, 0.0)
    assert depths(close) == [0.0] * 9
    # Left-most first: an obstacle on the left shows in the first depths only.
    left = np.where(bearings > math.radians(20), 0.3, np.inf)
    assert depths(left)[0] < 1.0 and depths(left)[-1] == DEPTH_MAX


def test_tag_numbers_are_the_map_ids_as_numbers():
    assert tag_number("7") == 7.0 and math.isnan(tag_number("b1"))


@pytest.mark.parametrize(
    ("name", "args", "outputs", "text"),
    [
        ("travelDist", [0.2, 0.5], [], "travelDist(0.200,0.500)"),
        ("TravelDistCreate", [0.2, -0.5], [], "travelDist(0.200,-0.500)"),
        ("TurnCreate", [0.1, 270], [], "turnAngle(0.100,270.000)"),
        ("SetFwdVelAngVelCreate", [0.2, 0.0], [], "SetFwdVelAngVelCreate(0.200,0.000)"),
        ("SetLEDsRoomba", [1, 50, 100], [], "SetLEDsRoomba(1,50,100)"),
        ("DemoCmdsCreate", [3], [], "DemoCmdsCreate(3)"),
        ("BeepCreate", [], [], "BeepRoomba"),
        (
            "BumpsWheelDropsSensorsRoomba",
            [],
            [0.0, 1.0, 0.0, 0.0, 0.0, 0.0],
            "[0 1 0 0 0 0]= BumpsWheelDropsSensorsRoomba",
        ),
        ("ReadSonar", [2], [0.4123], "0.412= ReadSonar"),
        ("ReadSonar", [4], [[]], "[]= ReadSonar"),
        ("ReadSonarMultiple", [3], [[]], "[]= ReadSonarMultiple(3)"),
        ("ReadSonarMultiple", [1], [1.5], "1.500= ReadSonarMultiple(1)"),
        ("OverheadLocalizationCreate", [], [1.0, 2.0, -0.5], "[1.000 2.000 -0.500]]= OverheadLocalizationCreate"),
        ("VirtualWallSensorCreate", [], [1.0], "1= VirtualWallSensorCreate"),
        ("ReadBeacon", [], [[-0.1], [0.0], [0.4], [0.0], [7.0]], "[-0.100 0.000 0.400 0.000 7.000] = ReadBeacon"),
        ("ReadBeacon", [], [[], [], [], [], []], "[]= ReadBeacon"),
        ("RealSenseTag", [], [[]], "[]= RealSenseTag"),
        ("RealSenseTag", [], [[[0.1, 7.0, 0.4, 0.1, 0.0]]], "[0.400 0.100 0.000 0.000 7.000] = RealSenseTag"),
        (
            "CameraSensorCreate",
            [],
            [[0.3], [1.2], [[1.0, 0.0, 0.0]]],
            "[0.300 1.200 [1.000 0.000 0.000]]= CameraSensorCreate",
        ),
        ("RealSenseDist", [], [[0.05, *range(1, 10)]], "[0.050 2.000 4.000 6.000 9.000]= RealSenseDist"),
        ("LidarSensorCreate", [], [list(range(681))], "[0.000 170.000 340.000 510.000 680.000]= LidarSensorCreate"),
    ],
)
def test_calls_are_written_as_the_originals_saved_data_writes_them(name, args, outputs, text):
    assert name in CALLS
    assert call_text(name, args, outputs) == text
