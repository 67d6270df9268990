"""Benchmark the bag recorder and player against the issue's goals.

    ROS_AUTOMATIC_DISCOVERY_RANGE=LOCALHOST .venv/bin/python bench/record.py [--rate 20000] [--seconds 3]

Recorder: a publisher process (pinned to CPU 1) sends mixed-size messages — 70 % short strings,
25 % 360-beam LaserScans (~1.5 kB), 5 % 64x64 OccupancyGrids (~4 kB) — at `--rate` messages/s
on three topics; the recorder (this process, pinned to CPU 0, zstd chunks) must write every
one. Player: replays 2 s of a 1,000 msg/s robot-like bag, then of the recorded scans+grids
(6,000 msg/s), at rate 1, and reports median / 99th percentile lateness against the schedule.
Goals: ≥ 20,000 msg/s with zero drops; median lateness ≤ 1 ms.
"""

from __future__ import annotations

import argparse
import os
import subprocess
import sys
import tempfile
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(ROOT))
os.environ.setdefault("ROS_AUTOMATIC_DISCOVERY_RANGE", "LOCALHOST")
os.environ.setdefault("FASTRTPS_DEFAULT_PROFILES_FILE", str(ROOT / "config" / "fastdds_localhost.xml"))

GOAL_RATE = 20_000
GOAL_LATENESS_MS = 1.0
TOPICS = ("/bench/chatter", "/bench/scan", "/bench/grid")


def _pin(cpu: int) -> None:
    if hasattr(os, "sched_setaffinity") and cpu < os.cpu_count():
        os.sched_setaffinity(0, {cpu})


def publisher(rate: float, seconds: float) -> None:
    """Publisher process: pre-serialised messages, paced in 1 ms batches; prints the count."""
    import rclpy
    from nav_msgs.msg import OccupancyGrid
    from rclpy.qos import HistoryPolicy, QoSProfile, ReliabilityPolicy
    from rclpy.serialization import serialize_message
    from sensor_msgs.msg import LaserScan
    from std_msgs.msg import String

    _pin(1)
    rclpy.init()
    node = rclpy.create_node("bench_publisher")
    qos = QoSProfile(history=HistoryPolicy.KEEP_LAST, depth=5000, reliability=ReliabilityPolicy.RELIABLE)
    types = (String, LaserScan, OccupancyGrid)
    pubs = [node.create_publisher(t, name, qos) for t, name in zip(types, TOPICS, strict=True)]
    grid = OccupancyGrid()
    grid.info.width = grid.info.height = 64
    grid.data = [0] * 4096
    payloads = [
        serialize_message(String(data="x" * 40)),
        serialize_message(LaserScan(ranges=[1.0] * 360)),
        serialize_message(grid),
    ]
    pattern = [0] * 14 + [1] * 5 + [2]  # 70 % / 25 % / 5 %
    deadline = time.monotonic() + 15
    while any(p.get_subscription_count() < 1 for p in pubs):
        if time.monotonic() > deadline:
            sys.exit("publisher: recorder never subscribed")
        time.sleep(0.01)
    time.sleep(0.2)
    total = int(rate * seconds)
    start = time.perf_counter()
    sent = 0
    while sent < total:
        due = min(total, int((time.perf_counter() - start) * rate) + 1)
        while sent < due:
            kind = pattern[sent % 20]
            pubs[kind].publish(payloads[kind])
            sent += 1
        time.sleep(0.0005)
    elapsed = time.perf_counter() - start
    time.sleep(1.0)  # let reliable retransmissions finish before the writers go away
    print(sent, elapsed, flush=True)
    node.destroy_node()
    rclpy.shutdown()


def bench_record(rate: float, seconds: float, folder: Path) -> tuple[int, int, float, float]:
    """(published, recorded, publish rate, record seconds) for one run."""
    import rclpy
    from rclpy.task import Future

    from sim_runtime.bag.record import Recorder
    from sim_runtime.bag.writer import BagWriter
    from sim_runtime.run import make_executor

    _pin(0)
    rclpy.init()
    recorder = Recorder(BagWriter(folder, compression="zstd"), list(TOPICS), clock="wall")
    executor = make_executor()
    executor.add_node(recorder)
    proc = subprocess.Popen(
        [sys.executable, __file__, "--publisher", "--rate", str(rate), "--seconds", str(seconds)],
        stdout=subprocess.PIPE,
        text=True,
        env=dict(os.environ, PYTHONPATH=str(ROOT)),
    )
    # Spin as `robot_sims record` does (spin_until_future_complete), not spin_once per message.
    publisher_done = Future()
    recorder.create_timer(
        0.1, lambda: proc.poll() is not None and not publisher_done.done() and publisher_done.set_result(True)
    )
    cpu0 = time.process_time()
    while not publisher_done.done():
        executor.spin_until_future_complete(publisher_done, timeout_sec=0.5)
    out = proc.stdout.read().split()
    sent, pub_elapsed = int(out[0]), float(out[1])
    deadline = time.monotonic() + 5
    while recorder.writer.message_count < sent and time.monotonic() < deadline:
        executor.spin_once(timeout_sec=0.05)
    cpu = time.process_time() - cpu0
    recorder.close()
    recorded = recorder.writer.message_count
    recorder.destroy_node()
    executor.shutdown()
    rclpy.shutdown()
    return sent, recorded, sent / pub_elapsed, cpu


def robot_bag(folder: Path, rate: float, seconds: float) -> Path:
    """A bag like a simulated robot's: scans, odometry and ranges at `rate` msg/s in total."""
    from nav_msgs.msg import Odometry
    from rclpy.serialization import serialize_message
    from sensor_msgs.msg import LaserScan, Range

    from sim_runtime.bag.writer import BagWriter, qos_profiles_yaml

    qos = qos_profiles_yaml([{"reliability": "best_effort"}])
    kinds = [
        ("/robot/scan", "sensor_msgs/msg/LaserScan", serialize_message(LaserScan(ranges=[1.0] * 360))),
        ("/robot/odom", "nav_msgs/msg/Odometry", serialize_message(Odometry())),
        ("/robot/sonar", "sensor_msgs/msg/Range", serialize_message(Range())),
    ]
    with BagWriter(folder) as w:
        ids = [w.add_topic(topic, type_name, qos) for topic, type_name, _ in kinds]
        for i in range(int(rate * seconds)):
            w.write(ids[i % 3], 10**9 + int(i * 1e9 / rate), kinds[i % 3][2])
    return folder


def bench_replay(folder: Path, seconds: float, topics: list[str] | None = None) -> tuple[float, float, int]:
    """(median ms, p99 ms, messages) lateness of replaying `seconds` of the bag at rate 1."""
    import numpy as np
    import rclpy

    from sim_runtime.bag.replay import SWITCH_INTERVAL, play_bag

    sys.setswitchinterval(SWITCH_INTERVAL)  # as `robot_sims replay` does
    rclpy.init()
    try:
        stats = play_bag(folder, duration=seconds, topics=topics)
    finally:
        rclpy.shutdown()
    late = np.asarray(stats.lateness_ns) / 1e6
    return float(np.median(late)), float(np.percentile(late, 99)), stats.published


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--rate", type=float, default=GOAL_RATE, help="messages/s to publish")
    parser.add_argument("--seconds", type=float, default=3.0)
    parser.add_argument("--publisher", action="store_true", help=argparse.SUPPRESS)
    opts = parser.parse_args()
    if opts.publisher:
        publisher(opts.rate, opts.seconds)
        return
    with tempfile.TemporaryDirectory() as tmp:
        folder = Path(tmp) / "bench_bag"
        sent, recorded, pub_rate, cpu = bench_record(opts.rate, opts.seconds, folder)
        drops = sent - recorded
        size = sum(f.stat().st_size for f in folder.glob("*.mcap"))
        print(
            f"recorder: {sent} msgs published at {pub_rate:,.0f} msg/s, {recorded} recorded, "
            f"{drops} dropped, recorder CPU {cpu:.2f} s ({recorded / cpu:,.0f} msg per CPU-s), "
            f"bag {size / 1e6:.1f} MB"
        )
        print(f"{'metric':34s} {'goal':>12s} {'measured':>12s} {'ratio':>7s}")
        kept = pub_rate * recorded / sent  # messages/s that made it into the bag
        print(f"{'recorded msg/s (1 core)':34s} {GOAL_RATE:>12,} {kept:>12,.0f} {kept / GOAL_RATE:>6.2f}x")
        print(f"{'dropped messages':34s} {0:>12} {drops:>12} {'ok' if drops == 0 else 'FAIL':>7s}")
        runs = [
            ("1,000 msg/s robot bag", robot_bag(Path(tmp) / "robot", 1000, 3.0), None),
            ("6,000 msg/s scans+grids above", folder, ["/bench/scan", "/bench/grid"]),
        ]
        for label, bag, topics in runs:
            median, p99, n = bench_replay(bag, 2.0, topics)
            print(
                f"{'replay median lateness (ms)':34s} {GOAL_LATENESS_MS:>12.3f} {median:>12.3f} "
                f"{GOAL_LATENESS_MS / max(median, 1e-6):>6.1f}x  {label}"
            )
            print(f"{'replay p99 lateness (ms)':34s} {'':>12s} {p99:>12.3f}          ({n} msgs)")


if __name__ == "__main__":
    main()
