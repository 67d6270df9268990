"""Benchmark the studio's live view in a real browser (Debian's headless Chromium).

    ROS_AUTOMATIC_DISCOVERY_RANGE=LOCALHOST .venv/bin/python bench/studio.py [--seconds 15]

A ``create_world`` (default rates: scan 10 Hz with 681 beams, pose/odom/bump/cliff/wall 50 Hz,
sonar 20 Hz, camera 10 Hz) runs in its own process, the studio in another, and Chromium shows
the Simulator page with every layer on while the robot turns on the spot. Measured:

- frames/s: scans drawn per second in the browser (a MutationObserver reads the LIDAR
  polyline's stamp), goal >= 10 (every 10 Hz scan drawn);
- delay: from the scan's arrival in this process (its publication, within a fraction of a
  millisecond on one machine) to the browser's DOM holding it, median and 90th percentile,
  goal median <= 100 ms;
- studio CPU (% of one core, /proc utime+stime), goal <= 25 %; side by side with the same
  studio and world with no page open (the ROS side alone), as the baseline.
"""

from __future__ import annotations

import argparse
import os
import subprocess
import sys
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(ROOT))
from _studio_support import CHROMEDRIVER, CHROMIUM, cpu_seconds, free_port, new_driver, use_local_ros  # noqa: E402

use_local_ros()

from sim_tools.cli import executable_command  # noqa: E402

GOAL_FPS = 10.0
GOAL_DELAY_MS = 100.0
GOAL_CPU = 25.0

OBSERVER_JS = """
window.__drawn = [];
const view = document.querySelector('.studio-view');
let last = null;
new MutationObserver(() => {
  const p = view.querySelector('polyline.lidar');
  const stamp = p && p.dataset.stamp;
  if (stamp && stamp !== last) { last = stamp; window.__drawn.push([stamp, Date.now() / 1000]); }
}).observe(view, {childList: true, subtree: true});
"""


def start_children(port: int) -> tuple[subprocess.Popen, subprocess.Popen]:
    """A ``create_world`` and a studio on ``port``, in this run's ROS domain."""
    env = {k: v for k, v in os.environ.items() if k != "PYTEST_CURRENT_TEST"}
    env["PYTHONPATH"] = str(ROOT) + os.pathsep + env.get("PYTHONPATH", "")
    world = subprocess.Popen(executable_command("create_world"), env=env, stdout=subprocess.DEVNULL)
    studio = subprocess.Popen(
        [sys.executable, "-m", "studio", "--port", str(port), "--workspace", str(ROOT)],
        env=env,
        stdout=subprocess.DEVNULL,
        cwd=ROOT,
    )
    return world, studio


class Listener:
    """This process's node: when each scan arrived (by stamp), and the turn command."""

    def __init__(self) -> None:
        import rclpy
        from geometry_msgs.msg import Twist
        from rclpy.node import Node
        from sensor_msgs.msg import LaserScan

        from sim_runtime.msgs import time_from_msg
        from sim_runtime.qos import ANY_PUBLISHER_QOS, COMMAND_PUBLISHER_QOS
        from sim_runtime.run import make_executor

        rclpy.init()
        self.node = Node("studio_bench")
        self.executor = make_executor()
        self.executor.add_node(self.node)
        self.arrivals: dict[str, float] = {}
        self.node.create_subscription(
            LaserScan,
            "/scan",
            lambda m: self.arrivals.setdefault(f"{time_from_msg(m.header.stamp):.9f}", time.time()),
            ANY_PUBLISHER_QOS,
        )
        self.cmd = self.node.create_publisher(Twist, "/cmd_vel", COMMAND_PUBLISHER_QOS)
        self.turn = Twist()
        self.turn.angular.z = 1.0  # keep every layer changing

    def spin_until(self, condition, timeout: float) -> bool:
        from sim_runtime.testing import spin_until

        return spin_until(self.executor, condition, timeout=timeout)

    def close(self) -> None:
        import rclpy

        self.executor.shutdown()
        self.node.destroy_node()
        rclpy.shutdown()


def measure(seconds: float) -> tuple[float, float, float, list, dict[str, float]]:
    """Run the world, the studio and the page: (studio CPU without a page, with it, seconds
    watched, the browser's (stamp, drawn at) list, this process's stamp → arrival)."""
    port = free_port()
    world, studio = start_children(port)
    ros = Listener()
    driver = None

    def studio_cpu(for_s: float) -> float:
        c0, t0 = cpu_seconds(studio.pid), time.monotonic()
        ros.spin_until(lambda: time.monotonic() - t0 >= for_s, timeout=for_s + 5)
        return 100.0 * (cpu_seconds(studio.pid) - c0) / (time.monotonic() - t0)

    try:
        assert ros.spin_until(lambda: len(ros.arrivals) > 5, timeout=60.0), "no scans from create_world"
        ros.cmd.publish(ros.turn)
        idle_cpu = studio_cpu(seconds / 2)
        driver = new_driver()
        driver.get(f"http://127.0.0.1:{port}/")
        lidar = "return !!document.querySelector('.studio-view polyline.lidar')"
        ros.spin_until(lambda: driver.execute_script(lidar), timeout=60)
        driver.execute_script(OBSERVER_JS)
        ros.arrivals.clear()
        t0 = time.time()
        view_cpu = studio_cpu(seconds)
        elapsed = time.time() - t0
        drawn = driver.execute_script("return window.__drawn")
    finally:
        if driver is not None:
            driver.quit()
        for child in (studio, world):
            child.terminate()
            child.wait(timeout=20)
        ros.close()
    return idle_cpu, view_cpu, elapsed, drawn, ros.arrivals


def report(seconds: float, idle_cpu: float, view_cpu: float, elapsed: float, drawn: list, arrivals: dict) -> None:
    delays = sorted(1000.0 * (t - arrivals[s]) for s, t in drawn if s in arrivals)
    fps = len(drawn) / elapsed
    median = delays[len(delays) // 2] if delays else float("nan")
    p90 = delays[int(len(delays) * 0.9)] if delays else float("nan")
    scans_published = len(arrivals) / elapsed
    load = ", ".join(f"{v:.1f}" for v in os.getloadavg())
    print(f"studio live view, {seconds:.0f} s, {os.cpu_count()} CPUs, load average {load}")
    print(f"{'measure':34s} {'value':>9s} {'goal':>9s} {'ratio':>7s}")
    ratio = fps / GOAL_FPS
    print(f"{'scans drawn per s (published/s)':34s} {fps:9.1f} {GOAL_FPS:9.1f} {ratio:7.2f}  ({scans_published:.1f})")
    print(f"{'delay arrival->DOM median (ms)':34s} {median:9.1f} {GOAL_DELAY_MS:9.1f} {median / GOAL_DELAY_MS:7.2f}")
    print(f"{'delay arrival->DOM p90 (ms)':34s} {p90:9.1f}")
    print(f"{'studio CPU, page open (% core)':34s} {view_cpu:9.1f} {GOAL_CPU:9.1f} {view_cpu / GOAL_CPU:7.2f}")
    print(f"{'studio CPU, no page (baseline)':34s} {idle_cpu:9.1f}  page/baseline {view_cpu / max(idle_cpu, 0.1):.2f}")
    ok = fps >= GOAL_FPS * 0.95 and median <= GOAL_DELAY_MS and view_cpu <= GOAL_CPU
    print("all goals met" if ok else "GOAL MISSED (check the load average: the machine may be busy)")


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--seconds", type=float, default=15.0)
    args = parser.parse_args()
    if not (Path(CHROMIUM).exists() and Path(CHROMEDRIVER).exists()):
        print("bench/studio.py skipped: needs Debian's chromium and chromium-driver (apt-get install -y ...)")
        return 0
    report(args.seconds, *measure(args.seconds))
    return 0


if __name__ == "__main__":
    sys.exit(main())
