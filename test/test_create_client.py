"""The toolbox-style client against an in-process create_world."""

from __future__ import annotations

import math
import os
import signal
import subprocess
import sys
import threading
from pathlib import Path

import pytest
from nav_msgs.msg import Odometry
from rclpy.parameter import Parameter
from std_srvs.srv import SetBool, Trigger
from test_create_node import Rig, make_world

from create_sim.client import AllSensors, CreateRobot
from create_sim.world_node import CreateWorldNode
from sim_runtime.msgs import time_from_msg
from sim_runtime.paths import config_path
from sim_runtime.qos import SENSOR_SUBSCRIBER_QOS
from sim_runtime.testing import Collector, spin_until, wait_for_match
from sim_tools.cli import executable_command

ROOT = Path(__file__).resolve().parent.parent


def hosted_robot(rig: Rig, **kwargs) -> CreateRobot:
    """A client on the probe node; while it blocks, the world steps, after it has received every
    command sent and with each odometry message handled before the next step (deterministic
    however loaded the machine is)."""
    odom = Collector(rig.probe, Odometry, "odom", SENSOR_SUBSCRIBER_QOS)

    def spin() -> None:
        spin_until(rig.executor, lambda: rig.world.commands_received >= robot.commands_sent)
        rig.step()
        if rig.world.step_count % 2 == 0:  # odom is published at 50 Hz, every other step
            now = rig.world.sim_time
            spin_until(rig.executor, lambda: odom.last and time_from_msg(odom.last.header.stamp) >= now - 1e-9)

    robot = CreateRobot(node=rig.probe, spin=spin, **kwargs)
    for subscription in rig.probe.subscriptions:
        assert wait_for_match(rig.executor, subscription)
    return robot


@pytest.fixture(scope="module", autouse=True)
def compiled_kernels(ros):
    """Compile (or load from cache) every numba kernel of the world before any test runs: the
    client's timeouts are wall-clock, and a first compile on a cold cache can take longer."""
    world = make_world(
        {
            "map_file": str(config_path("create/example.map")),
            "real_time_factor": 0.0,
            "config_file": str(config_path("create/example_config.txt")),
        }
    )
    world.model.set_velocity(0.2, 0.5)
    world.step(20)
    model = world.model
    model.bumps(), model.cliff_signals(), model.wall_sensor(), model.virtual_wall()
    model.sonar(), model.lidar(), model.camera()
    world.destroy_node()


@pytest.fixture
def rig(executor, make_node, tmp_path):
    return Rig(executor, make_node, tmp_path)


@pytest.fixture
def robot(rig):
    return hosted_robot(rig)


def test_travel_dist_drives_the_distance_and_stops(rig, robot):
    travelled = robot.travel_dist(0.2, 0.5)
    assert travelled == pytest.approx(0.5, abs=0.01)
    x, y, _theta = robot.overhead_localization()
    assert x == pytest.approx(0.5, abs=0.015) and y == pytest.approx(0.0, abs=1e-9)
    robot.pause(0.1)  # the stop command is on its way to the world
    assert rig.world.model.command == (0.0, 0.0)
    assert rig.world.model.pose[0] == pytest.approx(x, abs=0.01)
    assert robot.travel_dist(-0.3, -0.25) == pytest.approx(-0.25, abs=0.01)  # backwards
    assert rig.world.model.pose[0] == pytest.approx(0.25, abs=0.02)


def test_travel_dist_speed_limits(rig, robot):
    robot.travel_dist(5.0, 0.1)  # capped at 0.5 m/s (the original's limit), still stops at 0.1 m
    assert rig.world.model.pose[0] == pytest.approx(0.1, abs=0.015)
    robot.pause(0.1)
    start = rig.world.sim_time
    robot.travel_dist(-0.001, 0.02)  # a negative tiny speed is raised to 0.025 m/s (seed bug 11)
    assert rig.world.sim_time - start == pytest.approx(0.02 / 0.025, abs=0.1)


def test_travel_dist_into_a_wall_gives_up_after_the_timeout(rig, robot):
    travelled = robot.travel_dist(0.5, 3.0, timeout=5.0)  # the wall is 1.84 m ahead
    assert travelled == pytest.approx(1.84, abs=0.02)
    assert robot.sim_time == pytest.approx(5.0, abs=0.05)


def test_turn_angle_turns_the_angle(rig, robot):
    assert robot.turn_angle(0.2, 90) == pytest.approx(90, abs=1.0)
    assert math.degrees(robot.overhead_localization()[2]) == pytest.approx(90, abs=1.0)
    robot.turn_angle(0.2, -45)
    assert math.degrees(rig.world.model.pose[2]) == pytest.approx(45, abs=1.5)
    assert rig.world.model.pose[0] == pytest.approx(0.0, abs=1e-9)  # in place


def test_turn_angle_360_is_a_full_turn_not_nothing(executor, make_node, tmp_path):
    # 31 s of sim time: only odometry is needed, so the other sensors stay quiet.
    quiet = {f"rate.{name}": 0.0 for name in ("scan", "camera", "sonar", "cliff", "wall", "virtual_wall", "bump")}
    rig = Rig(executor, make_node, tmp_path, **quiet)
    robot = hosted_robot(rig)
    assert robot.turn_angle(0.2, 360) == pytest.approx(360, abs=1.0)
    assert rig.world.sim_time >= 2 * math.pi / 0.2 - 0.1


def test_sonar_readings_use_the_toolbox_numbering(executor, make_node, tmp_path):
    rig = Rig(executor, make_node, tmp_path, initial_pose=[-1.0, -1.0, math.pi / 2])
    robot = hosted_robot(rig)
    assert robot.read_sonar() == pytest.approx(2.84)  # default: front
    assert robot.read_sonar(3) == pytest.approx(0.84)  # left
    assert robot.read_sonar_multiple() == pytest.approx([2.84, 2.84, 0.84, 0.84])  # right front left back
    assert robot.read_sonar_multiple(4, 1) == pytest.approx([0.84, 2.84])
    with pytest.raises(ValueError, match="sonar_num"):
        robot.read_sonar(5)


def test_no_sonar_return_is_none(executor, make_node, tmp_path):
    rig = Rig(executor, make_node, tmp_path, map_text="wall 0 1 1 1\n")
    robot = hosted_robot(rig)
    assert robot.read_sonar(2) is None
    assert robot.read_sonar(3) == pytest.approx(0.84)


def test_bumps_lidar_camera_and_odometry_counters(rig, robot):
    assert robot.bumps_wheel_drops() == (False, False, False, False, False, False)
    assert robot.lidar().shape == (681,)
    assert robot.lidar()[340] == pytest.approx(1.84, abs=1e-4)
    angles, distances, colours = robot.camera()
    assert distances == pytest.approx([1.37]) and angles == pytest.approx([0.0], abs=1e-9)
    assert colours.tolist() == [[1.0, 0.0, 0.0]]
    assert robot.beacons()[0][0] == "Red1"
    assert robot.read_beacon()[0][1:4] == pytest.approx((0.0, 0.0, 1.37), abs=1e-9)
    robot.distance_sensor(), robot.angle_sensor()
    robot.set_fwd_vel_ang_vel(0.5, 0.0)
    robot.pause(5.0)  # into the wall at x = 2
    assert robot.bumps_wheel_drops() == (False, False, False, False, False, True)  # front = both pressed
    assert robot.distance_sensor() == pytest.approx(1.84, abs=0.02)
    assert robot.distance_sensor() == pytest.approx(0.0)  # since the last call
    robot.set_fwd_vel_ang_vel(0.0, 0.0)
    robot.turn_angle(0.2, 30)
    assert robot.angle_sensor() == pytest.approx(math.radians(30), abs=0.02)
    assert robot.wall_sensor() is True  # turned left at the wall: it is now on the IR sensor's right
    assert robot.virtual_wall_sensor() is False
    assert robot.cliff_front_left_signal_strength() == pytest.approx(21.5)
    assert robot.cliff_left_sensor() is False


def test_buttons_battery_and_all_sensors(rig, robot):
    rig.call(SetBool, "press_advance", SetBool.Request(data=True))
    robot.pause(0.2)
    assert robot.buttons() == (True, False)  # (advance, play) as ButtonsSensorRoomba
    assert robot.battery_charge() == pytest.approx((3000.0, 3000.0, 100.0))
    assert robot.battery_voltage() == pytest.approx(17.2)
    assert robot.current_tester() == pytest.approx(-3.0)
    everything = robot.all_sensors_read()
    assert isinstance(everything, AllSensors) and len(everything) == 23
    assert everything.button_advance and not everything.button_play
    assert everything.voltage == pytest.approx(17.2) and everything.temperature == pytest.approx(25.0)


def test_velocity_commands(rig, robot):
    assert robot.set_drive_wheels(0.8, 0.1) == pytest.approx((0.3, 0.4 / 0.258))  # right clamped to 0.5
    assert robot.set_fwd_vel_ang_vel(0.0, 10.0) == pytest.approx((0.0, 1.0 / 0.258))  # per-wheel limit
    assert robot.set_fwd_vel_radius(0.2, 0.5) == pytest.approx((0.2, 0.4))
    assert robot.set_fwd_vel_radius(0.2, math.inf) == pytest.approx((0.2, 0.0))
    assert robot.set_fwd_vel_radius(0.2, 10.0) == pytest.approx((0.2, 0.1))  # radius capped at 2 m
    robot.set_fwd_vel_ang_vel(0.1, 0.5)
    robot.pause(0.1)
    assert rig.world.model.command == pytest.approx((0.1, 0.5))
    with pytest.raises(ValueError, match="fwd_vel"):
        robot.set_fwd_vel_ang_vel(math.nan, 0.0)
    with pytest.raises(ValueError, match="led"):
        robot.set_leds(4, 0, 50)


def test_reading_without_a_robot_times_out_clearly(executor, make_node):
    node = make_node("lonely", namespace="nobody")
    robot = CreateRobot(node=node, spin=lambda: executor.spin_once(timeout_sec=0.05), timeout=0.3)
    with pytest.raises(TimeoutError, match="nobody"):
        robot.overhead_localization()


def test_standalone_client_with_its_own_spinner_thread(executor):
    # The world runs paced at twice real time in its own thread, as another process would.
    world = CreateWorldNode(
        namespace="solo",
        parameter_overrides=[Parameter("map_file", value=""), Parameter("real_time_factor", value=2.0)],
    )
    executor.add_node(world)
    world.start_pacing()
    stop = threading.Event()

    def run_world():
        while not stop.is_set():
            executor.spin_once(timeout_sec=0.05)

    robot = CreateRobot(namespace="solo")
    thread = threading.Thread(target=run_world, daemon=True)
    thread.start()
    try:
        assert robot.travel_dist(0.2, 0.3) == pytest.approx(0.3, abs=0.03)
        assert world.model.pose[0] == pytest.approx(0.3, abs=0.05)
    finally:
        robot.close()
        stop.set()
        thread.join()


def test_first_command_of_a_fresh_client_reaches_a_world_in_another_process(tmp_path):
    """The typical ported MATLAB opening: connect, command at once, wait. The command must not be
    lost while the client and the world are still discovering each other."""
    import os
    import signal
    import subprocess
    from pathlib import Path

    root = Path(__file__).resolve().parent.parent
    world = subprocess.Popen(
        executable_command("create_world", ["--ros-args", "-p", "map_file:=''", "-r", "__ns:=/fresh"]),
        env=dict(os.environ, PYTHONPATH=str(root)),
        cwd=root,
        stderr=subprocess.PIPE,
        text=True,
    )
    robot = CreateRobot(namespace="fresh", timeout=30.0)
    try:
        assert robot.set_fwd_vel_ang_vel(0.3, 0.0) == (0.3, 0.0)
        robot.pause(1.0)
        x, y, _ = robot.overhead_localization()
        # The command arrived: the robot drove straight for at least the second paused. How much
        # longer depends on how soon this process read the pose (one full-suite run read it
        # 0.76 s late, x = 0.528), not on the command.
        assert x >= 0.3 - 0.05 and y == pytest.approx(0.0, abs=1e-6)
    finally:
        robot.close()
        world.send_signal(signal.SIGINT)
        world.communicate(timeout=30)


def test_odometry_counters_ignore_the_jump_of_a_world_reset(rig, robot):
    robot.turn_angle(0.2, 60)
    robot.travel_dist(0.3, 0.2)
    assert rig.call(Trigger, "reset", Trigger.Request()).success
    robot.pause(0.2)
    assert robot.angle_sensor() == pytest.approx(math.radians(60), abs=0.02)
    assert robot.distance_sensor() == pytest.approx(0.2, abs=0.01)


# ------------------------------------------------------------ how a student's program ends
STUDENT_START = """
from create_sim.client import CreateRobot
robot = CreateRobot(namespace="ending", timeout=60)
robot.set_fwd_vel_ang_vel(0.2, 0.0)
robot.pause(0.2)
"""
DRIVE_ON = "while True:\n    robot.pause(0.1)\n"
ENDINGS = {
    # name: (program, signal sent once the robot drives, exit status, what stderr shows)
    "normal_end_without_close": (STUDENT_START, None, 0, None),
    "exception": (STUDENT_START + "raise RuntimeError('a bug in the program')\n", None, 1, "RuntimeError: a bug"),
    "ctrl_c": (STUDENT_START + DRIVE_ON, signal.SIGINT, -signal.SIGINT, "KeyboardInterrupt"),
    "sigterm": (STUDENT_START + DRIVE_ON, signal.SIGTERM, -signal.SIGTERM, None),
    "with_block": (
        "from create_sim.client import CreateRobot\n"
        "with CreateRobot(namespace='ending', timeout=60) as robot:\n"
        "    robot.set_fwd_vel_ang_vel(0.2, 0.0)\n"
        "    robot.pause(0.2)\n",
        None,
        0,
        None,
    ),
    "exception_in_a_with_block": (
        "from create_sim.client import CreateRobot\n"
        "with CreateRobot(namespace='ending', timeout=60) as robot:\n"
        "    robot.set_fwd_vel_ang_vel(0.2, 0.0)\n"
        "    robot.pause(0.2)\n"
        "    raise ValueError('inside the with block')\n",
        None,
        1,
        "ValueError: inside the with block",
    ),
}


@pytest.fixture(scope="module")
def world_process():
    """A create_world in another process (namespace /ending, free space, real time) that holds the
    last command forever, as by default: a robot left driving keeps driving."""
    world = subprocess.Popen(
        executable_command("create_world", ["--ros-args", "-p", "map_file:=''", "-r", "__ns:=/ending"]),
        env=dict(os.environ, PYTHONPATH=str(ROOT)),
        cwd=ROOT,
        stderr=subprocess.PIPE,
        text=True,
    )
    yield world
    world.send_signal(signal.SIGINT)
    world.communicate(timeout=30)


@pytest.mark.parametrize("ending", ENDINGS)
def test_however_a_program_ends_the_robot_stops_and_python_exits_as_usual(ending, world_process, executor, make_node):
    program, stop_signal, status, shown = ENDINGS[ending]
    odom = Collector(make_node("ending_probe"), Odometry, "/ending/odom", SENSOR_SUBSCRIBER_QOS)
    # The world is up (its first start may compile its kernels) and the robot stands still.
    assert spin_until(executor, lambda: odom.last is not None, timeout=120), "no odometry from create_world"
    assert spin_until(executor, lambda: odom.last.twist.twist.linear.x == 0.0, timeout=10)
    student = subprocess.Popen(
        [sys.executable, "-c", program],
        env=dict(os.environ, PYTHONPATH=str(ROOT)),
        cwd=ROOT,
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
        text=True,
    )
    try:
        moving = lambda: [m for m in odom.msgs if m.twist.twist.linear.x == pytest.approx(0.2)]  # noqa: E731
        assert spin_until(executor, lambda: moving() or student.poll() is not None, timeout=60)
        assert moving(), f"the program never drove the robot: {student.communicate()[1]}"
        if stop_signal is not None:
            student.send_signal(stop_signal)
        _out, err = student.communicate(timeout=60)
    finally:
        if student.poll() is None:
            student.kill()
            student.communicate()
    assert student.returncode == status, err
    assert "terminate called" not in err, err
    if shown is None:
        assert "Traceback" not in err, err
    else:
        assert "Traceback" in err and shown in err, err
    # After the program ended, the world reports the robot standing: every odometry message
    # newer than the last moving one, half a second of them, has zero velocity.
    last_moving = time_from_msg(moving()[-1].header.stamp)
    after = lambda: [m for m in odom.msgs if time_from_msg(m.header.stamp) > last_moving]  # noqa: E731
    assert spin_until(executor, lambda: len(after()) >= 25, timeout=60), "the world stopped publishing"
    assert all(m.twist.twist.linear.x == 0.0 and m.twist.twist.angular.z == 0.0 for m in after())
