"""Toolbox-style client: port a MATLAB Create control program line by line.

Each method is the snake_case twin of a function of the MATLAB Toolbox for the iRobot Create
(``SetFwdVelAngVelCreate(serPort, v, w)`` → ``robot.set_fwd_vel_ang_vel(v, w)``), talking to any
robot that speaks the ``create_world`` topics::

    from create_sim.client import CreateRobot

    with CreateRobot() as robot:                # RoombaInit: a node + background spinner
        robot.travel_dist(0.2, 0.5)             # drive 0.5 m forward at 0.2 m/s, blocking
        robot.turn_angle(0.2, 90)               # turn 90° counter-clockwise, blocking
        bump_right, bump_left, *_, bump_front = robot.bumps_wheel_drops()
        print(robot.read_sonar(2), robot.overhead_localization())

However the program ends (the end of the ``with`` block or of the program, an exception,
Ctrl-C, SIGTERM), the robot is sent zero velocity and the client's node and thread are shut
down, so the process exits as Python does (status, traceback) and the robot does not drive on.

Readings are the latest message on each topic (the first call waits for one). Time is the
robot's sim time, taken from message stamps, so blocking calls behave the same at any
``real_time_factor``.

Differences from the toolbox, all on purpose: no-return sonar/LIDAR values are ``None``/``inf``
(REP-117) instead of the range limit; ``turn_angle`` turns the angle asked for (the toolbox
wrapped 360° to 0 and did nothing); a negative ``speed`` is treated as its magnitude and raised
to the minimum; cliff booleans are ``False`` (there are no cliffs) and ``all_sensors_read``
reports them as booleans, not signal strengths; ``read_sonar()`` without an argument reads the
front sonar, as the toolbox documented.
"""

from __future__ import annotations

import atexit
import math
import os
import signal
import threading
import time
import warnings
import weakref
from collections.abc import Callable
from functools import partial
from typing import Any, NamedTuple

import numpy as np
import rclpy
from geometry_msgs.msg import PoseStamped, Twist, TwistStamped
from nav_msgs.msg import Odometry
from rclpy.executors import SingleThreadedExecutor
from rclpy.node import Node
from rclpy.signals import SignalHandlerOptions
from sensor_msgs.msg import BatteryState, Illuminance, Joy, LaserScan, Range
from visualization_msgs.msg import MarkerArray

from create_sim import spec
from sim_runtime.angles import wrap_angle
from sim_runtime.msgs import time_from_msg, time_msg, yaw_from_quaternion
from sim_runtime.qos import COMMAND_PUBLISHER_QOS, SENSOR_SUBSCRIBER_QOS

# The robot's limits, kept under the names programs and docs use.
MAX_WHEEL_SPEED = spec.MAX_WHEEL_SPEED_MPS  # m/s
WHEEL_BASE = spec.WHEEL_BASE_M  # m
MAX_TURN_RATE = spec.MAX_TURN_RATE_RADPS  # rad/s, wheels at full speed in opposite directions
TRAVEL_SPEED_RANGE = (0.025, 0.5)  # m/s, travelDist
TURN_SPEED_RANGE = (0.025, 0.2)  # rad/s, turnAngle
RADIUS_RANGE = (0.001, 2.0)  # m, SetFwdVelRadiusRoomba
SONAR_NUMBERS = {1: "right", 2: "front", 3: "left", 4: "back"}  # the toolbox's ReadSonar numbering
CLIFF_NAMES = spec.CLIFF_NAMES
STOP_CONFIRM_TIMEOUT = 1.0  # s, wall: how long closing waits for the robot to report it has stopped

# Standalone clients still open, stopped by SIGTERM before the process dies of it.
_clients: weakref.WeakSet[CreateRobot] = weakref.WeakSet()


def _stop_on_sigterm() -> None:
    """On SIGTERM, stop every open client, then die of SIGTERM as Python does by default.

    Only when nobody else handles SIGTERM: a program with its own handler keeps it (and ends
    through it, when atexit stops the robot).
    """
    if threading.current_thread() is not threading.main_thread():
        return  # signal handlers can only be set from the main thread
    if signal.getsignal(signal.SIGTERM) is not signal.SIG_DFL:
        return

    def stop_then_die(signum: int, _frame: object) -> None:
        for client in list(_clients):
            client.close()
        signal.signal(signum, signal.SIG_DFL)
        os.kill(os.getpid(), signum)

    signal.signal(signal.SIGTERM, stop_then_die)


class AllSensors(NamedTuple):
    """``AllSensorsReadRoomba``'s 23 outputs, in its order."""

    bump_right: bool
    bump_left: bool
    bump_front: bool
    wall: bool
    virt_wall: bool
    cliff_left: bool
    cliff_right: bool
    cliff_front_left: bool
    cliff_front_right: bool
    left_current_over: bool
    right_current_over: bool
    dirt_left: bool
    dirt_right: bool
    button_play: bool
    button_advance: bool
    distance: float
    angle: float
    voltage: float
    current: float
    temperature: float
    charge: float
    capacity: float
    percent_charge: float


def _clamp(value: float, low: float, high: float) -> float:
    return min(max(value, low), high)


def _check_finite(**values: float) -> None:
    for name, value in values.items():
        if not math.isfinite(value):
            raise ValueError(f"{name} must be a finite number, got {value!r}")


class CreateRobot:
    """A Create behind the ``create_world`` topics, with the MATLAB toolbox's functions.

    Standalone (``CreateRobot(namespace="/robot1")``): owns a node and spins it in a background
    thread; call :meth:`close` (or use ``with``) at the end.

    Hosted (``CreateRobot(node=my_node, spin=...)``): subscribes with your node and, while a call
    blocks, calls ``spin()`` repeatedly to make progress (default
    ``rclpy.spin_once(node, timeout_sec=0.05)``). Tests pass a ``spin`` that steps an in-process
    world and spins their executor.

    ``timeout`` (wall seconds) bounds how long a call waits without any new message from the
    robot before raising :class:`TimeoutError`. ``confirm_first_command`` (wall seconds, 0 = no):
    the first velocity command is sent again until the robot's odometry shows it, at most this
    long; by default standalone clients do for ``STOP_CONFIRM_TIMEOUT`` (1 s), hosted ones not.
    """

    def __init__(
        self,
        namespace: str = "",
        *,
        node: Node | None = None,
        spin: Callable[[], None] | None = None,
        stamped: bool = False,
        timeout: float = 5.0,
        confirm_first_command: float | None = None,
    ) -> None:
        self.timeout = timeout
        self._cond = threading.Condition()
        self._latest: dict[str, Any] = {}  # topic -> newest message
        self._updates = 0  # messages received, to tell progress from a dead robot
        self._sim_time = 0.0
        self._odom_prev: tuple[float, float, float, float] | None = None  # t, x, y, yaw
        self._travelled = 0.0  # signed odometry distance since start, never reset
        self._turned = 0.0  # odometry heading change since start, never reset
        self._distance_mark = 0.0  # _travelled at the last distance_sensor() call
        self._angle_mark = 0.0
        self._thread: threading.Thread | None = None
        self._executor: SingleThreadedExecutor | None = None
        self._closed = False
        self._odom_count = 0  # odometry messages received
        self._heard = False  # the robot has shown a command of ours in its odometry
        self._owns_rclpy = False
        if node is None:
            if not rclpy.ok():
                # Without rclpy's signal handlers: they shut the context down on Ctrl-C/SIGTERM,
                # after which the robot could not be told to stop.
                rclpy.init(signal_handler_options=SignalHandlerOptions.NO)
                self._owns_rclpy = True
            node = Node("create_client", namespace=namespace)
            self._executor = SingleThreadedExecutor()
            self._executor.add_node(node)
            self._thread = threading.Thread(target=self._spin_thread, daemon=True, name="create_client")
            self._owned_node = True
        else:
            self._owned_node = False
        self.node = node
        self._spin = spin or (lambda: rclpy.spin_once(node, timeout_sec=0.05))  # hosted mode only
        # Hosted clients whose spin steps an in-process world (tests) leave the first command
        # unconfirmed, so that it costs no extra steps; a hosted one over a separate world (the
        # MATLAB bridge) asks for it.
        default_confirm = STOP_CONFIRM_TIMEOUT if self._thread is not None else 0.0
        self._confirm_first = default_confirm if confirm_first_command is None else confirm_first_command
        self._stamped = stamped
        self.commands_sent = 0  # velocity commands published
        self._cmd_pub = node.create_publisher(
            TwistStamped if stamped else Twist, spec.CMD_VEL_TOPIC, COMMAND_PUBLISHER_QOS
        )
        self._subscribe()
        if self._thread:
            self._thread.start()
            # However the program ends, the robot stops and the spinner thread ends before the
            # interpreter does (a thread still inside rclpy at exit aborts the process).
            atexit.register(self.close)
            _stop_on_sigterm()
            _clients.add(self)

    def _subscribe(self) -> None:
        topics: list[tuple[type, str]] = [
            *((Range, spec.bump_topic(side)) for side in spec.BUMP_SIDES),
            (Range, spec.WALL_TOPIC),
            (Range, spec.VIRTUAL_WALL_TOPIC),
            *((Illuminance, spec.cliff_topic(n)) for n in CLIFF_NAMES),
            *((Range, spec.sonar_topic(n)) for n in SONAR_NUMBERS.values()),
            (LaserScan, spec.SCAN_TOPIC),
            (MarkerArray, spec.CAMERA_BEACONS_TOPIC),
            (PoseStamped, spec.OVERHEAD_POSE_TOPIC),
            (Joy, spec.BUTTONS_TOPIC),
            (BatteryState, spec.BATTERY_TOPIC),
        ]
        for msg_type, topic in topics:
            self.node.create_subscription(msg_type, topic, partial(self._store, topic), SENSOR_SUBSCRIBER_QOS)
        self.node.create_subscription(Odometry, spec.ODOM_TOPIC, self._on_odom, SENSOR_SUBSCRIBER_QOS)

    # ------------------------------------------------------------ plumbing
    def _store(self, topic: str, msg: Any) -> None:
        with self._cond:
            self._latest[topic] = msg
            self._updates += 1
            if topic == spec.ODOM_TOPIC:
                self._odom_count += 1
            if hasattr(msg, "header"):
                self._sim_time = max(self._sim_time, time_from_msg(msg.header.stamp))
            self._cond.notify_all()

    def _on_odom(self, msg: Odometry) -> None:
        t = time_from_msg(msg.header.stamp)
        p = msg.pose.pose.position
        yaw = yaw_from_quaternion(msg.pose.pose.orientation)
        with self._cond:
            if self._odom_prev is not None:
                t0, x0, y0, yaw0 = self._odom_prev
                turn = wrap_angle(yaw - yaw0)
                mid = yaw0 + turn / 2
                step = (p.x - x0) * math.cos(mid) + (p.y - y0) * math.sin(mid)
                # A jump no wheel could make is a reset of the robot's odometry, not motion.
                dt = max(t - t0, 0.0)
                if abs(step) <= 2 * MAX_WHEEL_SPEED * dt + 0.01 and abs(turn) <= 2 * MAX_TURN_RATE * dt + 0.05:
                    self._travelled += step
                    self._turned += turn
            self._odom_prev = (t, p.x, p.y, yaw)
        self._store(spec.ODOM_TOPIC, msg)

    def _wait_until(self, done: Callable[[], bool], what: str) -> None:
        with self._cond:
            deadline, seen = time.monotonic() + self.timeout, self._updates
            while not done():
                if self._thread:
                    self._cond.wait(0.05)
                else:
                    self._cond.release()
                    try:
                        self._spin()
                    finally:
                        self._cond.acquire()
                if self._updates != seen:
                    deadline, seen = time.monotonic() + self.timeout, self._updates
                elif time.monotonic() > deadline:
                    raise TimeoutError(
                        f"{what}: no message from the robot for {self.timeout} s "
                        f"(is create_world running in namespace {self.node.get_namespace()!r}?)"
                    )

    def _msg(self, topic: str) -> Any:
        self._wait_until(lambda: topic in self._latest, f"waiting for {topic}")
        return self._latest[topic]

    @property
    def sim_time(self) -> float:
        """The robot's clock (s): the newest stamp received."""
        return self._sim_time

    def reading_age(self, topic: str) -> float:
        """How long ago (s of sim time, ≥ 0) the newest message on ``topic`` was measured, by its stamp
        (the first marker's for a MarkerArray; 0 for one without a stamp)."""
        msg = self._msg(topic)
        header = getattr(msg, "header", None) or next((m.header for m in getattr(msg, "markers", [])), None)
        return 0.0 if header is None else max(self._sim_time - time_from_msg(header.stamp), 0.0)

    def pause(self, seconds: float) -> None:
        """Wait ``seconds`` of the robot's sim time (MATLAB ``pause`` for control loops)."""
        _check_finite(seconds=seconds)
        self._msg(spec.ODOM_TOPIC)
        end = self._sim_time + seconds
        self._wait_until(lambda: self._sim_time >= end - 1e-9, "pause")

    def close(self) -> None:
        """Stop the robot and release the node, its spinner thread and rclpy (standalone mode).

        Safe to call more than once. Also runs by itself when the program ends (normally, by an
        exception, Ctrl-C or SIGTERM) and at the end of a ``with`` block.
        """
        if self._closed:
            return
        self._closed = True
        _clients.discard(self)
        try:
            self._send_stop()
        finally:
            spinning = False
            if self._executor is not None:
                self._executor.shutdown(timeout_sec=2.0)
                if self._thread is not None:  # always, with an executor
                    self._thread.join(timeout=10.0)
                    # a node destroyed under a thread still spinning it crashes the process: leave it
                    spinning = self._thread.is_alive()
            if self._owned_node and not spinning:
                self.node.destroy_node()
            if self._owns_rclpy and rclpy.ok():
                rclpy.shutdown()
            if self._thread is not None:
                atexit.unregister(self.close)

    def _send_stop(self) -> None:
        """Zero velocity to whoever listens on cmd_vel, confirmed before the node goes away.

        The world's command subscription is best effort and acknowledges nothing, so the
        confirmation is the robot's own odometry reporting zero velocity after the stop was sent.
        The stop is repeated every 0.1 s until then, for at most ``STOP_CONFIRM_TIMEOUT`` seconds
        (a robot that publishes no odometry gets the stop ten times).
        """
        if not self.node.context.ok() or self._cmd_pub.get_subscription_count() == 0:
            return  # no world to stop
        deadline = time.monotonic() + STOP_CONFIRM_TIMEOUT
        while time.monotonic() < deadline:
            self._publish(0.0, 0.0)
            with self._cond:
                sent_after = self._odom_count
            if self._await(partial(self._odom_shows, sent_after, 0.0, 0.0), timeout=0.1):
                return

    def _odom_shows(self, sent_after: int, v: float, w: float) -> bool:
        """Odometry came after the first ``sent_after`` messages and reports velocity (v, w)."""
        return self._odom_count > sent_after and self._odom_is(v, w)

    def _odom_is(self, v: float, w: float) -> bool:
        """The newest odometry reports velocity (v, w)."""
        twist = self._latest[spec.ODOM_TOPIC].twist.twist
        return bool(abs(twist.linear.x - v) < 1e-6 and abs(twist.angular.z - w) < 1e-6)

    def _await(self, done: Callable[[], bool], timeout: float) -> bool:
        """Wait up to ``timeout`` wall seconds for ``done()``, spinning in hosted mode; never raises."""
        end = time.monotonic() + timeout
        with self._cond:
            while not done():
                remaining = end - time.monotonic()
                if remaining <= 0:
                    return False
                if self._thread:
                    self._cond.wait(min(remaining, 0.02))
                else:
                    self._cond.release()
                    try:
                        self._spin()
                    finally:
                        self._cond.acquire()
        return True

    def __enter__(self) -> CreateRobot:
        return self

    def __exit__(self, *_exc: object) -> None:
        self.close()

    # ------------------------------------------------------------ commands
    def set_fwd_vel_ang_vel(self, fwd_vel: float, ang_vel: float) -> tuple[float, float]:
        """``SetFwdVelAngVelCreate``: forward (m/s) and angular (rad/s, CCW) velocity.

        Each wheel is clamped to ±0.5 m/s (so an over-limit turn keeps turning, unlike the
        original toolbox). Returns the (v, ω) sent. Does not block.
        """
        _check_finite(fwd_vel=fwd_vel, ang_vel=ang_vel)
        right = _clamp(fwd_vel + ang_vel * WHEEL_BASE / 2, -MAX_WHEEL_SPEED, MAX_WHEEL_SPEED)
        left = _clamp(fwd_vel - ang_vel * WHEEL_BASE / 2, -MAX_WHEEL_SPEED, MAX_WHEEL_SPEED)
        return self.set_drive_wheels(right, left)

    def set_fwd_vel_radius(self, fwd_vel: float, radius: float) -> tuple[float, float]:
        """``SetFwdVelRadiusRoomba``: forward velocity (m/s) on a circle of ``radius`` m (left > 0).

        ``radius = ±inf`` drives straight; other radii are limited to 0.001–2 m in magnitude as on
        the robot (0 warns and becomes 0.001).
        """
        _check_finite(fwd_vel=fwd_vel)
        if math.isnan(radius):
            raise ValueError(f"radius must be a number, got {radius!r}")
        fwd_vel = _clamp(fwd_vel, -MAX_WHEEL_SPEED, MAX_WHEEL_SPEED)
        if math.isinf(radius):
            return self.set_fwd_vel_ang_vel(fwd_vel, 0.0)
        if radius == 0.0:
            warnings.warn("set_fwd_vel_radius: radius 0 is not allowed, using 0.001 m", stacklevel=2)
        radius = math.copysign(_clamp(abs(radius), *RADIUS_RANGE), radius)
        return self.set_fwd_vel_ang_vel(fwd_vel, fwd_vel / radius)

    def set_drive_wheels(self, right_wheel_vel: float, left_wheel_vel: float) -> tuple[float, float]:
        """``SetDriveWheelsCreate``: wheel velocities (m/s), each clamped to ±0.5. Returns (v, ω)."""
        _check_finite(right_wheel_vel=right_wheel_vel, left_wheel_vel=left_wheel_vel)
        right = _clamp(right_wheel_vel, -MAX_WHEEL_SPEED, MAX_WHEEL_SPEED)
        left = _clamp(left_wheel_vel, -MAX_WHEEL_SPEED, MAX_WHEEL_SPEED)
        v, w = (right + left) / 2, (right - left) / WHEEL_BASE
        if self._closed:
            raise RuntimeError("this CreateRobot is closed: create a new one to drive again")
        if self._cmd_pub.get_subscription_count() == 0:
            # A command published before the world has matched would be lost silently.
            self._wait_until(
                lambda: self._cmd_pub.get_subscription_count() > 0, "waiting for the world to subscribe to cmd_vel"
            )
        first = not self._heard and self._confirm_first > 0.0
        if first:  # another node's subscription to cmd_vel (the studio's display) is not the world's
            self._await(self._world_subscribed, self._confirm_first)
        self._publish(v, w)
        if first:
            self._confirm_first_command(v, w)
        return v, w

    def _spin_thread(self) -> None:
        """The standalone client's executor thread. A program ending (SIGTERM, Ctrl-C, exit) shuts
        the executor down while a callback may still be waking it: rclpy then raises on the
        already-destroyed guard condition, a race of its shutdown and no fault of the program, so
        it ends the thread quietly instead of printing a traceback over the program's own exit."""
        assert self._executor is not None
        try:
            self._executor.spin()
        except Exception:  # InvalidHandle, ExternalShutdownException, RCLError at shutdown
            if not (self._closed or not rclpy.ok()):
                raise

    def _world_subscribed(self) -> bool:
        """Whether a node publishing this robot's odometry (the world) subscribes to our cmd_vel."""
        odom_topic = self.node.resolve_topic_name(spec.ODOM_TOPIC)
        worlds = {(i.node_namespace, i.node_name) for i in self.node.get_publishers_info_by_topic(odom_topic)}
        readers = self.node.get_subscriptions_info_by_topic(self._cmd_pub.topic_name)
        return any((i.node_namespace, i.node_name) in worlds for i in readers)

    def _confirm_first_command(self, v: float, w: float) -> None:
        """Repeat the first command until the robot's odometry shows it (``confirm_first_command`` s).

        Just after discovery our publisher may see the world before the world sees it, and the
        world then drops what we send (a reliable subscription asks for it again only while we
        are alive; one overridden to best effort never does). Worse, another node's subscription
        to cmd_vel (the studio shows the commands) can be the one our publisher matched first: a
        sample published then is never sent to the world's reader matched after it (volatile).
        A ported MATLAB program commands once and waits, so that first command must arrive.
        """
        deadline = time.monotonic() + self._confirm_first
        while time.monotonic() < deadline:
            with self._cond:
                sent_after = self._odom_count
            if self._await(partial(self._odom_shows, sent_after, v, w), timeout=0.1):
                break
            self._publish(v, w)
        self._heard = True  # once only, also for a robot that publishes no odometry

    def _publish(self, v: float, w: float) -> None:
        twist = Twist()
        twist.linear.x, twist.angular.z = v, w
        if self._stamped:
            msg = TwistStamped(twist=twist)
            msg.header.stamp = time_msg(self._sim_time)  # the newest sim time the robot reported
            self._cmd_pub.publish(msg)
        else:
            self._cmd_pub.publish(twist)
        self.commands_sent += 1

    def travel_dist(self, speed: float, distance: float, timeout: float | None = None) -> float:
        """``travelDist``: drive ``distance`` m (negative = backwards) at ``|speed|`` m/s, then stop.

        Blocks until odometry reports the distance. ``|speed|`` is kept in 0.025–0.5 m/s. A wall
        in the way stops the body and its odometry, so pass ``timeout`` (sim seconds) to give up
        then. Returns the odometry distance travelled (signed).
        """
        _check_finite(speed=speed, distance=distance)
        speed = _clamp(abs(speed), *TRAVEL_SPEED_RANGE)
        start = self._travelled
        self._drive_until(
            math.copysign(speed, distance),
            0.0,
            abs(distance),
            lambda: abs(self._travelled - start),
            timeout,
            "travel_dist",
        )
        return self._travelled - start

    def turn_angle(self, speed: float, angle: float, timeout: float | None = None) -> float:
        """``turnAngle``: turn in place by ``angle`` degrees (positive = CCW) at ``|speed|`` rad/s.

        Blocks until odometry reports the turn (or ``timeout`` sim seconds pass). ``|speed|`` is
        kept in 0.025–0.2 rad/s. Unlike the toolbox the angle is not wrapped: 360 turns a full
        circle. Returns the odometry turn (degrees).
        """
        _check_finite(speed=speed, angle=angle)
        speed = _clamp(abs(speed), *TURN_SPEED_RANGE)
        target = math.radians(angle)
        start = self._turned
        self._drive_until(
            0.0, math.copysign(speed, target), abs(target), lambda: abs(self._turned - start), timeout, "turn_angle"
        )
        return math.degrees(self._turned - start)

    def _drive_until(
        self, v: float, w: float, goal: float, progress: Callable[[], float], timeout: float | None, what: str
    ) -> None:
        self._msg(spec.ODOM_TOPIC)
        if goal == 0.0:
            return
        deadline = math.inf if timeout is None else self._sim_time + timeout
        self.set_fwd_vel_ang_vel(v, w)
        try:
            self._wait_until(lambda: progress() >= goal or self._sim_time >= deadline, what)
        finally:
            self.set_fwd_vel_ang_vel(0.0, 0.0)

    def beep(self) -> None:
        """``BeepRoomba``: the terminal bell."""
        print("\a", end="", flush=True)

    def set_leds(self, led: int, color: float, intensity: float) -> None:
        """``SetLEDsRoomba``: validated like the toolbox; the simulated robot has no LEDs to show."""
        if led not in (0, 1, 2, 3):
            raise ValueError(f"led must be 0 (none), 1 (Advance), 2 (Play) or 3 (both), got {led!r}")
        if not 0 <= color <= 100:
            raise ValueError(f"color must be 0 (green) to 100 (red), got {color!r}")
        if not 1 <= intensity <= 100:
            raise ValueError(f"intensity must be 1 to 100, got {intensity!r}")

    # ------------------------------------------------------------ sensors
    def _detected(self, topic: str) -> bool:
        return bool(self._msg(topic).range == -math.inf)

    def bumps_wheel_drops(self) -> tuple[bool, bool, bool, bool, bool, bool]:
        """``BumpsWheelDropsSensorsRoomba``: (bump_right, bump_left, wheel_drop_right,
        wheel_drop_left, wheel_drop_caster, bump_front). Both bumpers pressed reads as front only."""
        left, right = (self._detected(spec.bump_topic(side)) for side in spec.BUMP_SIDES)
        front = left and right
        return (right and not front, left and not front, False, False, False, front)

    def wall_sensor(self) -> bool:
        """The IR wall sensor (front right, 0.1 m): True when a wall is there."""
        return self._detected(spec.WALL_TOPIC)

    def virtual_wall_sensor(self) -> bool:
        """``VirtualWallSensorCreate``: True inside a virtual wall's halo or field."""
        return self._detected(spec.VIRTUAL_WALL_TOPIC)

    def _cliff_strength(self, name: str) -> float:
        return float(self._msg(spec.cliff_topic(name)).illuminance)

    def cliff_left_signal_strength(self) -> float:
        """``CliffLeftSignalStrengthRoomba``: percent (≈21.5 on floor, ≈1.5 over a line)."""
        return self._cliff_strength("left")

    def cliff_front_left_signal_strength(self) -> float:
        """``CliffFrontLeftSignalStrengthRoomba``: percent."""
        return self._cliff_strength("front_left")

    def cliff_front_right_signal_strength(self) -> float:
        """``CliffFrontRightSignalStrengthRoomba``: percent."""
        return self._cliff_strength("front_right")

    def cliff_right_signal_strength(self) -> float:
        """``CliffRightSignalStrengthRoomba``: percent."""
        return self._cliff_strength("right")

    def cliff_left_sensor(self) -> bool:
        """``CliffLeftSensorRoomba``: always False (the simulated floor has no cliffs)."""
        return False

    cliff_front_left_sensor = cliff_front_right_sensor = cliff_right_sensor = cliff_left_sensor

    def read_sonar(self, sonar_num: int = 2) -> float | None:
        """``ReadSonar``: distance (m) from the body's edge seen by sonar 1 right, 2 front (default),
        3 left or 4 back; ``None`` when nothing is in range (0.02–3 m)."""
        if sonar_num not in SONAR_NUMBERS:
            raise ValueError(f"sonar_num must be 1 (right), 2 (front), 3 (left) or 4 (back), got {sonar_num!r}")
        value = self._msg(spec.sonar_topic(SONAR_NUMBERS[sonar_num])).range
        return float(value) if math.isfinite(value) else None

    def read_sonar_multiple(self, *sonar_nums: int) -> list[float | None]:
        """``ReadSonarMultiple``: :meth:`read_sonar` for several sonars, default all four in the
        toolbox's order [right, front, left, back]."""
        return [self.read_sonar(n) for n in (sonar_nums or tuple(SONAR_NUMBERS))]

    def lidar(self) -> np.ndarray:
        """``LidarSensorCreate``: 681 ranges (m), index 0 at −120° (right) counter-clockwise to +120°;
        ``inf`` = no return within 4 m."""
        return np.asarray(self._msg(spec.SCAN_TOPIC).ranges, dtype=np.float64)

    def camera(self) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """``CameraSensorCreate``: (angles rad left-positive, distances m, colours N×3 RGB) of the
        beacons the camera sees; empty arrays when none."""
        sightings = self.beacons()
        return (
            np.array([s[2] for s in sightings]),
            np.array([s[1] for s in sightings]),
            np.array([s[3] for s in sightings]).reshape(-1, 3),
        )

    def beacons(self) -> list[tuple[str, float, float, tuple[float, float, float]]]:
        """Beacons in view as (id, distance m, angle rad, (r, g, b)); ids as written in the map."""
        out = []
        for m in self._msg(spec.CAMERA_BEACONS_TOPIC).markers:
            if m.action != m.ADD:
                continue
            x, y = m.pose.position.x, m.pose.position.y
            out.append((m.text, math.hypot(x, y), math.atan2(y, x), (m.color.r, m.color.g, m.color.b)))
        return out

    def read_beacon(self) -> list[tuple[str, float, float, float, float]]:
        """``ReadBeacon`` (AR-tag variant): (id, X right, Y down, Z depth, rotation) per beacon."""
        return [(beacon_id, -d * math.sin(a), 0.0, d * math.cos(a), 0.0) for beacon_id, d, a, _ in self.beacons()]

    def overhead_localization(self) -> tuple[float, float, float]:
        """``OverheadLocalizationCreate``: exact (x, y, θ) in the map frame."""
        pose = self._msg(spec.OVERHEAD_POSE_TOPIC).pose
        return pose.position.x, pose.position.y, yaw_from_quaternion(pose.orientation)

    def distance_sensor(self) -> float:
        """``DistanceSensorRoomba``: odometry distance (m) since the last call."""
        self._msg(spec.ODOM_TOPIC)
        with self._cond:
            value, self._distance_mark = self._travelled - self._distance_mark, self._travelled
        return value

    def angle_sensor(self) -> float:
        """``AngleSensorRoomba``: odometry turn (rad, CCW) since the last call."""
        self._msg(spec.ODOM_TOPIC)
        with self._cond:
            value, self._angle_mark = self._turned - self._angle_mark, self._turned
        return value

    def buttons(self) -> tuple[bool, bool]:
        """``ButtonsSensorRoomba``: (advance, play), in the toolbox's order."""
        play, advance = self._msg(spec.BUTTONS_TOPIC).buttons[:2]
        return bool(advance), bool(play)

    def battery_charge(self) -> tuple[float, float, float]:
        """``BatteryChargeReaderRoomba``: (charge mAh, capacity mAh, percent)."""
        msg = self._msg(spec.BATTERY_TOPIC)
        return msg.charge * 1000.0, msg.capacity * 1000.0, msg.percentage * 100.0

    def battery_voltage(self) -> float:
        """``BatteryVoltageRoomba``: volts."""
        return float(self._msg(spec.BATTERY_TOPIC).voltage)

    def current_tester(self) -> float:
        """``CurrentTesterRoomba``: amperes (negative = discharging)."""
        return float(self._msg(spec.BATTERY_TOPIC).current)

    def all_sensors_read(self) -> AllSensors:
        """``AllSensorsReadRoomba``: every basic sensor at once (distance and angle since last call)."""
        bump_right, bump_left, _, _, _, bump_front = self.bumps_wheel_drops()
        advance, play = self.buttons()
        charge, capacity, percent = self.battery_charge()
        battery = self._msg(spec.BATTERY_TOPIC)
        return AllSensors(
            bump_right,
            bump_left,
            bump_front,
            self.wall_sensor(),
            self.virtual_wall_sensor(),
            False,
            False,
            False,
            False,
            False,
            False,
            False,
            False,
            play,
            advance,
            self.distance_sensor(),
            self.angle_sensor(),
            float(battery.voltage),
            float(battery.current),
            float(battery.temperature),
            charge,
            capacity,
            percent,
        )
