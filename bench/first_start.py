"""A user's first ``robot_sims create_world``: time to the first /scan with numba's cache cold vs after
``python -m sim_runtime.warmup`` (what ``make venv`` runs).

Run:  ROS_AUTOMATIC_DISCOVERY_RANGE=LOCALHOST .venv/bin/python bench/first_start.py

Deletes the numba cache of this checkout (``__pycache__/*.nbi``, ``*.nbc``) twice: before the cold
start, and before the warm-up (so the warm-up's own time is from cold too). The world runs as a user
starts it, ``robot_sims create_world`` in its own process; the time is from launching it to this
process receiving its first LaserScan. ``compiled at start`` counts the kernels the world had to
compile itself (numba's ``NUMBA_DEBUG_CACHE`` "data saved" lines): 0 means the warm-up covered it.
"""

from __future__ import annotations

import argparse
import os
import signal
import subprocess
import sys
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(ROOT))
os.environ.setdefault("ROS_AUTOMATIC_DISCOVERY_RANGE", "LOCALHOST")
os.environ.setdefault("FASTRTPS_DEFAULT_PROFILES_FILE", str(ROOT / "config" / "fastdds_localhost.xml"))

import rclpy  # noqa: E402
from sensor_msgs.msg import LaserScan  # noqa: E402

from sim_runtime.cli import executable_command  # noqa: E402
from sim_runtime.qos import SENSOR_SUBSCRIBER_QOS  # noqa: E402
from sim_runtime.run import make_executor  # noqa: E402

PACKAGES = ("create_sim", "simrobot_sim", "arm_sim", "sim_runtime")
NAMESPACE = "/first_start_bench"


def clear_numba_cache() -> int:
    """Delete this checkout's numba cache files; returns how many."""
    files = [p for pkg in PACKAGES for p in (ROOT / pkg).rglob("__pycache__/*") if p.suffix in (".nbi", ".nbc")]
    for path in files:
        path.unlink()
    return len(files)


def load() -> str:
    return "load {:.2f} {:.2f} {:.2f}".format(*os.getloadavg())


def time_to_first_scan(executor, node) -> tuple[float, int]:
    """(wall seconds from launching create_world to its first /scan here, kernels it compiled)."""
    scans: list[LaserScan] = []
    subscription = node.create_subscription(LaserScan, f"{NAMESPACE}/scan", scans.append, SENSOR_SUBSCRIBER_QOS)
    env = dict(os.environ, PYTHONPATH=str(ROOT), NUMBA_DEBUG_CACHE="1")
    start = time.monotonic()
    world = subprocess.Popen(
        executable_command("create_world", ["--ros-args", "-r", f"__ns:={NAMESPACE}"]),
        env=env,
        cwd=ROOT,
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
        text=True,
    )
    try:
        while not scans:
            if world.poll() is not None:
                raise RuntimeError(f"create_world ended: {world.communicate()[1]}")
            if time.monotonic() - start > 600:
                raise RuntimeError("no /scan within 600 s")
            executor.spin_once(timeout_sec=0.01)
        elapsed = time.monotonic() - start
    finally:
        world.send_signal(signal.SIGINT)
        out, _err = world.communicate(timeout=60)
        node.destroy_subscription(subscription)
    return elapsed, out.count("data saved to")


def main() -> int:
    argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter).parse_args()
    rclpy.init()
    node = rclpy.create_node("first_start_bench")
    executor = make_executor()
    executor.add_node(node)
    try:
        cleared = clear_numba_cache()
        print(f"cold cache ({cleared} numba cache files deleted), {load()}")
        cold, cold_compiled = time_to_first_scan(executor, node)
        print(f"  create_world first start to first /scan: {cold:6.1f} s   compiled at start: {cold_compiled}")

        clear_numba_cache()
        print(f"warm-up from a cold cache, {load()}")
        start = time.monotonic()
        subprocess.run([sys.executable, "-m", "sim_runtime.warmup"], cwd=ROOT, env=dict(os.environ), check=True)
        warmup = time.monotonic() - start
        print(f"  python -m sim_runtime.warmup: {warmup:6.1f} s")
        print(f"after the warm-up, {load()}")
        warm, warm_compiled = time_to_first_scan(executor, node)
        print(f"  create_world first start to first /scan: {warm:6.1f} s   compiled at start: {warm_compiled}")
        print(f"cold / after warm-up: {cold / warm:.1f}x ({cold:.1f} s vs {warm:.1f} s)")
    finally:
        executor.shutdown()
        node.destroy_node()
        rclpy.shutdown()
    return 0


if __name__ == "__main__":
    sys.exit(main())
