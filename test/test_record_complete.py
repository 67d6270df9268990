"""A world at real_time_factor 0 never outruns a recorder attached to it; at real time a recorder
that falls behind says how many messages it lost (sim_runtime.flow_control)."""

from __future__ import annotations

import itertools
import os
import signal
import subprocess
import tempfile
import time
from collections import defaultdict
from pathlib import Path

import yaml

from sim_runtime.bag import record
from sim_runtime.bag.reader import open_bag
from sim_runtime.bag.record import LOST_KEY, Recorder
from sim_runtime.bag.writer import BagWriter
from sim_runtime.msgs import time_from_msg
from sim_runtime.testing import spin_until
from sim_tools.cli import executable_command

ROOT = Path(__file__).resolve().parent.parent
NOT_RECORDED = "/rosout|/parameter_events"


class Process:
    """``robot_sims <name> <args>`` in its own process, its log in a file the test can read."""

    def __init__(self, name: str, *args: str) -> None:
        self.log = tempfile.TemporaryFile(mode="w+")  # noqa: SIM115 - closed in stop()
        self.popen = subprocess.Popen(
            executable_command(name, args),
            cwd=ROOT,
            env=dict(os.environ, PYTHONPATH=str(ROOT)),
            stdout=subprocess.DEVNULL,
            stderr=self.log,
            text=True,
        )

    def text(self) -> str:
        self.log.seek(0)
        return self.log.read()

    def signal(self, signum: int) -> None:
        self.popen.send_signal(signum)

    def stop(self) -> str:
        """Ctrl-C; the log once the process has ended."""
        if self.popen.poll() is None:
            self.popen.send_signal(signal.SIGCONT)
            self.popen.send_signal(signal.SIGINT)
            try:
                self.popen.wait(timeout=20)
            except subprocess.TimeoutExpired:
                self.popen.kill()
                self.popen.wait()
        text = self.text()
        self.log.close()
        return text


def world_process(rtf: float) -> Process:
    return Process("create_world", "--ros-args", "-p", f"real_time_factor:={rtf}")


def gaps(bag: Path) -> tuple[int, dict[str, int]]:
    """(clock ticks recorded, {topic: messages missing}) from the header stamps of every periodic
    topic and the /clock ticks, between the first and the last one recorded."""
    times: dict[str, list[float]] = defaultdict(list)
    for m in open_bag(bag).messages():
        stamp = m.msg.clock if m.topic == "/clock" else getattr(getattr(m.msg, "header", None), "stamp", None)
        if stamp is not None:
            times[m.topic].append(time_from_msg(stamp))
    missing = {}
    for topic, stamps in times.items():
        distinct = sorted(set(stamps))
        if len(distinct) < 3:
            continue  # latched or one-off messages: nothing periodic to check
        period = min(round(b - a, 6) for a, b in itertools.pairwise(distinct))
        expected = round((distinct[-1] - distinct[0]) / period) + 1
        if expected != len(distinct):
            missing[topic] = expected - len(distinct)
    return len(times["/clock"]), missing


class SlowRecorder(Recorder):
    """A recorder that needs a millisecond per message, with a subscription queue of 50 messages:
    a world running free fills the queue within a few dozen steps and the oldest messages drop."""

    def _write(self, tid: int, data: bytes) -> None:
        time.sleep(0.001)
        super()._write(tid, data)


def test_a_slow_recorder_beside_a_world_at_real_time_factor_0_records_every_message(executor, tmp_path, monkeypatch):
    monkeypatch.setattr(record, "RECORD_DEPTH", 50)
    recorder = SlowRecorder(BagWriter(tmp_path / "bag"), exclude=NOT_RECORDED, node_name="slow_recorder")
    executor.add_node(recorder)
    world = world_process(0.0)
    try:
        assert spin_until(executor, lambda: recorder.writer.message_count > 3000, timeout=90.0), world.text()
    finally:
        log = world.stop()
        recorder.close()
    ticks, missing = gaps(tmp_path / "bag")
    assert ticks > 100, log
    assert missing == {}, log


def test_a_stopped_recorder_holds_a_world_at_real_time_factor_0_only_briefly_and_the_world_says_so(
    executor, make_node, tmp_path
):
    from rosgraph_msgs.msg import Clock

    sim = []
    make_node("clock_watch").create_subscription(Clock, "/clock", lambda m: sim.append(time_from_msg(m.clock)), 10)
    recorder = Process("record", "-o", str(tmp_path / "bag"), "--exclude", NOT_RECORDED)
    world = world_process(0.0)
    try:
        assert spin_until(executor, lambda: "recording /clock" in recorder.text() and len(sim) > 50, timeout=90.0)
        assert spin_until(executor, lambda: "attached" in world.text(), timeout=30.0)  # the world follows it
        recorder.signal(signal.SIGSTOP)  # a hung recorder: its DDS threads stop too
        assert spin_until(executor, lambda: "has recorded nothing for" in world.text(), timeout=20.0)
        held_at = sim[-1]
        assert spin_until(executor, lambda: sim[-1] > held_at + 5.0, timeout=20.0)  # stepping on
    finally:
        recorder.stop()
        log = world.stop()
    assert "Traceback" not in log, log


def test_a_recorder_that_falls_behind_at_real_time_counts_its_lost_messages_in_its_log_and_metadata(
    executor, make_node, tmp_path
):
    from rosgraph_msgs.msg import Clock

    sim = []
    make_node("clock_watch").create_subscription(Clock, "/clock", lambda m: sim.append(time_from_msg(m.clock)), 10)
    recorder = Process("record", "-o", str(tmp_path / "bag"), "--exclude", NOT_RECORDED)
    world = world_process(5.0)  # 500 steps a second, so 1.5 s away loses more than a publisher keeps
    try:
        assert spin_until(executor, lambda: "recording /clock" in recorder.text() and len(sim) > 50, timeout=90.0)
        assert spin_until(executor, lambda: "attached" in world.text(), timeout=30.0)  # the world follows it
        recorder.signal(signal.SIGSTOP)
        stopped_at = sim[-1]
        assert spin_until(executor, lambda: sim[-1] > stopped_at + 7.5, timeout=20.0)
        recorder.signal(signal.SIGCONT)
        assert spin_until(executor, lambda: "messages lost so far" in recorder.text(), timeout=20.0)
    finally:
        world.stop()
        log = recorder.stop()
    assert "messages lost on the way" in log, log
    info = yaml.safe_load((tmp_path / "bag" / "metadata.yaml").read_text())["rosbag2_bagfile_information"]
    lost = {k: int(v) for k, v in (info["custom_data"] or {}).items() if k.startswith(LOST_KEY)}
    assert sum(lost.values()) > 0 and f"{LOST_KEY}./clock" in lost


def test_a_world_whose_clock_is_remapped_does_not_wait_for_recorders_of_the_root_clock(ros):
    from rclpy.parameter import Parameter

    from sim_runtime.world_node import SimWorldNode

    rtf0 = [Parameter("real_time_factor", value=0.0)]
    second = SimWorldNode(
        "w2", physics_rate=100.0, parameter_overrides=rtf0, cli_args=["--ros-args", "-r", "/clock:=/w2/clock"]
    )
    first = SimWorldNode("w1", physics_rate=100.0, parameter_overrides=rtf0)
    try:
        assert second._recorders is None and first._recorders is not None
        assert second.ready_to_step() and first.ready_to_step()
    finally:
        second.destroy_node()
        first.destroy_node()
