"""``robot_sims matlab_bridge``: serve one Create's toolbox calls to a MATLAB/Octave program over TCP.

The m-files of ``robot_sims matlab_path`` (class ``CreateRobot``) send each toolbox call here; the
bridge makes it on a :class:`create_sim.client.CreateRobot` in the robot's namespace and sends the
outputs back. It listens on loopback only (a program on the same machine; nothing else can drive
the robot) and serves one program at a time.

On a shared host (a classroom) loopback is not private: any local user can connect. With a key
(environment ``ROBOT_SIMS_BRIDGE_KEY``, or ``--key-file``; never an argument, which ``ps`` shows
to everyone) a connection's first line must be ``key <the key>``, sent before the bridge says
anything; anything else is closed unanswered, no call made. The studio makes a fresh key for each
run and hands it to the bridge and to Octave in their environment; ``CreateRobot`` sends it.

Protocol, version 2 (UTF-8 text, one line each way, ``\\n``-terminated):

- With a key, the program first sends ``key <the key>`` (the bridge waits up to :data:`KEY_WAIT`
  s for it, then closes; a bridge without a key ignores the line).
- On connect (keyed: once the key is right) the bridge sends ``robot_sims-matlab 2 create
  <namespace>`` (name, protocol version, toolbox, robot namespace). While another program is
  connected it sends ``busy <message>`` instead and closes the connection: one program at a
  time, a second is refused, not queued.
- The program sends a request: ``@<id>`` (a number it has not used before), the toolbox
  function's name and its numeric arguments after ``serPort``, separated by spaces
  (``@7 SetFwdVelAngVelCreate 0.2 0.5``; ``Inf``/``NaN`` allowed).
- The bridge answers ``@<id> ok`` followed by each output as one JSON value, tab-separated
  (``@7 ok\\t0\\t1\\t0\\t0\\t0\\t0``; a command answers a bare ``@7 ok``), or
  ``@<id> error <message>``, which the m-file raises as a MATLAB error with that message
  (identifier ``CreateRobot:bridge``). One request, one reply, always: a program that lost a
  reply (Ctrl-C while it waited) skips replies to other ids until its own comes.
- ``@<id> cancel`` (the m-file sends it when a call of its is interrupted): a blocking call
  (``travelDist``, ``turnAngle``) still running ends at once, the robot stopped, and answers
  ``@<id> error interrupted``; any new request during a blocking call does the same. A cancel
  for a call already answered is ignored; a cancel gets no reply of its own.
- ``bye`` ends the program's session (so does closing the socket).
- Version 1 lines (without ``@<id>``) are still served, answered without an id.

However the session ends (``bye``, the socket closed, Octave killed, Ctrl-C'd MATLAB clearing
``serPort``), the robot is stopped (zero velocity, confirmed by its odometry); a program lost
during a blocking call (``travelDist``, ``turnAngle``) is noticed within milliseconds, not at the
call's end. ``DistanceSensorRoomba`` and ``AngleSensorRoomba`` count from the program's
connection, as after ``RoombaInit``.

A world that stops answering (killed, hung) turns every call into an error within a second:
after :data:`WORLD_QUIET` s without odometry the bridge asks the world node for a parameter, and
without a reply in :data:`WORLD_ANSWER` s the call fails (a paused world answers, so its frozen
readings are served). Each call is also published on ``matlab_calls`` (``std_msgs/String``) as
the original simulator wrote it into its saved data; record it beside ``overhead_pose`` and
``bag_to_mat`` fills ``datahistory``'s fifth column.

From Python (the studio)::

    bridge = MatlabBridge("/robot1")      # bound and listening; port 0 = any free port
    bridge.start()                        # serve in a background thread
    print(bridge.port)                    # -> CreateRobot(port) in the program
    bridge.close()

or :func:`spawn_bridge` for a bridge in its own process.
"""

from __future__ import annotations

import argparse
import contextlib
import hmac
import ipaddress
import json
import math
import os
import re
import secrets
import signal
import socket
import subprocess
import sys
import threading
import time
from collections.abc import Callable, Sequence
from pathlib import Path
from typing import Any

import rclpy
from nav_msgs.msg import Odometry
from rcl_interfaces.srv import GetParameters
from rclpy.client import Client
from rclpy.duration import Duration
from rclpy.executors import SingleThreadedExecutor
from rclpy.node import Node
from rclpy.signals import SignalHandlerOptions
from std_msgs.msg import String

from create_sim import spec
from create_sim.client import STOP_CONFIRM_TIMEOUT, CreateRobot
from sim_runtime.errors import InputError
from sim_runtime.qos import SENSOR_SUBSCRIBER_QOS
from sim_tools.matlab.calls import COMMANDS, call_text, run_call

PROTOCOL_VERSION = 2
HELLO = "robot_sims-matlab"
DEFAULT_HOST = "127.0.0.1"
DEFAULT_PORT = 47800
POLL = 0.002  # s, wall: how often a blocking call checks its goal and that its program is still there
LISTENING = re.compile(r"listening on ([\d.:a-f\[\]]+):(\d+)")
# s, wall. The world publishes odometry at 50 Hz of sim time, every 20 ms at real time: after
# WORLD_QUIET s without any the bridge asks the world node whether it is there (a paused or very
# slow world answers) and gives it WORLD_ANSWER s to reply; together under the second a program
# waits at most before a dead world is an error.
WORLD_QUIET = 0.3
WORLD_ANSWER = 0.5
# s, wall: how long a program's first command is sent again until the odometry shows it (a world
# on a loaded machine took 1.5 s to match a new bridge's writer, at load 30 on 2 cores).
FIRST_COMMAND_CONFIRM = 5.0
# s, wall: how long a call on matlab_calls waits for a new subscriber to be matched, and then to
# acknowledge it (a recorder started just before the program).
FIRST_CALL_ACK = 5.0
ACK_SLICE = 0.02  # s, wall: that wait in slices, each ending early if the program interrupts
KEY_ENV = "ROBOT_SIMS_BRIDGE_KEY"
KEY_WAIT = 10.0  # s, wall: for a keyed connection's first line (Octave sends it as it connects)
KEY_LINE_MAX = 4096  # bytes: a longer first line is not the key (nor is it buffered without end)


class ProgramLost(Exception):
    """The program's connection closed (it ended, or Octave/MATLAB was killed)."""


class Interrupted(Exception):
    """During a blocking call the program sent a line: it cancelled the call (Ctrl-C) or moved on."""


class WorldLost(RuntimeError):
    """The world stopped publishing and does not answer."""


def check_loopback(host: str) -> None:
    """Refuse any address but loopback: the bridge drives a robot for whoever connects."""
    try:
        addresses = {info[4][0] for info in socket.getaddrinfo(host, None)}
    except socket.gaierror as error:
        raise InputError(f"--host {host!r}: unknown host ({error})") from None
    if not all(ipaddress.ip_address(str(a).split("%")[0]).is_loopback for a in addresses):
        raise InputError(
            f"--host {host!r}: the MATLAB bridge listens on loopback only (127.0.0.1, ::1, localhost), "
            "so that no other machine can drive the robot"
        )


def _encode(value: Any) -> Any:
    """JSON-able outputs, with non-finite numbers as null (MATLAB's jsondecode reads NaN)."""
    if isinstance(value, float) and not math.isfinite(value):
        return None
    if isinstance(value, list | tuple):
        return [_encode(v) for v in value]
    return value


def reply_ok(outputs: list[Any]) -> str:
    return "\t".join(["ok", *(json.dumps(_encode(o)) for o in outputs)])


def reply_error(error: BaseException) -> str:
    text = str(error) or type(error).__name__
    if not isinstance(error, ValueError | RuntimeError | TimeoutError):
        text = f"{type(error).__name__}: {text}"
    return "error " + " ".join(text.split())  # one line


def split_id(line: str) -> tuple[str, str]:
    """``@7 Name a1 …`` → (``"@7 "``, ``"Name a1 …"``): the reply's prefix and the request; a
    version-1 line without an id gives an empty prefix."""
    if line.startswith("@"):
        ident, _, rest = line.partition(" ")
        return ident + " ", rest.strip()
    return "", line


def parse_request(line: str) -> tuple[str, list[float]]:
    """``Name a1 a2 …`` → (name, numeric arguments); ValueError naming what is wrong."""
    words = line.split()
    if not words:
        raise ValueError("empty request: expected a toolbox function name and its arguments")
    try:
        return words[0], [float(w) for w in words[1:]]
    except ValueError:
        raise ValueError(f"{words[0]}: arguments must be numbers, got {' '.join(words[1:])!r}") from None


class Session:
    """One program's connection: requests in, one reply each out, the robot stopped at the end."""

    def __init__(self, conn: socket.socket, bridge: MatlabBridge, buffered: bytes = b"") -> None:
        self.conn = conn
        self.bridge = bridge
        self._buffer = buffered  # what the program sent after its key
        self.armed = False  # while True (a call runs), a line from the program interrupts it

    def serve(self, namespace: str) -> None:
        self._send(f"{HELLO} {PROTOCOL_VERSION} create {namespace}")
        try:
            self._loop()
        except ProgramLost:
            pass
        except OSError as error:  # the connection failed (reset, or the bridge is closing)
            _log(f"the program's connection failed: {error!r}")
        finally:
            self.armed = False
            self.bridge.stop_robot()

    def _loop(self) -> None:
        while (line := self._read_line()) != "bye":
            prefix, request = split_id(line)
            if request == "cancel":
                continue  # the call it cancels was answered already
            if not prefix and request.startswith("key "):
                continue  # a toolbox given a key, and this bridge none: nothing to check
            self._send(prefix + self.answer(request))

    def answer(self, request: str) -> str:
        """The reply (without id) to one request."""
        self.bridge.wait_to_serve()
        try:
            name, args = parse_request(request)
            self.bridge.check_world()
            if name in COMMANDS:  # a command is written as it begins (a travelDist lasts), as the original
                self.bridge.publish_call(name, args, [], interrupted=self.line_waiting)
            self.armed = True
            try:
                outputs = run_call(self.bridge.robot, name, args)
            finally:
                self.armed = False
        except ProgramLost:
            raise
        except Interrupted:
            self.bridge.stop_robot()
            return f"error {name}: interrupted by the program; the robot stopped"
        except Exception as error:  # the program's mistake or the robot's: the program's error()
            return reply_error(error)
        if name not in COMMANDS:  # a reading: with its outputs
            self.bridge.publish_call(name, args, outputs, interrupted=self.line_waiting)
        return reply_ok(outputs)

    def _read_line(self) -> str:
        while b"\n" not in self._buffer:
            chunk = self.conn.recv(65536)
            if not chunk:
                raise ProgramLost
            self._buffer += chunk
        line, self._buffer = self._buffer.split(b"\n", 1)
        return line.decode("utf-8", "replace").strip()

    def _send(self, line: str) -> None:
        self.conn.sendall(line.encode() + b"\n")

    def line_waiting(self) -> bool:
        """Whether the program has sent a line (or closed the connection) that the next poll takes:
        a wait before a call ends early for it, and the call is then interrupted at once."""
        try:
            chunk = self.conn.recv(65536, socket.MSG_DONTWAIT)
        except BlockingIOError:
            return b"\n" in self._buffer
        except OSError:
            return True
        if not chunk:
            return True  # closed: the next poll's recv sees it too
        self._buffer += chunk
        return b"\n" in self._buffer

    def poll(self) -> None:
        """During a call: ProgramLost if the connection has closed, Interrupted if a line came."""
        if not self.armed:
            return
        try:
            chunk = self.conn.recv(65536, socket.MSG_DONTWAIT)
        except BlockingIOError:
            return
        except OSError:
            raise ProgramLost from None
        if not chunk:
            raise ProgramLost
        self._buffer += chunk
        if b"\n" in self._buffer:
            raise Interrupted


class MatlabBridge:
    """A listening bridge for the Create in ``namespace`` (bound when constructed).

    One client serves every program in turn: its subscriptions live as long as the bridge, so a
    program's first command reaches a world that has long discovered it. Without ``node`` the
    bridge makes its own in ``namespace`` and spins it in a thread; with one (its namespace is the
    robot's), the caller spins it.
    """

    def __init__(
        self,
        namespace: str = "",
        host: str = DEFAULT_HOST,
        port: int = DEFAULT_PORT,
        node: Node | None = None,
        key: str | None = None,
    ) -> None:
        check_loopback(host)
        self._key = f"key {key}".encode() if key else None  # a connection's first line, when set
        self._server = socket.create_server((host, port), family=_family(host))
        self._executor: SingleThreadedExecutor | None = None
        self._spinning = threading.Event()  # cleared to end the spinner thread
        if node is None:
            node = self._own_node(namespace)
        self.node = node
        self._odom: Odometry | None = None
        self._odom_time = 0.0  # monotonic, when it came
        self._world_answered = 0.0  # monotonic, when the world last answered a probe
        self._odom_topic = node.resolve_topic_name(spec.ODOM_TOPIC)
        self._probes: dict[str, Client] = {}
        node.create_subscription(Odometry, spec.ODOM_TOPIC, self._on_odom, SENSOR_SUBSCRIBER_QOS)
        self._calls = node.create_publisher(String, "matlab_calls", 100)
        self._calls_acked = 0  # subscribers matched when a call last waited for acknowledgement (publish_call)
        #: Cleared by :meth:`hold_calls`: calls wait (their program with them) until :meth:`serve_calls`.
        self._serving = threading.Event()
        self._serving.set()
        self._calls_unmatched = 0  # subscribers in the graph the last wait for them gave up on
        # Its first command repeated until the odometry shows it (at most FIRST_COMMAND_CONFIRM s):
        # a new bridge's writer may have matched only the studio's cmd_vel display, or the world's
        # reader before the world matched the writer; either way the world would not get it.
        self.robot = CreateRobot(node=node, spin=self._spin, confirm_first_command=FIRST_COMMAND_CONFIRM)
        self._busy = threading.Lock()
        self._session: Session | None = None
        self._closed = threading.Event()
        if self._executor is not None:
            self._spinner.start()

    def _own_node(self, namespace: str) -> Node:
        if not rclpy.ok():
            # Without rclpy's signal handlers: they would shut ROS down on Ctrl-C before the
            # robot could be told to stop.
            rclpy.init(signal_handler_options=SignalHandlerOptions.NO)
        node = Node("matlab_bridge", namespace=namespace)
        self._executor = SingleThreadedExecutor()
        self._executor.add_node(node)
        self._spinning.set()
        self._spinner = threading.Thread(target=self._spin_executor, daemon=True, name="matlab_bridge_spin")
        return node

    def _spin_executor(self) -> None:
        # Our own loop rather than executor.spin(): close() ends it and joins the thread before
        # shutting the executor down, so no spin is inside the executor as it is torn down (that
        # race gave "'NoneType' object has no attribute 'trigger'" at exit).
        assert self._executor is not None
        while self._spinning.is_set() and self._executor.context.ok():
            self._executor.spin_once(timeout_sec=0.05)

    def _on_odom(self, msg: Odometry) -> None:
        self._odom, self._odom_time = msg, time.monotonic()

    def _spin(self) -> None:
        """While a call blocks: the executor thread brings the messages; give up if the program
        is gone or has interrupted the call, or the world is."""
        threading.Event().wait(POLL)
        session = self._session
        if session is not None:
            session.poll()
        self.check_world()

    def check_world(self) -> None:
        """WorldLost if the world has been quiet for WORLD_QUIET s and does not answer a probe."""
        if self._odom is None:
            return  # no world heard yet: the client waits for its first messages, and says so
        heard = max(self._odom_time, self._world_answered)
        if time.monotonic() - heard < WORLD_QUIET:
            return
        world = self._world_node()
        if (world is not None and self._answers(world)) or self._odom_time > heard:
            self._world_answered = time.monotonic()  # (or its odometry came meanwhile: a slow world)
            return
        silent = f"no reply from its node {world} in {WORLD_ANSWER} s" if world else "no node publishes it"
        raise WorldLost(
            f"the world of {self.node.get_namespace()} stopped answering: no odometry for "
            f"{time.monotonic() - self._odom_time:.1f} s and {silent} (is create_world still running?)"
        )

    def _world_node(self) -> str | None:
        """The full name of the node publishing the robot's odometry (None: there is none)."""
        for info in self.node.get_publishers_info_by_topic(self._odom_topic):
            if info.node_name != self.node.get_name():
                return f"{info.node_namespace.rstrip('/')}/{info.node_name}"
        return None

    def _answers(self, world: str) -> bool:
        """Whether ``world`` answers a parameter request within WORLD_ANSWER s."""
        client = self._probes.get(world)
        if client is None:
            client = self._probes[world] = self.node.create_client(GetParameters, f"{world}/get_parameters")
        if not client.service_is_ready():
            return False
        answered = threading.Event()
        future = client.call_async(GetParameters.Request(names=["real_time_factor"]))
        future.add_done_callback(lambda _f: answered.set())
        if answered.wait(WORLD_ANSWER):
            return True
        client.remove_pending_request(future)
        return False

    def hold_calls(self) -> None:
        """Make programs' calls wait until :meth:`serve_calls`: a batch episode holds its program's
        first call until its recorder has subscribed to matlab_calls and the world is set up."""
        self._serving.clear()

    def serve_calls(self) -> None:
        """Answer calls again (see :meth:`hold_calls`)."""
        self._serving.set()

    def wait_to_serve(self) -> None:
        """Return when calls are served; ProgramLost if the bridge closes meanwhile."""
        while not self._serving.wait(0.05):
            if self._closed.is_set():
                raise ProgramLost

    def publish_call(
        self, name: str, args: Sequence[float], outputs: list[Any], interrupted: Callable[[], bool] = lambda: False
    ) -> None:
        """The call on ``matlab_calls``, as the original's saved data writes it. Its waits for a new
        subscriber end early when ``interrupted()`` (the program's Ctrl-C: the robot stops at once)."""
        try:
            text = call_text(name, args, outputs)
        except (ValueError, TypeError, IndexError) as error:  # a record, never the program's failure
            _log(f"cannot write {name}'s call for matlab_calls: {error}")
            return
        # A recorder files each call by when it arrives (bag_to_mat's datahistory rows). One
        # started just before the program shows in the graph before this writer has matched it;
        # it would get the call only once matched, or on the reliable repair, after the robot
        # has moved. So a call waits for a subscriber new to this writer (at most FIRST_CALL_ACK s
        # each, once per subscriber count: one that can never match costs one wait), and then for
        # its acknowledgement; the later calls arrive as they are made.
        self._await_new_subscribers(interrupted)
        self._calls.publish(String(data=text))
        matched = self._calls.get_subscription_count()
        if matched != self._calls_acked:  # once per count: a subscriber that never answers costs one wait
            self._calls_acked = matched
            deadline = time.monotonic() + FIRST_CALL_ACK
            while not self._calls.wait_for_all_acked(Duration(seconds=ACK_SLICE)):
                if interrupted() or time.monotonic() > deadline:
                    break

    def _await_new_subscribers(self, interrupted: Callable[[], bool]) -> None:
        """Until this writer has matched every subscriber of matlab_calls the graph shows."""
        shown = self.node.count_subscribers(self._calls.topic_name)
        if shown <= self._calls.get_subscription_count() or shown == self._calls_unmatched:
            return
        deadline = time.monotonic() + FIRST_CALL_ACK
        while self._calls.get_subscription_count() < shown:
            if interrupted():
                return  # the call ends at once; the next one waits again
            if time.monotonic() > deadline:
                self._calls_unmatched = shown  # never matched (its QoS?): no more waits for it
                return
            threading.Event().wait(POLL)
        self._calls_unmatched = 0

    def stop_robot(self) -> None:
        """Zero velocity, repeated until the robot's odometry reports it standing (at most 1 s)."""
        deadline = time.monotonic() + STOP_CONFIRM_TIMEOUT
        while time.monotonic() < deadline:
            try:
                self.robot.set_fwd_vel_ang_vel(0.0, 0.0)
            except (TimeoutError, RuntimeError):
                return  # no world to stop, or the bridge is closing
            sent = time.monotonic()
            while time.monotonic() - sent < 0.1:
                if self._standing(after=sent):
                    return
                threading.Event().wait(POLL)

    def _standing(self, after: float) -> bool:
        odom = self._odom
        if odom is None:
            return False
        twist = odom.twist.twist
        return self._odom_time > after and twist.linear.x == 0.0 and twist.angular.z == 0.0

    @property
    def port(self) -> int:
        return int(self._server.getsockname()[1])

    @property
    def host(self) -> str:
        return str(self._server.getsockname()[0])

    def start(self) -> MatlabBridge:
        """Serve in a background thread; returns self."""
        threading.Thread(target=self.serve_forever, daemon=True, name="matlab_bridge").start()
        return self

    def serve_forever(self) -> None:
        """Accept programs until :meth:`close`: one served at a time, others told so."""
        while not self._closed.is_set():
            try:
                conn, _address = self._server.accept()
            except OSError:
                return  # closed
            conn.setsockopt(socket.IPPROTO_TCP, socket.TCP_NODELAY, 1)
            if self._key is None:
                self._admit(conn, b"")
            else:  # in its own thread: a connection that sends nothing holds up no other
                threading.Thread(target=self._check_key, args=(conn,), daemon=True, name="matlab_key").start()

    def _admit(self, conn: socket.socket, buffered: bytes) -> None:
        if self._busy.acquire(blocking=False):
            threading.Thread(target=self._serve, args=(conn, buffered), daemon=True, name="matlab_session").start()
        else:
            _refuse(conn, self.node.get_namespace())

    def _check_key(self, conn: socket.socket) -> None:
        """Admit a connection whose first line is the key; close any other unanswered."""
        assert self._key is not None
        line, rest = _first_line(conn)
        if line is None or not hmac.compare_digest(line.rstrip(b"\r"), self._key):
            _log(
                f"refused a connection to {self.node.get_namespace()}: its first line was not this run's key "
                "(another local user, or a program started without ROBOT_SIMS_BRIDGE_KEY)"
            )
            conn.close()
            return
        if self._closed.is_set():  # closed while it sent the key: no session to start
            conn.close()
            return
        self._admit(conn, rest)

    def _serve(self, conn: socket.socket, buffered: bytes = b"") -> None:
        try:
            _log(f"a program connected to {self.node.get_namespace()}")
            if self._odom is not None:  # (without a robot yet, the program's first call will say so)
                self.robot.distance_sensor(), self.robot.angle_sensor()  # count from here, as after RoombaInit
            self._session = Session(conn, self, buffered)
            self._session.serve(self.node.get_namespace())
            _log("the program ended: robot stopped")
        finally:
            self._session = None
            self._busy.release()  # before the program hears the end: the next one is welcome
            conn.close()

    def close(self) -> None:
        """Stop listening, end the program's session (stopping the robot) and the node."""
        if self._closed.is_set():
            return
        self._closed.set()
        self._server.close()
        session = self._session
        if session is not None:
            with contextlib.suppress(OSError):  # already closed: the session has ended
                session.conn.shutdown(socket.SHUT_RDWR)  # its program is lost: the robot stops
        if self._busy.acquire(timeout=5.0):
            self._busy.release()
        if self._executor is not None:
            self._spinning.clear()
            self._spinner.join(timeout=10.0)  # a thread still inside rclpy at exit aborts the process
            if not self._spinner.is_alive():  # and a node destroyed under it crashes it
                self._executor.shutdown(timeout_sec=2.0)
                self.node.destroy_node()


def _first_line(conn: socket.socket) -> tuple[bytes | None, bytes]:
    """A new connection's first line and what came after it; None if none came within KEY_WAIT
    s, the connection closed first, or the line is longer than any key."""
    data = b""
    conn.settimeout(KEY_WAIT)
    try:
        while b"\n" not in data:
            chunk = conn.recv(KEY_LINE_MAX)
            if not chunk or len(data) + len(chunk) > KEY_LINE_MAX:
                return None, b""
            data += chunk
    except OSError:  # (socket.timeout is one)
        return None, b""
    finally:
        with contextlib.suppress(OSError):
            conn.settimeout(None)
    line, _, rest = data.partition(b"\n")
    return line, rest


def read_key(key_file: str | None) -> str | None:
    """The bridge's key: the file's first line (read once), else ``ROBOT_SIMS_BRIDGE_KEY``; None
    without either. InputError for a file that cannot be read or holds no key."""
    if key_file is None:
        return os.environ.get(KEY_ENV, "").strip() or None
    try:
        text = Path(key_file).read_text(encoding="utf-8")
    except (OSError, UnicodeDecodeError) as error:
        raise InputError(f"--key-file {key_file!r}: cannot read it ({error})") from None
    key = text.strip().split("\n")[0].strip()
    if not key:
        raise InputError(f"--key-file {key_file!r}: empty (write the key on its first line)")
    return key


def _family(host: str) -> socket.AddressFamily:
    return socket.AF_INET6 if ":" in host else socket.AF_INET


def _refuse(conn: socket.socket, namespace: str) -> None:
    message = f"busy another program is connected to the robot {namespace}: one program at a time per bridge"
    try:
        conn.sendall(message.encode() + b"\n")
    finally:
        conn.close()


def _log(text: str) -> None:
    print(f"matlab_bridge: {text}", file=sys.stderr, flush=True)


def spawn_bridge(
    namespace: str, port: int = 0, env: dict[str, str] | None = None, key: str | None = None
) -> tuple[subprocess.Popen, int]:
    """``robot_sims matlab_bridge`` for ``namespace`` in its own process; returns it and its port
    once it listens (port 0: any free port). Stop it with SIGINT or SIGTERM: the robot stops.
    With ``key`` (a fresh :func:`new_key` for each run) it serves only connections that send it
    first; the key goes in the bridge's environment, never its arguments (``ps`` shows those)."""
    from sim_tools.cli import executable_command  # the CLI imports every executable's table

    env = dict(os.environ if env is None else env)
    if key:
        env[KEY_ENV] = key
    else:
        env.pop(KEY_ENV, None)  # (the caller's own key is not this bridge's)

    process = subprocess.Popen(
        executable_command("matlab_bridge", ["--namespace", namespace, "--port", str(port)]),
        stdout=subprocess.PIPE,
        text=True,
        env=env,
    )
    assert process.stdout is not None
    said = []  # Fast DDS writes its own errors to stdout (a stale shared-memory port): skip them
    while (line := process.stdout.readline()) and (match := LISTENING.search(line)) is None:
        said.append(line)
    if not line or match is None:
        process.kill()
        process.wait()
        raise RuntimeError(f"matlab_bridge did not start (said {''.join(said)!r}); see its stderr")
    return process, int(match.group(2))


def new_key() -> str:
    """A fresh random key for one run (256 bits, hex: a plain line for the m-file to send)."""
    return secrets.token_hex(32)


def _interrupt(_signum: int, _frame: object) -> None:
    """The first SIGINT or SIGTERM ends the bridge (through close(), which stops the robot); any
    later one is ignored, so that it cannot cut the stop short (nor print a traceback)."""
    signal.signal(signal.SIGINT, signal.SIG_IGN)
    signal.signal(signal.SIGTERM, signal.SIG_IGN)
    raise KeyboardInterrupt


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(
        prog="robot_sims matlab_bridge",
        description="Serve one Create's toolbox calls to a MATLAB/Octave program (loopback TCP).",
    )
    parser.add_argument("--namespace", default="", help="the robot's namespace, e.g. /robot1 (default: none)")
    parser.add_argument("--host", default=DEFAULT_HOST, help="loopback address to listen on (default 127.0.0.1)")
    parser.add_argument("--port", type=int, default=DEFAULT_PORT, help=f"port (default {DEFAULT_PORT}; 0 = any free)")
    parser.add_argument(
        "--key-file",
        help=f"serve only programs that send the key on this file's first line (default: ${KEY_ENV}, if set)",
    )
    args = parser.parse_args(sys.argv[1:] if argv is None else argv)
    # SIGTERM ends like Ctrl-C: through close(), which stops the robot; a second is ignored.
    signal.signal(signal.SIGINT, _interrupt)
    signal.signal(signal.SIGTERM, _interrupt)
    try:
        key = read_key(args.key_file)
        bridge = MatlabBridge(args.namespace, args.host, args.port, key=key)
    except InputError as error:
        print(f"matlab_bridge: error: {error}", file=sys.stderr)
        return 2
    except KeyboardInterrupt:
        return 130  # ended while starting: no robot driven yet
    # A program waits on each reply: hand the interpreter to the session thread sooner than the
    # default 5 ms when the spinner thread is busy with the robot's messages (p99 latency).
    sys.setswitchinterval(0.0005)
    if key is None:
        _log(f"no key ({KEY_ENV} or --key-file): any local user's connection may drive the robot")
    print(f"matlab_bridge: listening on {bridge.host}:{bridge.port} for {bridge.node.get_namespace()}", flush=True)
    try:
        bridge.serve_forever()
    except KeyboardInterrupt:
        pass
    finally:
        bridge.close()
        if rclpy.ok():
            rclpy.shutdown()
    return 0
