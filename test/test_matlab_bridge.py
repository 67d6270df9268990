"""MATLAB/Octave control programs, unchanged, against a create_world through ``matlab_bridge``.

One world (its own process, real time, a wall 0.6 m ahead of the robot) and one bridge serve the
module; each test resets the robot first. Octave programs are compared with their Python twins on
the toolbox-style client (test/matlab_programs/create_*.m and .py): at real time the two runs see
different message timings, so their tracks agree within TRACK_TOLERANCE (3 cm), not exactly, plus
what the sim time their stops took to reach the world explains (measured from the world's own
odometry: a busy machine delays them, more at three times real time, where the square runs).
"""

from __future__ import annotations

import math
import os
import re
import signal
import socket
import subprocess
import sys
import warnings
from dataclasses import dataclass
from pathlib import Path

import numpy as np
import pytest
from geometry_msgs.msg import PoseStamped
from nav_msgs.msg import Odometry
from octave_support import OCTAVE, octave_command
from rcl_interfaces.msg import Parameter as ParameterMsg
from rcl_interfaces.msg import ParameterType, ParameterValue
from rcl_interfaces.srv import SetParameters
from rclpy.qos import DurabilityPolicy, QoSProfile
from std_msgs.msg import String
from std_srvs.srv import Trigger

from sim_runtime.bag.reader import BagWarning, open_bag
from sim_runtime.errors import InputError
from sim_runtime.msgs import yaw_from_quaternion
from sim_runtime.qos import SENSOR_SUBSCRIBER_QOS
from sim_runtime.testing import Collector, spin_until
from sim_tools.cli import executable_command
from sim_tools.matlab.bridge import HELLO, KEY_ENV, LISTENING, PROTOCOL_VERSION, MatlabBridge, new_key, spawn_bridge
from sim_tools.matlab.calls import CALLS
from sim_tools.matlab.paths import matlab_dir

ROOT = Path(__file__).resolve().parent.parent
PROGRAMS = ROOT / "test" / "matlab_programs"
NAMESPACE = "/matlab"
TRACK_TOLERANCE = 0.03  # m: the furthest a point of one track may be from the other track
HEADING_TOLERANCE = math.radians(3)
needs_octave = pytest.mark.skipif(OCTAVE is None, reason="octave-cli not installed (CI installs it: .ci/run)")
ENV = dict(os.environ, PYTHONPATH=str(ROOT))
# Every public function of the original toolbox at its latest version (37): a program may call any.
ORIGINAL_FUNCTIONS = [
    "AllSensorsReadRoomba",
    "AngleSensorRoomba",
    "BatteryChargeReaderRoomba",
    "BatteryVoltageRoomba",
    "BeepCreate",
    "BeepRoomba",
    "BumpsWheelDropsSensorsRoomba",
    "ButtonsSensorRoomba",
    "CameraSensorCreate",
    "CliffFrontLeftSensorRoomba",
    "CliffFrontLeftSignalStrengthRoomba",
    "CliffFrontRightSensorRoomba",
    "CliffFrontRightSignalStrengthRoomba",
    "CliffLeftSensorRoomba",
    "CliffLeftSignalStrengthRoomba",
    "CliffRightSensorRoomba",
    "CliffRightSignalStrengthRoomba",
    "CurrentTesterRoomba",
    "DemoCmdsCreate",
    "DistanceSensorRoomba",
    "LidarSensorCreate",
    "OverheadLocalizationCreate",
    "ReadBeacon",
    "ReadSonar",
    "ReadSonarMultiple",
    "RealSenseDist",
    "RealSenseTag",
    "RoombaInit",
    "SetDriveWheelsCreate",
    "SetFwdVelAngVelCreate",
    "SetFwdVelRadiusRoomba",
    "SetLEDsRoomba",
    "TravelDistCreate",
    "TurnCreate",
    "VirtualWallSensorCreate",
    "travelDist",
    "turnAngle",
]


@pytest.fixture(scope="module")
def world(tmp_path_factory):
    """create_world in /matlab at real time: a wall across the floor 0.6 m ahead of the robot, and
    one along it 0.45 m to its right, meeting in a corner; a red beacon (tag 7) ahead on the floor."""
    map_file = tmp_path_factory.mktemp("matlab_map") / "walls.map"
    map_file.write_text("wall 0.6 -0.45 0.6 3\nwall -3 -0.45 0.6 -0.45\nbeacon 0.5 0.13 [1 0 0] 7\n")
    process = subprocess.Popen(
        executable_command("create_world", ["--ros-args", "-p", f"map_file:={map_file}", "-r", f"__ns:={NAMESPACE}"]),
        env=ENV,
        cwd=ROOT,
        stderr=subprocess.DEVNULL,
    )
    yield process
    process.send_signal(signal.SIGINT)
    process.wait(timeout=30)


@pytest.fixture(scope="module")
def bridge_port(world):
    process, port = spawn_bridge(NAMESPACE, env=ENV)
    yield port
    process.send_signal(signal.SIGINT)
    process.wait(timeout=30)


class Robot:
    """The test's view of the robot: its pose and odometry, and the world's reset."""

    def __init__(self, executor, node) -> None:
        self.executor, self.node = executor, node
        self.poses = Collector(node, PoseStamped, f"{NAMESPACE}/overhead_pose", SENSOR_SUBSCRIBER_QOS)
        self.odom = Collector(node, Odometry, f"{NAMESPACE}/odom", SENSOR_SUBSCRIBER_QOS)

    def call(self, srv_type, name: str, request):
        """The world's service ``name`` called (both are idempotent): again when no reply came in
        15 s, as a new client's first reply can be lost while its reader is still being matched
        (seen on a busy machine); a ceiling of four tries."""
        client = self.node.create_client(srv_type, f"{NAMESPACE}/{name}")
        assert client.wait_for_service(timeout_sec=120), f"no {name} service: is create_world up?"
        for _try in range(4):
            future = client.call_async(request)
            if spin_until(self.executor, future.done, timeout=15):
                return future.result()
            client.remove_pending_request(future)
        raise AssertionError(f"{name}: no reply to four calls in 60 s")

    def reset(self, real_time_factor: float = 1.0) -> None:
        """Real time factor set, robot back at the origin and standing, tracks cleared."""
        value = ParameterValue(type=ParameterType.PARAMETER_DOUBLE, double_value=real_time_factor)
        request = SetParameters.Request(parameters=[ParameterMsg(name="real_time_factor", value=value)])
        assert self.call(SetParameters, "create_world/set_parameters", request).results[0].successful
        assert self.call(Trigger, "reset", Trigger.Request()).success
        self.poses.clear()
        self.odom.clear()
        assert spin_until(self.executor, lambda: self.standing() and self.track() and self.track()[-1] == (0, 0), 10)
        self.poses.clear()

    def track(self) -> list[tuple[float, float]]:
        return [(m.pose.position.x, m.pose.position.y) for m in self.poses.msgs]

    def heading(self) -> float:
        return yaw_from_quaternion(self.poses.last.pose.orientation)

    def moving(self) -> bool:
        return self.odom.last is not None and abs(self.odom.last.twist.twist.linear.x) > 0.01

    def standing(self) -> bool:
        return self.odom.last is not None and not self.moving() and self.odom.last.twist.twist.angular.z == 0.0

    def run(self, argv: list[str], timeout: float = 60) -> subprocess.CompletedProcess:
        """A program in its own process, this node collecting the track while it runs."""
        process = subprocess.Popen(argv, env=ENV, cwd=ROOT, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
        try:
            assert spin_until(self.executor, lambda: process.poll() is not None, timeout), f"{argv} still running"
        finally:
            if process.poll() is None:
                process.kill()
        out, err = process.communicate()
        # The last poses in: half a second more of them, standing.
        after = len(self.poses.msgs)
        assert spin_until(self.executor, lambda: len(self.poses.msgs) >= after + 5, 10), "the world stopped"
        return subprocess.CompletedProcess(argv, process.returncode, out, err)


@pytest.fixture
def robot(world, executor, make_node):
    return Robot(executor, make_node("matlab_probe"))


def octave(port: int, program: str, *paths: Path) -> list[str]:
    """octave-cli running ``program(serPort)`` with our toolbox (and ``paths``) on the path."""
    adds = "".join(f"addpath('{p}'); " for p in (matlab_dir("create"), PROGRAMS, *paths))
    return octave_command(f"{adds}serPort = CreateRobot({port}); {program}")


def python_twin(name: str) -> list[str]:
    return [sys.executable, str(PROGRAMS / f"{name}.py"), NAMESPACE]


def furthest(track: list[tuple[float, float]], other: list[tuple[float, float]]) -> float:
    """The largest distance from a point of ``track`` to the nearest point of ``other`` (and back)."""

    def one_way(a, b):
        return max(min(math.dist(p, q) for q in b) for p in a)

    return max(one_way(track, other), one_way(other, track))


def run_both(robot: Robot, port: int, name: str, real_time_factor: float = 1.0, odometry: list | None = None):
    """The Octave program and its Python twin from the same start: (track, heading) of each (and
    each run's odometry messages appended to ``odometry``)."""
    runs = []
    for argv in (octave(port, f"{name}(serPort)", PROGRAMS / "create_real_toolbox"), python_twin(name)):
        robot.reset(real_time_factor)
        done = robot.run(argv)
        assert done.returncode == 0, done.stderr
        assert robot.standing()
        runs.append((robot.track(), robot.heading()))
        if odometry is not None:
            odometry.append(list(robot.odom.msgs))
    return runs


ODOM_PERIOD = 1 / 50  # s (sim): the world's odometry rate
# s (sim): two catch-up bursts (MAX_CATCH_UP_STEPS steps each, during which the world reads no
# command) of a world behind real time. A stop later than that was missed, not late (seen on 2
# cores at load 28, three times real time: 0.5 s).
LAG_CEILING = 1.0


@dataclass(frozen=True)
class Move:
    """One drive of a program, read from the world's odometry: its kind ("forward", "back",
    "left", "right"), how far it went (m or rad), and how long (sim s) it ran on past its goal at
    its speed: the sim time its stop took to reach the world, what a busy machine changes."""

    kind: str
    progress: float
    lag: float


def moves(odometry: list[Odometry], goals: dict[str, float], speeds: dict[str, float]) -> list[Move]:
    """The drives in a run's odometry, each from the pose before its first message to the pose at
    the first message of another kind (the stop, or the next command, had arrived by then). Poses
    are absolute, so messages the probe missed on a busy machine change nothing."""

    def kind(msg: Odometry) -> str:
        v, w = msg.twist.twist.linear.x, msg.twist.twist.angular.z
        if abs(v) > 0.01:
            return "forward" if v > 0 else "back"
        return ("left" if w > 0 else "right") if abs(w) > 0.01 else "stand"

    found, k = [], 1
    while k < len(odometry):
        what = kind(odometry[k])
        if what == "stand":
            k += 1
            continue
        start, progress = odometry[k - 1].pose.pose.position, 0.0
        while k < len(odometry):
            msg = odometry[k]
            if what in ("forward", "back"):
                progress = math.hypot(msg.pose.pose.position.x - start.x, msg.pose.pose.position.y - start.y)
            else:
                turn = yaw_from_quaternion(msg.pose.pose.orientation)
                turn -= yaw_from_quaternion(odometry[k - 1].pose.pose.orientation)
                progress += abs(math.remainder(turn, math.tau))
            if kind(msg) != what:
                break
            k += 1
        lag = max(progress - goals[what], 0.0) / speeds[what] if what in goals else 0.0
        found.append(Move(what, progress, lag))
    return found


def stop_lags_allowed(runs: list[list[Move]], speeds: dict[str, float], reach: float) -> float:
    """How far apart (m) the tracks of two runs of one program may be on top of TRACK_TOLERANCE,
    given what their stops' lags, measured in sim time, explain: a drive that ran on ``lag`` longer
    went ``speed * lag`` further; a turn that did turned the rest of the track (at most ``reach``
    long) by ``speed * lag``. Each lag is checked against LAG_CEILING first: a stop later than one
    catch-up burst of the world was missed, not late."""
    for run in runs:
        assert all(move.lag <= LAG_CEILING for move in run), run
    one, other = runs
    lin = sum(
        speeds[a.kind] * abs(a.lag - b.lag) for a, b in zip(one, other, strict=True) if a.kind in ("forward", "back")
    )
    ang = sum(
        speeds[a.kind] * abs(a.lag - b.lag) for a, b in zip(one, other, strict=True) if a.kind in ("left", "right")
    )
    return lin + ang * reach


@needs_octave
def test_a_bump_and_turn_program_runs_unchanged_in_octave_as_its_python_twin_does(robot, bridge_port):
    odometry: list[list[Odometry]] = []
    (octave_track, octave_heading), (python_track, python_heading) = run_both(
        robot, bridge_port, "create_bump_turn", odometry=odometry
    )
    # Two bumps at the wall (x = 0.6 - the body's radius), each followed by a 20° turn.
    assert max(x for x, _y in octave_track) == pytest.approx(0.6 - 0.17, abs=0.02)
    assert octave_heading == pytest.approx(math.radians(40), abs=HEADING_TOLERANCE)
    # After each bump travelDist(0.2, -0.1) and turnAngle(0.2, 20), ended by odometry; the two
    # runs' stops reach the world after different delays (more when a busy machine stalls a
    # process): the tracks may differ by what those delays, measured in sim time, explain.
    goals, speeds = {"back": 0.1, "left": math.radians(20)}, {"back": 0.2, "left": 0.2}
    runs = [[m for m in moves(o, goals, speeds) if m.kind != "forward"] for o in odometry]
    assert [[m.kind for m in run] for run in runs] == [["back", "left"] * 2] * 2, runs
    for run in runs:
        for move, goal in zip(run, [0.1, math.radians(20)] * 2, strict=True):
            assert move.progress >= goal - speeds[move.kind] * ODOM_PERIOD - 1e-3, run  # on its goal, not before
    explained = stop_lags_allowed(runs, speeds, reach=0.6)
    assert furthest(octave_track, python_track) < TRACK_TOLERANCE + explained
    turns = sum(0.2 * abs(a.lag - b.lag) for a, b in zip(*runs, strict=True) if a.kind == "left")
    assert octave_heading == pytest.approx(python_heading, abs=HEADING_TOLERANCE + turns)


@needs_octave
def test_a_travel_dist_turn_angle_square_matches_its_python_twin_at_three_times_real_time(robot, bridge_port):
    # No pause or tic/toc in it: travelDist and turnAngle wait on the robot's odometry, so the
    # program runs the same at any real_time_factor, but for when each stop reaches the world:
    # at three times real time the robot goes three times as far per wall second of delay, more
    # when a busy machine stalls a process. That delay is measured in sim time from the world's
    # own odometry, and the checks allow what it explains, no more.
    odometry: list[list[Odometry]] = []
    (octave_track, octave_heading), (python_track, python_heading) = run_both(
        robot, bridge_port, "create_square", 3.0, odometry
    )
    goals, speeds = {"forward": 0.25, "left": math.radians(90)}, {"forward": 0.25, "left": 0.2}
    runs = [moves(o, goals, speeds) for o in odometry]
    assert [[m.kind for m in run] for run in runs] == [["forward", "left"] * 4] * 2, runs
    for run in runs:  # each side and turn ended on its goal, not before
        assert all(m.progress >= goals[m.kind] - speeds[m.kind] * ODOM_PERIOD - 1e-3 for m in run), run
    explained = stop_lags_allowed(runs, speeds, reach=4 * 0.25)
    # Back where it started, but for what its own late stops explain (a turn's rotates the rest).
    overshoot = sum(speeds[m.kind] * m.lag * (1.0 if m.kind == "forward" else 4 * 0.25) for m in runs[0])
    assert math.dist(octave_track[-1], (0, 0)) < TRACK_TOLERANCE + overshoot
    assert furthest(octave_track, python_track) < TRACK_TOLERANCE + explained
    turns = sum(0.2 * abs(a.lag - b.lag) for a, b in zip(*runs, strict=True) if a.kind == "left")
    assert math.remainder(octave_heading - python_heading, math.tau) == pytest.approx(0, abs=HEADING_TOLERANCE + turns)


@needs_octave
def test_a_sonar_wall_follower_turns_the_corner_as_its_python_twin_does(robot, bridge_port):
    (octave_track, octave_heading), (python_track, python_heading) = run_both(
        robot, bridge_port, "create_wall_follower"
    )
    # Along the wall on the right, then left at the corner and along the wall ahead.
    assert min(y for _x, y in octave_track) > -0.45 + 0.17 and max(x for x, _y in octave_track) < 0.6 - 0.17
    assert max(y for _x, y in octave_track) > 0.1 and octave_heading > math.radians(45)
    assert furthest(octave_track, python_track) < TRACK_TOLERANCE
    # It stops on the clock, mid-correction: 50 ms later or earlier the heading differs by 0.04 rad.
    assert octave_heading == pytest.approx(python_heading, abs=2 * HEADING_TOLERANCE)


@needs_octave
def test_a_program_that_errors_shows_the_bridges_message_and_the_robot_stops(robot, bridge_port):
    robot.reset()
    done = robot.run(octave(bridge_port, "create_error(serPort)"))
    assert done.returncode == 1
    assert "ReadSonar: sonar_num must be 1 (right), 2 (front), 3 (left) or 4 (back), got 9" in done.stderr
    assert max(x for x, _y in robot.track()) > 0.05  # it drove before the error
    assert spin_until(robot.executor, robot.standing, timeout=5)


@needs_octave
@pytest.mark.parametrize("program", ["create_forever", "create_long_travel"])
def test_a_program_killed_mid_loop_or_mid_call_stops_the_robot_and_the_world_runs_on(robot, bridge_port, program):
    robot.reset()
    process = subprocess.Popen(octave(bridge_port, f"{program}(serPort)"), env=ENV, stderr=subprocess.DEVNULL)
    try:
        assert spin_until(robot.executor, robot.moving, timeout=30), "the program never drove"
    finally:
        process.kill()
        process.wait()
    assert spin_until(robot.executor, robot.standing, timeout=2), "the robot drove on after its program died"
    stamps = len(robot.odom.msgs)
    assert spin_until(robot.executor, lambda: len(robot.odom.msgs) > stamps + 10, timeout=5), "the world stopped"
    # The next program is served.
    again = robot.run(octave(bridge_port, "x = OverheadLocalizationCreate(serPort); printf('x=%.3f\\n', x)"))
    assert again.returncode == 0 and "x=" in again.stdout, again.stderr


@needs_octave
def test_every_toolbox_function_is_a_method_with_help_and_readings_come_in_the_toolboxs_shapes(robot, bridge_port):
    robot.reset()
    assert len(ORIGINAL_FUNCTIONS) == 37 and set(ORIGINAL_FUNCTIONS) - {"RoombaInit"} <= set(CALLS)
    names = " ".join(sorted(set(CALLS) | set(ORIGINAL_FUNCTIONS)))
    script = (
        f"addpath('{matlab_dir('create')}'); names = strsplit('{names}'); "
        "for k = 1:numel(names), h = evalc(['help CreateRobot.' names{k}]); "
        "if isempty(strfind(h, upper(names{k}))), printf('no help: %s\\n', names{k}); end, end; "
        "m = methods('CreateRobot'); missing = setdiff(names, m); printf('missing: %s\\n', strjoin(missing, ' ')); "
        "try, CreateRobot(1), catch e, printf('%s\\n', e.message), end; "
        f"s = CreateRobot({bridge_port}); "
        "[a, d, c] = CameraSensorCreate(s); printf('camera %d %d %.3f %.3f %.3f\\n', size(c), c(1), d, a); "
        "[X, Y, Z, R, N] = ReadBeacon(s); printf('beacon %d %d %d %.3f %.3f\\n', size(X), N, X, Z); "
        "l = LidarSensorCreate(s); printf('lidar %d %d %.1f\\n', size(l), max(l)); "
        "r = ReadSonarMultiple(s); printf('sonars %d %d\\n', size(r)); "
        "printf('nothing behind: %d %d\\n', isempty(ReadSonar(s, 4)), isempty(ReadSonarMultiple(s, 4))); "
        "o = cell(1, 23); [o{:}] = AllSensorsReadRoomba(s); printf('all %d\\n', sum(cellfun(@isscalar, o))); "
        # (the same connection: a second one would be refused while this one is open)
        "r = RoombaInit(s); OverheadLocalizationCreate(r); "
        "printf('RoombaInit gives serPort back: %d\\n', r.Port == s.Port);"
    )
    done = subprocess.run(octave_command(script), capture_output=True, text=True, timeout=60)
    assert done.returncode == 0, done.stderr
    assert "no help" not in done.stdout and "missing: \n" in done.stdout, done.stdout + done.stderr
    assert "cannot reach the robot_sims MATLAB bridge at 127.0.0.1:1" in done.stdout
    # The beacon 0.37 m ahead of the camera (0.13 m ahead of the centre) and 0.13 m to the left.
    distance, bearing = math.hypot(0.37, 0.13), math.atan2(0.13, 0.37)
    assert f"camera 1 3 1.000 {distance:.3f} {bearing:.3f}" in done.stdout
    # ReadBeacon's five columns: X right, Z ahead of the camera; the tag's number as a number
    assert f"beacon 1 1 7 {-distance * math.sin(bearing):.3f} {distance * math.cos(bearing):.3f}" in done.stdout
    assert "nothing behind: 1 1" in done.stdout  # [] out of range, as the original
    assert "lidar 1 681 4.0" in done.stdout  # a row; rays with nothing in range read the 4 m limit
    assert "sonars 1 4" in done.stdout and "all 23" in done.stdout
    assert "RoombaInit gives serPort back: 1" in done.stdout


def octave_eval(port: int, script: str, timeout: float = 120) -> str:
    """What octave-cli prints running ``script`` with ``s`` connected to the bridge."""
    done = subprocess.run(
        octave_command(f"addpath('{matlab_dir('create')}'); s = CreateRobot({port}); {script}"),
        capture_output=True,
        text=True,
        timeout=timeout,
    )
    assert done.returncode == 0, done.stdout + done.stderr
    return done.stdout


@needs_octave
def test_turn_angle_takes_the_short_way_round_as_the_original(robot, bridge_port):
    # (turnAngle waits on odometry: at three times real time it turns the same, sooner)
    robot.reset(real_time_factor=3.0)
    turns = [("turnAngle(s, 0.2, 270)", -90.0), ("TurnCreate(s, 0.2, -300)", 60.0), ("turnAngle(s, 0.2, 360)", 0.0)]
    heading = 0.0
    for call, turn in turns:
        octave_eval(bridge_port, call)
        heading += turn
        assert spin_until(robot.executor, robot.standing, timeout=10)
        robot.poses.clear()
        assert spin_until(robot.executor, lambda: bool(robot.poses.msgs), timeout=10)
        assert math.degrees(robot.heading()) == pytest.approx(heading, abs=3.0), call
        assert math.dist(robot.track()[-1], (0, 0)) < 0.01  # in place


@needs_octave
def test_the_realsense_functions_see_the_wall_and_the_tag_ahead_as_the_original_reports_them(robot, bridge_port):
    robot.reset()
    out = octave_eval(
        bridge_port,
        "d = RealSenseDist(s); printf('depth %d %d |', size(d)); printf(' %.3f', d(2:end)); printf('\\n'); "
        "printf('dt %d\\n', d(1) >= 0 && d(1) < 1); "
        "t = RealSenseTag(s); printf('tags %d %d | %g %.3f %.3f %g\\n', size(t), t(1, 2:5)); "
        "[X, Y, Z, R, N] = ReadBeacon(s); printf('beacon %g %.3f %g %.3f %g\\n', X, Y, Z, R, N);",
    )
    # The wall across the floor 0.6 m ahead, square to the robot: every ray's depth (along the
    # heading, from the centre) is 0.6 m, as the original's depth camera would report.
    assert "depth 10 1 | " + " ".join(["0.600"] * 9) in out and "dt 1" in out
    # The tag 0.37 m ahead of the camera and 0.13 m to its left: [dt id x y rot], x ahead, y left.
    assert "tags 1 5 | 7 0.370 0.130 0" in out
    assert "beacon -0.13 0.000 0.37 0.000 7" in out


@needs_octave
def test_a_recorded_programs_calls_land_in_datahistory_as_the_originals_saved_data_has_them(
    robot, bridge_port, tmp_path
):
    from scipy.io import loadmat

    robot.reset()
    bag = tmp_path / "run"
    log = (tmp_path / "record.log").open("w")
    recorder = subprocess.Popen(
        executable_command("record", [f"{NAMESPACE}/overhead_pose", f"{NAMESPACE}/matlab_calls", "-o", str(bag)]),
        env=ENV,
        cwd=ROOT,
        stdout=log,
        stderr=subprocess.STDOUT,
    )
    try:
        # Recording as a user would see it begin: the subscription in the graph and poses in sim
        # time in the bag (its chunks are written every 0.7 s), so the recorder's clock runs.
        recording = lambda: len(robot.node.get_subscriptions_info_by_topic(f"{NAMESPACE}/matlab_calls")) > 0  # noqa: E731
        assert spin_until(robot.executor, recording, timeout=60), "the recorder never subscribed"
        assert spin_until(robot.executor, lambda: poses_in(bag) > 0, timeout=60), (tmp_path / "record.log").read_text()
        octave_eval(
            bridge_port,
            "travelDist(s, 0.2, 0.1); [x, y, a] = OverheadLocalizationCreate(s); ReadSonar(s, 4); "
            "b = BumpsWheelDropsSensorsRoomba(s); pause(0.3);",
        )
        spin_until(robot.executor, lambda: False, timeout=1.0)  # the last poses in
    finally:
        recorder.send_signal(signal.SIGINT)
        recorder.wait(timeout=30)
        log.close()
    done = subprocess.run(
        executable_command("bag_to_mat", [str(bag), "-o", str(tmp_path / "run.mat")]),
        env=ENV,
        capture_output=True,
        text=True,
        timeout=120,
    )
    assert done.returncode == 0, done.stderr
    history = loadmat(tmp_path / "run.mat", simplify_cells=True)["datahistory"]
    calls = []
    for row in history:
        made = row[4]
        calls += [made] if isinstance(made, str) else [str(c) for c in np.atleast_1d(made)]
    assert calls[0] == "travelDist(0.200,0.100)"
    assert re.fullmatch(r"\[0\.1\d\d -?0\.0\d\d -?0\.0\d\d\]\]= OverheadLocalizationCreate", calls[1]), calls
    assert calls[2:] == ["[]= ReadSonar", "[0 0 0 0 0 0]= BumpsWheelDropsSensorsRoomba"]
    # each in the row of the pose recorded just before it: the travelDist's row is before the
    # robot moved, the pose's row where the robot is 0.1 m on
    rows = [i for i, row in enumerate(history) if np.size(row[4])]
    shown = f"rows {[(i, *history[i][:2]) for i in rows]}; the recorder said: {(tmp_path / 'record.log').read_text()}"
    assert history[rows[0]][1] < 0.02 and history[rows[1]][1] == pytest.approx(0.1, abs=0.02), shown


def poses_in(bag: Path) -> int:
    """The poses a running recorder has written to ``bag`` so far (0 before its first chunk)."""
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", BagWarning)  # an unfinished file: read what is intact
        try:
            return sum(1 for m in open_bag(bag).messages() if m.topic.endswith("/overhead_pose"))
        except InputError:
            return 0  # no .mcap file yet


def connect(port: int) -> tuple[socket.socket, str]:
    sock = socket.create_connection(("127.0.0.1", port), timeout=10)
    return sock, sock.makefile("r").readline().strip()


def ask(sock: socket.socket, line: str) -> str:
    sock.sendall(line.encode() + b"\n")
    reply = b""
    while not reply.endswith(b"\n"):
        reply += sock.recv(65536)
    return reply.decode().rstrip("\n")


def test_the_protocol_greets_answers_each_call_and_turns_mistakes_into_error_replies(robot, bridge_port):
    robot.reset()  # the world is up
    sock, hello = connect(bridge_port)
    with sock:
        assert hello == f"{HELLO} {PROTOCOL_VERSION} create {NAMESPACE}"
        assert ask(sock, "@1 BumpsWheelDropsSensorsRoomba") == "@1 ok\t0.0\t0.0\t0.0\t0.0\t0.0\t0.0"
        assert ask(sock, "@2 SetFwdVelAngVelCreate 0 0") == "@2 ok"
        assert ask(sock, "@3 ReadSonar 4") == "@3 ok\t[]"  # nothing behind: [], as the original
        # A version-1 line (no id) is answered without one.
        assert ask(sock, "ReadSonar 4") == "ok\t[]"
        assert (
            ask(sock, "PowerOnTheMoon") == "error PowerOnTheMoon is not a function of the Create toolbox on this bridge"
        )
        assert ask(sock, "travelDist 0.2") == (
            "error travelDist takes serPort and (roombaSpeed, distance), got 1 more argument(s)"
        )
        assert ask(sock, "turnAngle fast 90") == "error turnAngle: arguments must be numbers, got 'fast 90'"
        assert ask(sock, "SetDriveWheelsCreate NaN 0") == "error right_wheel_vel must be a finite number, got nan"
        # One program at a time: a second is refused with a clear line.
        second, refused = connect(bridge_port)
        second.close()
        assert (
            refused == f"busy another program is connected to the robot {NAMESPACE}: one program at a time per bridge"
        )
        sock.sendall(b"bye\n")
        assert sock.recv(10) == b""  # the bridge ended the session
    sock, hello = connect(bridge_port)  # and serves the next program
    sock.close()
    assert hello.startswith(HELLO)


def test_a_cancel_ends_a_blocking_call_with_the_robot_stopped_and_every_request_gets_its_one_reply(robot, bridge_port):
    robot.reset()
    sock, _hello = connect(bridge_port)
    with sock:
        sock.sendall(b"@1 travelDist 0.1 2\n")  # 20 s of driving
        assert spin_until(robot.executor, robot.moving, timeout=10), "travelDist never drove"
        sock.sendall(b"@1 cancel\n")  # what the m-file sends when Ctrl-C interrupts the call
        assert spin_until(robot.executor, robot.standing, timeout=5), "the robot drove on after the cancel"
        stopped_at = robot.track()[-1]
        reply = sock.makefile("r")
        assert reply.readline() == "@1 error travelDist: interrupted by the program; the robot stopped\n"
        # A new request during a blocking call interrupts it too; then it is answered, once.
        sock.sendall(b"@2 turnAngle 0.2 90\n")
        assert spin_until(robot.executor, lambda: abs(robot.odom.last.twist.twist.angular.z) > 0.1, timeout=10)
        sock.sendall(b"@3 OverheadLocalizationCreate\n")
        assert reply.readline().startswith("@2 error turnAngle: interrupted")
        x, y, _theta = (float(v) for v in reply.readline().removeprefix("@3 ok\t").split("\t"))
        assert math.dist((x, y), stopped_at) < 0.01  # turning in place since the stop
        sock.sendall(b"@3 cancel\n@4 ReadSonar 4\n")  # a cancel for a call answered: ignored, no reply
        assert reply.readline() == "@4 ok\t[]\n"
    assert spin_until(robot.executor, robot.standing, timeout=5)


def closed_unanswered(sock: socket.socket) -> bytes:
    """Everything the bridge sent before closing the connection (a reset is a close too)."""
    said = b""
    try:
        while chunk := sock.recv(65536):
            said += chunk
    except ConnectionResetError:
        pass
    return said


def test_a_keyed_bridge_closes_connections_without_its_key_unanswered_and_serves_the_one_with_it(robot, capfd):
    robot.reset()
    key = new_key()
    process, port = spawn_bridge(NAMESPACE, env=ENV, key=key)
    try:
        assert key not in Path(f"/proc/{process.pid}/cmdline").read_text()  # what ps shows every user
        # Another local user: no key, or a wrong one, then a command. Closed, nothing said.
        for first in ("", f"key {new_key()}\n", f"key {key[:-1]}\n", "key\n"):
            with socket.create_connection(("127.0.0.1", port), timeout=30) as sock:
                sock.sendall(f"{first}@1 SetFwdVelAngVelCreate 0.3 0\n".encode())
                assert closed_unanswered(sock) == b""
        # ... and the robot stood through a second of sim time after it.
        after = len(robot.odom.msgs)
        assert spin_until(robot.executor, lambda: len(robot.odom.msgs) >= after + 50, 30), "the world stopped"
        assert all(abs(m.twist.twist.linear.x) < 1e-9 for m in robot.odom.msgs), "a refused command drove it"
        # The program with the key (and its first request in the same packet) is served.
        with socket.create_connection(("127.0.0.1", port), timeout=30) as sock:
            sock.sendall(f"key {key}\n@1 SetFwdVelAngVelCreate 0.2 0\n".encode())
            lines = sock.makefile("r")
            assert lines.readline() == f"{HELLO} {PROTOCOL_VERSION} create {NAMESPACE}\n"
            assert lines.readline() == "@1 ok\n"
            assert spin_until(robot.executor, robot.moving, timeout=10), "the keyed program's command never drove"
            sock.sendall(b"bye\n")
            assert closed_unanswered(sock) == b""
        assert spin_until(robot.executor, robot.standing, timeout=10), "the robot drove on after its program"
    finally:
        process.send_signal(signal.SIGINT)
        process.wait(timeout=30)
    log = capfd.readouterr().err
    assert log.count(f"matlab_bridge: refused a connection to {NAMESPACE}: its first line was not this run's key") == 4
    assert "any local user's connection may drive the robot" not in log


def test_a_bridge_without_a_key_says_it_accepts_any_local_connection_and_ignores_a_key_line(robot, bridge_port):
    robot.reset()
    sock, hello = connect(bridge_port)  # (the module's bridge: started without a key)
    with sock:
        assert hello.startswith(HELLO)
        sock.sendall(f"key {new_key()}\n".encode())  # a toolbox given a key: no reply of its own
        assert ask(sock, "@1 ReadSonar 4") == "@1 ok\t[]"
    done = subprocess.run(
        executable_command("matlab_bridge", ["--port", "0", "--key-file", "/nonexistent/key"]),
        env=ENV,
        cwd=ROOT,
        capture_output=True,
        text=True,
        timeout=60,
    )
    assert done.returncode == 2
    assert "matlab_bridge: error: --key-file '/nonexistent/key': cannot read it" in done.stderr


@needs_octave
def test_an_octave_program_given_the_runs_key_drives_a_keyed_bridges_robot_and_one_without_is_refused(robot, tmp_path):
    robot.reset()
    key = new_key()
    key_file = tmp_path / "key"
    key_file.write_text(key + "\n")
    key_file.chmod(0o600)
    process = subprocess.Popen(
        executable_command("matlab_bridge", ["--namespace", NAMESPACE, "--port", "0", "--key-file", str(key_file)]),
        env={k: v for k, v in ENV.items() if k != KEY_ENV},
        cwd=ROOT,
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
        text=True,
    )
    try:
        assert process.stdout is not None
        listening = None  # Fast DDS may write its own errors (a stale shared-memory port) first
        while listening is None and (line := process.stdout.readline()):
            listening = LISTENING.search(line)
        assert listening, "the bridge did not start"
        port = int(listening[2])
        script = octave_command(
            f"addpath('{matlab_dir('create')}'); s = CreateRobot({port}); "
            "SetFwdVelAngVelCreate(s, 0.2, 0); pause(1); [x, y, t] = OverheadLocalizationCreate(s); "
            "printf('x=%g\\n', x); clear s"
        )
        keyed_env = dict(os.environ, **{KEY_ENV: key})
        keyed = subprocess.run(script, env=keyed_env, capture_output=True, text=True, timeout=120)
        assert keyed.returncode == 0, keyed.stdout + keyed.stderr
        assert float(keyed.stdout.split("x=")[1].split()[0]) > 0.05
        unkeyed = subprocess.run(script, env=os.environ, capture_output=True, text=True, timeout=120)
        assert unkeyed.returncode != 0
        assert "closed the connection: it may want its key (set ROBOT_SIMS_BRIDGE_KEY)" in unkeyed.stderr
    finally:
        process.send_signal(signal.SIGINT)
        _out, err = process.communicate(timeout=30)
    assert f"refused a connection to {NAMESPACE}" in err


def test_the_bridge_refuses_to_listen_beyond_loopback():
    with pytest.raises(InputError, match="loopback only"):
        MatlabBridge(host="0.0.0.0")
    done = subprocess.run(
        executable_command("matlab_bridge", ["--host", "0.0.0.0", "--port", "0"]),
        env=ENV,
        cwd=ROOT,
        capture_output=True,
        text=True,
        timeout=60,
    )
    assert done.returncode == 2
    assert "matlab_bridge: error: --host '0.0.0.0': the MATLAB bridge listens on loopback only" in done.stderr
    assert "Traceback" not in done.stderr


def test_matlab_path_prints_the_toolbox_folder():
    done = subprocess.run(
        executable_command("matlab_path"), env=ENV, cwd=ROOT, capture_output=True, text=True, timeout=60, check=True
    )
    assert Path(done.stdout.strip()) == ROOT / "matlab" / "create"
    assert (Path(done.stdout.strip()) / "CreateRobot.m").is_file()


def test_a_calls_subscriber_that_never_matches_costs_one_wait_and_a_program_line_ends_it(
    executor, make_node, monkeypatch
):
    import sim_tools.matlab.bridge as bridge_module

    monkeypatch.setattr(bridge_module, "FIRST_CALL_ACK", 0.5)
    topic = "/never_matched/matlab_calls"
    # the calls' writer is volatile: a transient-local reader is shown in the graph, never matched
    latched = QoSProfile(depth=1, durability=DurabilityPolicy.TRANSIENT_LOCAL)
    make_node("calls_listener").create_subscription(String, topic, lambda _msg: None, latched)
    bridge = MatlabBridge("/never_matched", port=0)
    try:
        assert spin_until(executor, lambda: bridge.node.count_subscribers(topic) == 1, timeout=60)
        looks: list[str] = []

        def line(sent: bool, label: str):
            return lambda: looks.append(label) or sent

        # Ctrl-C while the call waits for the subscriber: the wait ends at its first look
        bridge.publish_call("travelDist", [0.2, 0.1], [], interrupted=line(True, "interrupted"))
        assert looks == ["interrupted"]
        # no line: it waits its ceiling out once, looking for one all along ...
        bridge.publish_call("travelDist", [0.2, 0.1], [], interrupted=line(False, "waiting"))
        assert len(looks) > 2 and set(looks[1:]) == {"waiting"}
        # ... and never again for the same subscribers
        looks.clear()
        bridge.publish_call("travelDist", [0.2, 0.1], [], interrupted=line(False, "again"))
        assert looks == []
    finally:
        bridge.close()
