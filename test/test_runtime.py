"""The shared runtime: sim clock and stepping, scheduled publishers, checked parameters, messages."""

import math
from collections.abc import Callable

import numpy as np
import pytest
from rclpy.duration import Duration
from rclpy.parameter import Parameter
from rosgraph_msgs.msg import Clock
from std_msgs.msg import Float64

from sim_runtime.errors import InputError
from sim_runtime.msgs import (
    float32_array,
    matrix_from_quaternion,
    quaternion_from_matrix,
    quaternion_from_yaw,
    time_from_msg,
    time_msg,
    yaw_from_quaternion,
)
from sim_runtime.qos import COMMAND_PUBLISHER_QOS, create_command_subscription
from sim_runtime.run import drain
from sim_runtime.testing import Collector, spin_until, wait_for_match
from sim_runtime.world_node import SimWorldNode


class CounterWorld(SimWorldNode):
    """A world whose 'model' counts physics steps and publishes at 10 Hz and 30 Hz."""

    def __init__(self, **kwargs):
        super().__init__("counter_world", physics_rate=100.0, **kwargs)
        self.physics_steps = 0
        self.ten_hz: list[float] = []
        self.thirty_hz: list[float] = []
        self.every(10.0, lambda: self.ten_hz.append(self.sim_time))
        self.every(30.0, lambda: self.thirty_hz.append(self.sim_time))
        self.every(0.0, lambda: pytest.fail("rate 0 must never fire"))
        self.pub = self.create_publisher(Float64, "value", 10)
        self.every(50.0, lambda: self.pub.publish(Float64(data=self.sim_time)))

    def physics_step(self):
        self.physics_steps += 1


def test_step_advances_sim_time_and_fires_publishers_at_their_rates(executor):
    world = CounterWorld()
    executor.add_node(world)
    world.step(100)
    assert world.physics_steps == 100
    assert world.sim_time == pytest.approx(1.0)
    assert world.ten_hz == pytest.approx([0.1 * k for k in range(1, 11)])
    # 30 Hz on a 100 Hz step: fires on the first step at or after each 1/30 s multiple.
    assert len(world.thirty_hz) == 30
    expected = [math.ceil(round(k / 30 * 100, 9)) / 100 for k in range(1, 31)]
    assert world.thirty_hz == pytest.approx(expected)


def test_clock_and_stamped_messages_carry_sim_time(executor, make_node):
    world = CounterWorld()
    executor.add_node(world)
    probe = make_node("probe")
    clocks = Collector(probe, Clock, "/clock", 100)
    values = Collector(probe, Float64, "value", 10)
    assert wait_for_match(executor, clocks.subscription)
    assert wait_for_match(executor, values.subscription)
    world.step(10)
    assert spin_until(executor, lambda: len(clocks.msgs) == 10 and len(values.msgs) == 5)
    assert [time_from_msg(m.clock) for m in clocks.msgs] == pytest.approx([0.01 * k for k in range(1, 11)])
    assert [m.data for m in values.msgs] == pytest.approx([0.02, 0.04, 0.06, 0.08, 0.1])


def test_drain_runs_every_callback_queued_before_it(executor):
    ran: list[int] = []
    for k in range(5):
        executor.create_task(lambda k=k: ran.append(k))
    assert drain(executor)
    assert ran == [0, 1, 2, 3, 4]


def test_parameters_are_checked_with_a_clear_error(ros):
    with pytest.raises(InputError, match=r"real_time_factor.*-1\.0"):
        CounterWorld(parameter_overrides=[Parameter("real_time_factor", value=-1.0)])
    world = CounterWorld(parameter_overrides=[Parameter("seed", value=7)])
    assert world.rng.integers(1 << 30) == np.random.default_rng(7).integers(1 << 30)
    world.destroy_node()


def test_time_and_quaternion_conversions_round_trip():
    stamp = time_msg(12.345678901)
    assert (stamp.sec, stamp.nanosec) == (12, 345678901)
    assert time_from_msg(stamp) == pytest.approx(12.345678901)
    for yaw in np.linspace(-3.1, 3.1, 13):
        assert yaw_from_quaternion(quaternion_from_yaw(yaw)) == pytest.approx(yaw)
        q = quaternion_from_matrix(matrix_from_quaternion(quaternion_from_yaw(yaw)))
        assert yaw_from_quaternion(q) == pytest.approx(yaw)
    rng = np.random.default_rng(1)
    for _ in range(20):
        rotation, _ = np.linalg.qr(rng.normal(size=(3, 3)))
        rotation *= np.sign(np.linalg.det(rotation))
        assert matrix_from_quaternion(quaternion_from_matrix(rotation)) == pytest.approx(rotation)


def test_float32_array_fills_message_fields_exactly():
    from sensor_msgs.msg import LaserScan

    values = np.array([0.5, math.inf, 2.25], dtype=np.float64)
    msg = LaserScan()
    msg.ranges = float32_array(values)
    assert list(msg.ranges) == [0.5, math.inf, 2.25]


def test_real_time_factor_paces_the_world_against_the_wall_clock(ros, monkeypatch):
    import sim_runtime.world_node as world_node

    wall = [100.0]
    monkeypatch.setattr(world_node.time, "monotonic", lambda: wall[0])
    world = CounterWorld(parameter_overrides=[Parameter("real_time_factor", value=2.0)])
    world.start_pacing()
    wall[0] += 0.2  # 0.2 wall seconds at twice real time: 0.4 sim seconds, 0.1 s (10 steps) a tick
    for _tick in range(4):
        world._pace()
    assert world.sim_time == pytest.approx(0.4) and world.physics_steps == 40
    wall[0] += 0.004  # less than one step's worth (0.005 s wall): nothing yet
    world._pace()
    assert world.physics_steps == 40
    wall[0] += 10.0  # far behind: a bounded backlog, then real time from there (physics never skips)
    burst = world.burst_steps  # MAX_BURST_SIM_S per tick: the executor takes messages in between
    assert burst == 10
    for tick in range(1, world_node.MAX_CATCH_UP_STEPS // burst + 1):
        world._pace()
        assert world.physics_steps == 40 + tick * burst
    world._pace()  # the backlog is done: nothing more due at this wall time
    assert world.physics_steps == 40 + world_node.MAX_CATCH_UP_STEPS
    wall[0] += 0.05
    world._pace()
    assert world.physics_steps == 40 + world_node.MAX_CATCH_UP_STEPS + 10
    world.destroy_node()


class CommandedWorld(CounterWorld):
    """A counter world with a command subscription: each step records the last command it had,
    and a test may publish during a step (``during``: step number -> action)."""

    def __init__(self, **kwargs):
        super().__init__(**kwargs)
        self.command = 0.0
        self.seen: list[float] = []  # the command each physics step ran with
        self.during: dict[int, Callable[[], None]] = {}
        create_command_subscription(self, Float64, "command", lambda msg: setattr(self, "command", msg.data))

    def physics_step(self):
        super().physics_step()
        self.seen.append(self.command)
        if action := self.during.get(self.physics_steps):
            action()


def test_a_command_sent_during_a_catch_up_burst_takes_effect_at_the_next_step(executor, make_node, monkeypatch):
    import sim_runtime.world_node as world_node

    wall = [100.0]
    monkeypatch.setattr(world_node.time, "monotonic", lambda: wall[0])
    world = CommandedWorld()
    executor.add_node(world)
    publisher = make_node("commander").create_publisher(Float64, "command", COMMAND_PUBLISHER_QOS)
    assert wait_for_match(executor, publisher) and wait_for_match(executor, world.command_subscriptions[0])
    world.start_pacing()

    def send(value: float) -> None:  # in the world's step, as if it came from another process then
        publisher.publish(Float64(data=value))
        assert publisher.wait_for_all_acked(Duration(seconds=30))  # it waits in the world's reader

    world.during = {3: lambda: send(1.0), 7: lambda: send(2.0)}
    wall[0] += 1.0  # 100 steps behind: a backlog of MAX_CATCH_UP_STEPS, burst_steps a tick
    world._pace()  # no executor turn inside: only the world itself takes the commands
    assert world.physics_steps == world.burst_steps == 10
    assert world.seen == [0.0] * 3 + [1.0] * 4 + [2.0] * 3  # one step after each, in sim time
    world.destroy_node()


def test_checked_parameters_accept_whole_numbers_for_floats_and_name_bad_types(ros):
    world = CounterWorld(parameter_overrides=[Parameter("real_time_factor", value=0)])
    assert world.real_time_factor == 0.0 and isinstance(world.real_time_factor, float)
    assert world.declare_checked("pose", [0.0, 0.0, 0.0], lambda v: len(v) == 3, "[x, y, theta]") == [0.0] * 3
    world.destroy_node()
    with pytest.raises(InputError, match=r"parameter 'real_time_factor' = 'fast'"):
        CounterWorld(parameter_overrides=[Parameter("real_time_factor", value="fast")])
    with pytest.raises(InputError, match=r"parameter 'seed' = 1.5"):
        CounterWorld(parameter_overrides=[Parameter("seed", value=1.5)])


def test_pid_alive_is_true_for_a_running_process_and_false_once_it_is_reaped() -> None:
    import subprocess

    from sim_runtime.processes import pid_alive

    child = subprocess.Popen(["sleep", "30"])
    assert pid_alive(child.pid)
    child.kill()
    child.wait()
    assert not pid_alive(child.pid)


def test_a_child_started_with_die_with_parent_is_killed_when_its_parent_is_killed() -> None:
    import signal
    import subprocess
    import sys
    import time

    from sim_runtime.processes import pid_alive

    # The parent: starts `sleep` with the preexec, prints its pid, then waits to be killed.
    parent_code = (
        "import os, subprocess, sys, time; from sim_runtime.processes import die_with_parent; "
        "child = subprocess.Popen(['sleep', '120'], preexec_fn=die_with_parent(os.getpid())); "
        "print(child.pid, flush=True); time.sleep(120)"
    )
    parent = subprocess.Popen([sys.executable, "-c", parent_code], stdout=subprocess.PIPE, text=True)
    try:
        child = int(parent.stdout.readline())
        assert pid_alive(child)
        parent.send_signal(signal.SIGKILL)
        parent.wait(timeout=30)
        # killed by the kernel: gone once reaped, a zombie until then (a generous ceiling for a busy machine)
        deadline = time.monotonic() + 30
        while running(child) and time.monotonic() < deadline:
            time.sleep(0.05)
        assert not running(child), "the child outlived its killed parent"
    finally:
        parent.kill()
        parent.wait(timeout=30)


def running(pid: int) -> bool:
    """Whether ``pid`` exists and is not a zombie (dead, its parent not having reaped it yet)."""
    from pathlib import Path

    try:
        stat = Path(f"/proc/{pid}/stat").read_text()
    except (FileNotFoundError, ProcessLookupError):
        return False
    return stat.rpartition(")")[2].split()[0] != "Z"
