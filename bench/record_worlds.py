"""Record each world's full default output from a separate process, as a user would, and count
what is missing.

    ROS_AUTOMATIC_DISCOVERY_RANGE=LOCALHOST .venv/bin/python bench/record_worlds.py [--seconds 6]

For each world (create_world on its example map, simrobot_world on the demo world, arm with
the IRB120) a world process runs at real_time_factor 1 beside a `robot_sims record` process.
After the run, every periodic topic's header stamps must advance by exactly one period (a gap
is a dropped message) between the first and last message recorded. Goal: zero drops.
"""

from __future__ import annotations

import argparse
import itertools
import os
import signal
import subprocess
import sys
import tempfile
import time
from collections import defaultdict
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(ROOT))
os.environ.setdefault("ROS_AUTOMATIC_DISCOVERY_RANGE", "LOCALHOST")
os.environ.setdefault("FASTRTPS_DEFAULT_PROFILES_FILE", str(ROOT / "config" / "fastdds_localhost.xml"))

from sim_tools.cli import executable_command  # noqa: E402

WORLDS = {
    "create_world": ["-p", "config_file:=" + str(ROOT / "config/create/example_config.txt")],
    # 1 s steps: run 10x faster so a few seconds hold enough steps to check.
    "simrobot_world": ["-p", "world_file:=" + str(ROOT / "config/simrobot/demo.yaml"), "-p", "real_time_factor:=10.0"],
    "arm": [],
}


def exe(name: str, *args: str) -> subprocess.Popen:
    """``robot_sims name args`` in its own process; its log goes to a temporary file (a pipe
    nobody reads until the end can fill up and block the process)."""
    log = tempfile.TemporaryFile(mode="w+")  # noqa: SIM115 - read after the process ends, then closed
    process = subprocess.Popen(
        executable_command(name, args),
        cwd=ROOT,
        env=dict(os.environ, PYTHONPATH=str(ROOT)),
        stdout=subprocess.DEVNULL,
        stderr=log,
        text=True,
    )
    process.log = log  # type: ignore[attr-defined]
    return process


def stop(process: subprocess.Popen) -> str:
    """Ctrl-C the process and return its log."""
    process.send_signal(signal.SIGINT)
    try:
        process.wait(timeout=30)
    except subprocess.TimeoutExpired:
        process.kill()
        process.wait()
    process.log.seek(0)  # type: ignore[attr-defined]
    return process.log.read()  # type: ignore[attr-defined]


def drops(bag: Path) -> tuple[int, int, dict[str, int]]:
    """(messages, topics checked, {topic: missing messages}) from header-stamp gaps."""
    from sim_runtime.bag.reader import open_bag
    from sim_runtime.msgs import time_from_msg

    stamps: dict[str, list[float]] = defaultdict(list)
    total = 0
    for m in open_bag(bag).messages():
        total += 1
        header = getattr(m.msg, "header", None)
        if header is not None:
            stamps[m.topic].append(time_from_msg(header.stamp))
    missing = {}
    checked = 0
    for topic, times in stamps.items():
        if len(times) < 3 or len(set(times)) == 1:
            continue  # latched or one-off messages: nothing periodic to check
        steps = sorted({round(b - a, 6) for a, b in itertools.pairwise(times) if b > a})
        period = steps[0]
        checked += 1
        expected = round((times[-1] - times[0]) / period) + 1
        if expected != len(set(times)):
            missing[topic] = expected - len(set(times))
    return total, checked, missing


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--seconds", type=float, default=6.0, help="wall seconds recorded per world")
    parser.add_argument("--verbose", action="store_true", help="print each world's log")
    args = parser.parse_args()
    print(f"{os.cpu_count()} CPUs, load average {os.getloadavg()[0]:.1f}")
    print(f"{'world':16s} {'messages':>9s} {'topics':>7s} {'dropped':>8s}   goal: 0 dropped")
    for world, world_args in WORLDS.items():
        with tempfile.TemporaryDirectory() as folder:
            bag = Path(folder) / "bag"
            recorder = exe("record", "-o", str(bag), "--exclude", "/rosout|/parameter_events")
            time.sleep(1.0)  # the recorder is listening before the world starts: nothing is missed at the start
            node = exe(world, "--ros-args", "-p", "real_time_factor:=1.0", *world_args)  # later -p wins
            time.sleep(args.seconds)
            world_err = stop(node)
            if args.verbose:
                print(world_err)
            time.sleep(0.5)  # the last messages in flight reach the recorder
            record_err = stop(recorder)
            if node.returncode or recorder.returncode:
                print(f"{world}: exit {node.returncode}/{recorder.returncode}\n{world_err}\n{record_err}")
                continue
            total, checked, missing = drops(bag)
            lost = sum(missing.values())
            print(f"{world:16s} {total:9d} {checked:7d} {lost:8d}   {'met' if lost == 0 else missing}")


if __name__ == "__main__":
    main()
