"""create_teleop driven through a pseudo-terminal, as a user at a keyboard would."""

from __future__ import annotations

import os
import pty
import select
import subprocess
import sys
import time
from pathlib import Path

import pytest
from geometry_msgs.msg import Twist

from create_sim.teleop import split_keys
from sim_runtime.qos import SENSOR_SUBSCRIBER_QOS
from sim_runtime.testing import Collector, spin_until, wait_for_match

ROOT = Path(__file__).resolve().parent.parent


def test_split_keys_separates_arrow_sequences():
    assert split_keys(b"w\x1b[Aa\x1b\x1bOC ") == [b"w", b"\x1b[A", b"a", b"\x1b", b"\x1bOC", b" "]


class Terminal:
    """The teleop running in a child process on a pty we type into."""

    def __init__(self, *ros_args: str) -> None:
        self.master, slave = pty.openpty()
        env = dict(os.environ, PYTHONPATH=str(ROOT))
        self.process = subprocess.Popen(
            [sys.executable, "-m", "create_sim.teleop", "--ros-args", *ros_args],
            stdin=slave,
            stdout=slave,
            stderr=subprocess.PIPE,
            env=env,
            cwd=ROOT,
        )
        os.close(slave)
        self.output = b""

    def read_until(self, text: bytes, timeout: float = 20.0) -> None:
        deadline = time.monotonic() + timeout
        while text not in self.output:
            assert time.monotonic() < deadline, f"teleop never printed {text!r}; got {self.output!r}"
            if select.select([self.master], [], [], 0.1)[0]:
                self.output += os.read(self.master, 1024)

    def type(self, keys: bytes) -> None:
        os.write(self.master, keys)

    def close(self) -> int:
        try:
            return self.process.wait(timeout=10)
        finally:
            if self.master >= 0:
                os.close(self.master)
                self.master = -1


@pytest.fixture
def terminal():
    # Repeating the command lets the test see the connection work both ways before typing: a
    # reliable publisher drops messages sent before it has matched the subscriber.
    term = Terminal("-p", "repeat_rate:=20.0")
    yield term
    if term.process.poll() is None:
        term.process.kill()
    term.close()


def test_keys_publish_the_seed_manual_control_velocities(terminal, executor, make_node):
    probe = make_node("teleop_probe")
    cmd = Collector(probe, Twist, "cmd_vel", SENSOR_SUBSCRIBER_QOS)
    assert wait_for_match(executor, cmd.subscription, timeout=30.0)
    terminal.read_until(b"Create teleop")  # the terminal is in cbreak mode from here on
    assert spin_until(executor, lambda: cmd.last is not None, timeout=10.0)
    assert (cmd.last.linear.x, cmd.last.angular.z) == (0.0, 0.0)

    def press(keys: bytes, v: float, w: float) -> None:
        cmd.clear()
        terminal.type(keys)
        assert spin_until(executor, lambda: len(cmd.msgs) >= 2, timeout=10.0), f"no cmd_vel after {keys!r}"
        # Typing publishes at once, and the repeat carries the same command: no stale message.
        assert (cmd.msgs[0].linear.x, cmd.msgs[0].angular.z) == pytest.approx((v, w)), keys
        assert (cmd.last.linear.x, cmd.last.angular.z) == pytest.approx((v, w)), keys

    press(b"w", 0.1, 0.0)
    press(b"\x1b[A", 0.2, 0.0)  # up arrow
    press(b"a", 0.2, 0.5)
    press(b"\x1b[D", 0.2, 1.0)  # left arrow
    press(b"d", 0.2, 0.5)
    press(b"\x1b[C", 0.2, 0.0)  # right arrow
    press(b"s", 0.1, 0.0)
    press(b"\x1b[B", 0.0, 0.0)  # down arrow
    press(b"\x1b[B", -0.1, 0.0)
    press(b" ", 0.0, 0.0)  # space stops
    press(b"wwwwwwwwww", 0.5, 0.0)  # capped at 0.5 m/s
    press(b"\r", 0.0, 0.0)  # Return stops
    press(b"aa", 0.0, 1.0)
    press(b"\x1b", 0.0, 0.0)  # Escape stops
    press(b"w", 0.1, 0.0)
    terminal.read_until(b"v = +0.1 m/s")
    cmd.clear()
    terminal.type(b"q")
    assert terminal.close() == 0
    assert spin_until(executor, lambda: len(cmd.msgs) > 0, timeout=10.0)
    assert (cmd.last.linear.x, cmd.last.angular.z) == (0.0, 0.0)  # quitting stops the robot


def test_teleop_refuses_to_run_without_a_terminal():
    result = subprocess.run(
        [sys.executable, "-m", "create_sim.teleop"],
        stdin=subprocess.DEVNULL,
        capture_output=True,
        text=True,
        env=dict(os.environ, PYTHONPATH=str(ROOT)),
        cwd=ROOT,
        timeout=60,
    )
    assert result.returncode != 0
    assert "terminal" in result.stderr
