"""MATLAB/Octave programs that end badly, as users end them: Ctrl-C at the Octave prompt inside a
call, SIGINT/SIGTERM to ``octave --eval`` inside a blocking call, a world killed under a running
program, a bridge stopped twice.

Real processes throughout: create_world and ``robot_sims matlab_bridge`` in their own processes,
octave-cli as a user runs it (at an interactive prompt on a pseudo-terminal for Ctrl-C). The
ceilings are generous (a loaded machine); the figures the bridge is built for (a robot stopped
0.2 s after Ctrl-C, a dead world an error within 1 s) are measured by bench/matlab_roundtrip.py.
"""

from __future__ import annotations

import math
import os
import signal
import socket
import subprocess
import time
from pathlib import Path

import pytest
from geometry_msgs.msg import PoseStamped
from nav_msgs.msg import Odometry
from octave_support import OCTAVE, OctavePrompt, octave_eval
from std_srvs.srv import Trigger

from sim_runtime.msgs import yaw_from_quaternion
from sim_runtime.qos import SENSOR_SUBSCRIBER_QOS
from sim_runtime.testing import Collector, spin_until
from sim_tools.cli import executable_command
from sim_tools.matlab.bridge import HELLO, LISTENING, spawn_bridge
from sim_tools.matlab.paths import matlab_dir

ROOT = Path(__file__).resolve().parent.parent
PROGRAMS = ROOT / "test" / "matlab_programs"
NAMESPACE = "/matlab_ends"
pytestmark = pytest.mark.skipif(OCTAVE is None, reason="octave-cli not installed (CI installs it: .ci/run)")
ENV = dict(os.environ, PYTHONPATH=str(ROOT))
STOPS_WITHIN = 5.0  # s, wall: generous on a loaded machine (the bridge's goal is 0.2 s)
ERRORS_WITHIN = 5.0  # s, wall: likewise (the goal is 1 s)
MAP = "wall 0.6 -3 0.6 3\n"  # a wall across the floor 0.6 m ahead of the robot


def start_world(map_file: Path, namespace: str) -> subprocess.Popen:
    return subprocess.Popen(
        executable_command("create_world", ["--ros-args", "-p", f"map_file:={map_file}", "-r", f"__ns:={namespace}"]),
        env=ENV,
        cwd=ROOT,
        stderr=subprocess.DEVNULL,
    )


def end(process: subprocess.Popen) -> None:
    if process.poll() is None:
        process.send_signal(signal.SIGINT)
        try:
            process.wait(timeout=30)
        except subprocess.TimeoutExpired:
            process.kill()
            process.wait()


@pytest.fixture(scope="module")
def map_file(tmp_path_factory) -> Path:
    path = tmp_path_factory.mktemp("matlab_ends") / "wall.map"
    path.write_text(MAP)
    return path


@pytest.fixture(scope="module")
def world(map_file):
    process = start_world(map_file, NAMESPACE)
    yield process
    end(process)


@pytest.fixture(scope="module")
def bridge(world):
    process, port = spawn_bridge(NAMESPACE, env=ENV)
    yield port
    end(process)


class Robot:
    """The test's view of a robot: its ground-truth pose and odometry, and the world's reset."""

    def __init__(self, executor, node, namespace: str = NAMESPACE) -> None:
        self.executor, self.node, self.namespace = executor, node, namespace
        self.poses = Collector(node, PoseStamped, f"{namespace}/overhead_pose", SENSOR_SUBSCRIBER_QOS)
        self.odom = Collector(node, Odometry, f"{namespace}/odom", SENSOR_SUBSCRIBER_QOS)

    def reset(self) -> None:
        client = self.node.create_client(Trigger, f"{self.namespace}/reset")
        assert client.wait_for_service(timeout_sec=120), "no reset service: is create_world up?"
        future = client.call_async(Trigger.Request())
        assert spin_until(self.executor, future.done, timeout=30) and future.result().success
        self.odom.clear()
        assert spin_until(self.executor, self.standing, timeout=10)
        self.poses.clear()
        assert spin_until(self.executor, lambda: self.poses.last is not None, timeout=10)

    def moving(self) -> bool:
        twist = self.odom.last.twist.twist if self.odom.last is not None else None
        return twist is not None and (abs(twist.linear.x) > 0.01 or abs(twist.angular.z) > 0.01)

    def standing(self) -> bool:
        twist = self.odom.last.twist.twist if self.odom.last is not None else None
        return twist is not None and twist.linear.x == 0.0 and twist.angular.z == 0.0

    def settled(self, seconds: float = 0.5) -> None:
        """Standing, and still standing ``seconds`` later (not a pause between two motions)."""
        assert spin_until(self.executor, self.standing, timeout=STOPS_WITHIN), "the robot drove on"
        spin_until(self.executor, lambda: False, timeout=seconds)
        assert self.standing(), "the robot started again"

    def pose(self) -> tuple[float, float, float]:
        pose = self.poses.last.pose
        return pose.position.x, pose.position.y, yaw_from_quaternion(pose.orientation)


@pytest.fixture
def robot(world, executor, make_node):
    robot = Robot(executor, make_node("matlab_ends_probe"))
    robot.reset()
    return robot


# A program of the manual's structure Ctrl-C'd inside its travelDist; a turnAngle typed at the prompt.
@pytest.mark.parametrize("call", ["create_travel_loop(s)", "turnAngle(s, 0.1, 170)"])
def test_ctrl_c_inside_a_call_at_the_prompt_stops_the_robot_and_the_next_calls_get_their_own_answers(
    robot, bridge, call
):
    prompt = OctavePrompt(
        f"addpath('{matlab_dir('create')}', '{PROGRAMS}'); s = CreateRobot({bridge}); disp('READY')", ENV
    )
    try:
        prompt.type(call)
        assert spin_until(robot.executor, robot.moving, timeout=30), f"{call} never drove"
        spin_until(robot.executor, lambda: False, timeout=0.5)  # well inside the call
        prompt.ctrl_c()
        robot.settled()  # stopped, not at the end of the call (50 s or 30 s away)
        x, y, theta = robot.pose()
        assert (x > 0.02) if call.startswith("create") else (abs(theta) > 0.02)
        assert x < 0.3 and abs(theta) < math.radians(90)  # nowhere near the call's goal
        # The next calls are answered, each with its own outputs (not the interrupted call's,
        # nor the previous call's): the pose, then the four sonars, then the pose again.
        prompt.type(
            "[x, y, a] = OverheadLocalizationCreate(s); printf('POSE %.4f %.4f %.4f\\n', x, y, a); "
            "r = ReadSonarMultiple(s); printf('SONARS %d\\n', numel(r)); "
            "[x2, y2] = OverheadLocalizationCreate(s); printf('AGAIN %.4f %.4f\\n', x2, y2);"
        )
        pose = prompt.expect(r"^POSE (\S+) (\S+) (\S+)")
        assert float(pose[1]) == pytest.approx(x, abs=0.005) and float(pose[2]) == pytest.approx(y, abs=0.005)
        assert float(pose[3]) == pytest.approx(theta, abs=0.01)
        assert prompt.expect(r"^SONARS (\d+)")[1] == "4"
        again = prompt.expect(r"^AGAIN (\S+) (\S+)")
        assert float(again[1]) == pytest.approx(x, abs=0.005)
        # And a motion call still works from the same serPort, to its end.
        prompt.type("travelDist(s, 0.2, 0.05); disp('TRAVELLED')")
        prompt.expect(r"^TRAVELLED")
        # It went its 5 cm (how far past depends on how late a starved machine's stop arrives at
        # 0.2 m/s; travelDist's accuracy is test_matlab_bridge's square), straight ahead.
        robot.settled()
        ahead = (robot.pose()[0] - x) * math.cos(theta) + (robot.pose()[1] - y) * math.sin(theta)
        assert 0.045 < ahead < 0.2
    finally:
        prompt.close()
    robot.settled()


@pytest.mark.parametrize("signum", [signal.SIGINT, signal.SIGTERM], ids=["SIGINT", "SIGTERM"])
@pytest.mark.parametrize(
    "program",
    [
        "travelDist(serPort, 0.1, 5)",
        "turnAngle(serPort, 0.1, 170)",
        "SetFwdVelAngVelCreate(serPort, 0.1, 0); pause(60)",
    ],
    ids=["travelDist", "turnAngle", "pause"],
)
def test_a_signal_to_octave_inside_a_blocking_call_ends_it_and_stops_the_robot(robot, bridge, program, signum):
    script = f"addpath('{matlab_dir('create')}'); serPort = CreateRobot({bridge}); {program}"
    octave = octave_eval(script, ENV, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
    try:
        assert spin_until(robot.executor, robot.moving, timeout=30), "the program never drove"
        spin_until(robot.executor, lambda: False, timeout=0.5)
        octave.send_signal(signum)
        assert spin_until(robot.executor, lambda: octave.poll() is not None, timeout=STOPS_WITHIN), (
            "Octave went on with its call"
        )
        robot.settled()
    finally:
        if octave.poll() is None:
            octave.kill()
            octave.wait()
    x, _y, theta = robot.pose()
    assert x < 0.3 and abs(theta) < math.radians(90)  # stopped early, not at the call's end
    with socket.create_connection(("127.0.0.1", bridge), timeout=10) as sock:  # the next program is served
        assert sock.makefile("r").readline().startswith(HELLO)


def test_a_killed_world_makes_a_running_call_and_every_later_call_a_bridge_error(
    map_file, executor, make_node, tmp_path
):
    namespace = "/matlab_killed"
    world = start_world(map_file, namespace)
    bridge, port = spawn_bridge(namespace, env=ENV)
    robot = Robot(executor, make_node("matlab_killed_probe"), namespace)
    assert spin_until(executor, lambda: robot.odom.last is not None, timeout=120), "the world never started"
    program = tmp_path / "survive.m"
    program.write_text(
        "function survive(s)\n"
        "try, travelDist(s, 0.05, 5); disp('TRAVEL returned');\n"
        "catch e, printf('TRAVEL %s | %s\\n', e.identifier, e.message); end\n"
        "calls = {'SetFwdVelAngVelCreate(s, 0.1, 0)', 'OverheadLocalizationCreate(s)', 'ReadSonar(s, 2)', ...\n"
        "         'travelDist(s, 0.1, 1)'};\n"
        "for k = 1:numel(calls)\n"
        "  t = tic;\n"
        "  try, eval([calls{k} ';']); printf('CALL ok %s\\n', calls{k});\n"
        "  catch e, printf('CALL %s %.3f | %s\\n', e.identifier, toc(t), e.message); end\n"
        "end\n"
        "end\n"
    )
    script = f"addpath('{matlab_dir('create')}', '{tmp_path}'); s = CreateRobot({port}); survive(s)"
    octave = octave_eval(script, ENV, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    try:
        assert spin_until(executor, robot.moving, timeout=120), "travelDist never drove"
        world.kill()  # SIGKILL: no goodbye to anyone
        world.wait()
        killed = time.monotonic()
        out, err = octave.communicate(timeout=60)
        ended = time.monotonic()
    finally:
        end(octave)
        end(bridge)
        end(world)
    lines = out.splitlines()
    assert lines[0].startswith("TRAVEL CreateRobot:bridge | travelDist: the world of /matlab_killed stopped answering")
    assert "is create_world still running?" in lines[0]
    calls = [line for line in lines if line.startswith("CALL")]
    assert len(calls) == 4, out + err
    for line in calls:
        identifier, seconds = line.split()[1:3]
        assert identifier == "CreateRobot:bridge" and float(seconds) < ERRORS_WITHIN, line
    # the whole program, the interrupted travelDist and four calls, in a few seconds, not the 5 s
    # timeout of each call nor the 10 s and more DDS takes to notice the world's death
    assert ended - killed < 5 * ERRORS_WITHIN


@pytest.mark.parametrize("signals", [(signal.SIGINT, signal.SIGINT), (signal.SIGTERM, signal.SIGINT)], ids=str)
def test_the_bridge_ends_quietly_however_often_it_is_told_to_while_a_program_is_connected(robot, signals):
    bridge = subprocess.Popen(
        executable_command("matlab_bridge", ["--namespace", NAMESPACE, "--port", "0"]),
        env=ENV,
        cwd=ROOT,
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
        text=True,
    )
    try:
        assert bridge.stdout is not None
        listening = None  # Fast DDS may write its own errors (a stale shared-memory port) first
        while listening is None and (line := bridge.stdout.readline()):
            listening = LISTENING.search(line)
        assert listening, "the bridge did not start"
        with socket.create_connection(("127.0.0.1", int(listening[2])), timeout=10) as sock:
            reply = sock.makefile("r")
            assert reply.readline().startswith(HELLO)
            sock.sendall(b"@1 SetFwdVelAngVelCreate 0.1 0\n")
            assert reply.readline() == "@1 ok\n"
            assert spin_until(robot.executor, robot.moving, timeout=30)
            for signum in signals:
                bridge.send_signal(signum)
                time.sleep(0.05)  # the second while the first is stopping the robot
            _out, err = bridge.communicate(timeout=30)
    finally:
        if bridge.poll() is None:
            bridge.kill()
            bridge.communicate()
    robot.settled()
    assert bridge.returncode == 0 and "Traceback" not in err and "Error" not in err, err


def test_a_call_before_any_world_answers_is_an_error_and_the_session_goes_on():
    bridge, port = spawn_bridge("/matlab_nobody", env=ENV)
    try:
        with socket.create_connection(("127.0.0.1", port), timeout=60) as sock:
            reply = sock.makefile("r")
            assert reply.readline().startswith(HELLO)
            sock.sendall(b"@1 OverheadLocalizationCreate\n")
            assert reply.readline() == (
                "@1 error waiting for overhead_pose: no message from the robot for 5.0 s "
                "(is create_world running in namespace '/matlab_nobody'?)\n"
            )
            sock.sendall(b"@2 DemoCmdsCreate 3\n")  # the same connection: still served
            assert reply.readline() == "@2 ok\n"
    finally:
        end(bridge)
