"""One-shot commands from fresh processes reach a running Create world, on a loaded machine.

    .venv/bin/python bench/commands_arrive.py [--tries 100] [--busy 3] [--cli /work/ros2cli_env]

A Create world runs at real_time_factor 1 in its own process while ``--busy`` CPU-bound loops
load the machine. Each try starts a fresh process that does what ``ros2 topic pub --once
/cmd_vel geometry_msgs/msg/Twist "{angular: {z: W}}"`` does in Jazzy (a reliable publisher, wait
until it matches a subscription, publish, stay 0.1 s, exit), with a new W each time (turning on
the spot: the robot never reaches a wall); the try counts as applied once the world's /odom
reports angular.z = W. Goal: every command applied.
``--cli`` runs the real ``ros2`` executable instead (``ros2 topic pub --once``) from a folder
holding ``pip install --target`` of ros2cli; ``--keep-alive`` is ros2topic's option of that name;
``--world-args`` adds ``-p`` rules to the world (e.g. a QoS override); ``--acked S`` makes our
publisher do what docs/conventions.md asks of one that exits: wait (at most S seconds) until every
matched reader has acknowledged the sample, then exit.

Why commands get lost (docs/conventions.md, "What a one-shot publisher must do"): the publisher
matches the world's reader before the loaded world has matched the publisher's writer; the sample
that arrives meanwhile is dropped, and only a writer still running when the world asks resends it.
"""

from __future__ import annotations

import argparse
import os
import shlex
import subprocess
import sys
import threading
import time
from collections import Counter
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(ROOT))
sys.path.insert(0, str(ROOT / "bench"))
os.environ.setdefault("ROS_AUTOMATIC_DISCOVERY_RANGE", "LOCALHOST")
os.environ.setdefault("FASTRTPS_DEFAULT_PROFILES_FILE", str(ROOT / "config" / "fastdds_localhost.xml"))

from record_worlds import exe, stop  # noqa: E402

BUSY_LOOP = "while 1: pass"
LOADS: list[float] = []  # the 1-minute load average after each try
ACKS: Counter[tuple[str, str]] = Counter()  # (verdict, acked or unacked as our publisher left): tries


def publish_once(topic: str, turn: float, reliability: str, keep_alive: float, acked: float = 0.0) -> None:
    """What ``ros2 topic pub --once`` does (Jazzy's ros2topic 0.32): a publisher with the default
    profile (reliable, volatile, depth 10), wait until a subscription matches, publish, keep the
    process ``--keep-alive`` seconds (default 0.1), exit."""
    import rclpy
    from geometry_msgs.msg import Twist
    from rclpy.qos import QoSProfile, ReliabilityPolicy

    rclpy.init()
    node = rclpy.create_node(f"pub_once_{os.getpid()}")
    qos = QoSProfile(depth=10, reliability=ReliabilityPolicy[reliability.upper()])
    publisher = node.create_publisher(Twist, topic, qos)
    while publisher.get_subscription_count() < 1:
        time.sleep(0.1)
    msg = Twist()
    msg.angular.z = turn
    publisher.publish(msg)
    from rclpy.duration import Duration

    if acked > 0.0:
        publisher.wait_for_all_acked(Duration(seconds=acked))
    time.sleep(keep_alive)
    # Whether every matched reader had acknowledged the sample as this writer leaves: after that
    # nothing can resend it (the bench prints it beside each verdict).
    print("acked" if publisher.wait_for_all_acked(Duration(nanoseconds=1)) else "unacked", flush=True)
    node.destroy_node()
    rclpy.shutdown()


def once_command(topic: str, turn: float, opts: argparse.Namespace) -> list[str]:
    """argv of one fresh publishing process."""
    keep = ["--keep-alive", str(opts.keep_alive), "--reliability", opts.reliability, "--acked", str(opts.acked)]
    if opts.cli:
        yaml = f"{{angular: {{z: {turn}}}}}"
        extra = ["--keep-alive", str(opts.keep_alive), "--qos-reliability", opts.reliability]
        ros2 = [sys.executable, str(Path(opts.cli) / "bin" / "ros2")]
        return [*ros2, "topic", "pub", "--once", *extra, topic, "geometry_msgs/msg/Twist", yaml]
    return [sys.executable, __file__, "--publish-once", str(turn), "--topic", topic, *keep]


class OdomWatcher:
    """Follows /odom's reported turn rate in a thread of this process."""

    def __init__(self) -> None:
        import rclpy
        from nav_msgs.msg import Odometry

        from sim_runtime.qos import SENSOR_SUBSCRIBER_QOS
        from sim_runtime.run import make_executor

        self.context = rclpy.Context()
        rclpy.init(context=self.context)
        self.node = rclpy.create_node("commands_watcher", context=self.context)
        self.speed: float | None = None
        self.count = 0  # odometry messages heard: tells a world that did not apply from a watcher that stalled
        self.node.create_subscription(Odometry, "/odom", self._on_odom, SENSOR_SUBSCRIBER_QOS)
        self.executor = make_executor(self.context)
        self.executor.add_node(self.node)
        self._running = True
        self._thread = threading.Thread(target=self._spin, daemon=True)
        self._thread.start()

    def _on_odom(self, msg) -> None:
        self.speed = msg.twist.twist.angular.z
        self.count += 1

    def _spin(self) -> None:
        while self._running and self.context.ok():
            self.executor.spin_once(timeout_sec=0.1)

    def wait_for_speed(self, speed: float, timeout: float) -> bool:
        deadline = time.monotonic() + timeout
        while time.monotonic() < deadline:
            if self.speed is not None and abs(self.speed - speed) < 1e-9:
                return True
            time.sleep(0.01)
        return False

    def verdict(self, speed: float, timeout: float) -> str:
        """After a miss: "late" if the speed shows within ``timeout``, "lost" once another second of
        odometry (50 messages) still shows the old one, else "stalled" (this watcher heard nothing:
        on a very busy machine its thread can starve, which says nothing about the world)."""
        start = self.count
        deadline = time.monotonic() + timeout
        while time.monotonic() < deadline:
            if self.speed is not None and abs(self.speed - speed) < 1e-9:
                return "late"
            if self.count - start >= 50:
                return "lost"
            time.sleep(0.01)
        return "stalled"

    def close(self) -> None:
        self._running = False
        self._thread.join(timeout=2)
        self.node.destroy_node()
        self.context.try_shutdown()


def run(opts: argparse.Namespace) -> tuple[int, int, list[float]]:
    """(tries, applied, seconds per try); a command that shows after ``--settle`` counts as applied
    (late), one the world's odometry goes on without is lost, and a try whose verdict this process
    could not hear is left out (stalled)."""
    watcher = OdomWatcher()
    world = exe("create_world", "--ros-args", "-p", "real_time_factor:=1.0", *shlex.split(opts.world_args))
    busy = [subprocess.Popen([sys.executable, "-c", BUSY_LOOP]) for _ in range(opts.busy)]
    applied, durations, tries = 0, [], opts.tries
    loads = LOADS
    acks = ACKS
    try:
        if not watcher.wait_for_speed(0.0, 600.0):  # a first start compiles kernels: minutes on a busy machine
            raise SystemExit(f"the world did not start:\n{stop(world)}")
        for i in range(opts.tries):
            speed = round(0.5 + 0.001 * (i + 1), 6) * (1 if i % 2 else -1)
            begin = time.monotonic()
            env = dict(os.environ, PYTHONPATH=opts.cli) if opts.cli else None
            command = once_command("/cmd_vel", speed, opts)
            try:  # a python start can take a minute at load 40: a publisher that never ran says nothing
                said = subprocess.run(command, check=True, timeout=300, env=env, capture_output=True, text=True)
            except subprocess.TimeoutExpired:
                print(f"  try {i + 1}: the publisher did not end in 300 s (left out)   load {os.getloadavg()[0]:.1f}")
                tries -= 1
                continue
            ok = watcher.wait_for_speed(speed, opts.settle)
            verdict = "applied" if ok else watcher.verdict(speed, 60.0)
            durations.append(time.monotonic() - begin)
            loads.append(os.getloadavg()[0])
            applied += verdict in ("applied", "late")
            tries -= verdict == "stalled"
            exit_state = said.stdout.split()[-1] if said.stdout.split() and not opts.cli else "-"
            acks[verdict, exit_state] += 1
            if not ok:
                print(
                    f"  try {i + 1}: v={speed} {verdict} (odom says {watcher.speed}; {exit_state} at exit)"
                    f"   load {loads[-1]:.1f}"
                )
            if (i + 1) % 10 == 0:
                print(f"  {i + 1} tries: {applied} applied; load {loads[-1]:.1f}", flush=True)
    finally:
        for process in busy:
            process.kill()
            process.wait()
        stop(world)
        watcher.close()
    return tries, applied, durations


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--tries", type=int, default=100, help="fresh publishing processes (default 100)")
    parser.add_argument("--busy", type=int, default=3, help="CPU-bound loops loading the machine (default 3)")
    parser.add_argument("--settle", type=float, default=5.0, help="seconds a command may take to show in /odom")
    parser.add_argument("--cli", help="publish with the real ros2 CLI: a folder holding a pip --target install of it")
    parser.add_argument("--reliability", default="reliable", choices=("reliable", "best_effort"))
    parser.add_argument("--keep-alive", type=float, default=0.1, help="seconds a publisher stays after publishing")
    parser.add_argument(
        "--acked", type=float, default=0.0, help="our publisher waits up to this long for acknowledgement (0 = no)"
    )
    parser.add_argument("--world-args", default="", help="extra ROS arguments of the world ('-p name:=value')")
    parser.add_argument("--publish-once", type=float, help=argparse.SUPPRESS)
    parser.add_argument("--topic", default="/cmd_vel", help=argparse.SUPPRESS)
    opts = parser.parse_args()
    if opts.publish_once is not None:
        publish_once(opts.topic, opts.publish_once, opts.reliability, opts.keep_alive, opts.acked)
        return
    print(
        f"{os.cpu_count()} CPUs, load {os.getloadavg()[0]:.1f}, {opts.busy} busy loops, {opts.tries} tries, "
        f"keep-alive {opts.keep_alive:g} s, acked {opts.acked:g} s, world args {opts.world_args!r}"
    )
    tries, applied, durations = run(opts)
    durations.sort()
    print(
        f"applied {applied} of {tries} one-shot commands ({'met' if applied == tries else 'MISSED'}); "
        f"median {durations[len(durations) // 2]:.2f} s per try; load {os.getloadavg()[0]:.1f} "
        f"(over the tries {min(LOADS, default=0):.1f}-{max(LOADS, default=0):.1f})"
    )
    if not opts.cli:
        print("verdict by acknowledgement as the publisher left:", dict(sorted(ACKS.items())))


if __name__ == "__main__":
    main()
