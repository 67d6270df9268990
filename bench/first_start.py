"""A user's first start after ``pip install``: each world's time to "ready" on its first start
after the install and on the next one, and whether a subscriber joining it later stalls it.

Run:  .venv/bin/python bench/first_start.py [--keep DIR] [--worlds create_world arm] [--repeat N]
                                            [--no-build-warmup]

This checkout (its tracked files as they are now) is copied and pip-installed into a temporary
prefix (``--ignore-installed --no-deps``: the venv's own editable install is left alone), as any
``pip install`` or ``colcon build`` does: the copy has no numba cache, so the build's warm-up
(``setup.py``'s ``build_py``, :func:`sim_tools.warmup.build_cache`) compiles every kernel and ships
the cache beside the installed sources. ``--no-build-warmup`` installs without it
(``ROBOT_SIMS_BUILD_WARMUP=0``): numba's cache is then empty at the first start, as before the
install warmed it. Each world runs as a user runs it, ``robot_sims <world>`` in its own process
from that prefix; times are from launching it to its "ready" log line, with the CPU time the
world's process (and a helper it started) had used by then (what a loaded machine stretches into
more wall time). Once it is ready this process listens to ``/clock`` for 2 s, then subscribes to a
sensor: "first reading" is the time from subscribing to its first message, "clock gap" the
longest wait between two ``/clock`` messages in the 3 s after subscribing (the stall a joining
RViz or recorder would cause), next to the longest in the 2 s before. "compiling" says whether the
world logged that it compiled kernels. ``--repeat N`` measures each world's first start N times,
the installed prefix put back as the install left it before each (the machine is shared: the
quietest run is the figure). The machine's load is printed with each start.
"""

from __future__ import annotations

import argparse
import itertools
import os
import shutil
import signal
import subprocess
import sys
import sysconfig
import tempfile
import threading
import time
from dataclasses import dataclass, field
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(ROOT))
os.environ.setdefault("ROS_AUTOMATIC_DISCOVERY_RANGE", "LOCALHOST")
os.environ.setdefault("FASTRTPS_DEFAULT_PROFILES_FILE", str(ROOT / "config" / "fastdds_localhost.xml"))

import rclpy  # noqa: E402
from rclpy.qos import qos_profile_sensor_data  # noqa: E402
from rosgraph_msgs.msg import Clock  # noqa: E402
from sensor_msgs.msg import JointState, LaserScan, Range  # noqa: E402

from sim_runtime.kernels import COMPILING_NOTICE  # noqa: E402
from sim_runtime.qos import CLOCK_QOS  # noqa: E402
from sim_runtime.run import make_executor  # noqa: E402

#: world -> (its arguments, the sensor topic subscribed once it is ready, that topic's type)
WORLDS = {
    "create_world": (["-r", "__ns:=/first_start"], "/first_start/scan", LaserScan),
    # 20 steps a second, so that /clock is frequent enough to show a stall
    "simrobot_world": (["-p", "world_file:=simrobot/demo.yaml", "-p", "real_time_factor:=20.0"], "/r1/sens1", Range),
    "arm": (["-r", "__ns:=/first_start"], "/first_start/joint_states", JointState),
}
READY_TIMEOUT_S = 900.0


@dataclass
class Start:
    """One start of a world: its times (s) and what it logged."""

    ready_s: float = float("nan")
    ready_cpu_s: float = float("nan")
    compiling: bool = False
    first_reading_s: float = float("nan")
    gap_before_s: float = float("nan")
    gap_after_s: float = float("nan")
    log: list[str] = field(default_factory=list)


def load() -> str:
    return "load {:.1f} {:.1f} {:.1f}".format(*os.getloadavg())


def install_copy(work: Path, build_warmup: bool = True) -> tuple[Path, Path]:
    """pip-install a copy of this checkout's tracked files into ``work/prefix``: (prefix, site-packages).
    Without ``build_warmup`` the build ships no numba cache."""
    tree = work / "tree"
    files = subprocess.run(["git", "ls-files", "-z"], cwd=ROOT, capture_output=True, check=True).stdout
    for name in files.decode().split("\0"):
        if name and (ROOT / name).is_file():
            (tree / name).parent.mkdir(parents=True, exist_ok=True)
            shutil.copy2(ROOT / name, tree / name)
    prefix = work / "prefix"
    pip = [sys.executable, "-m", "pip", "install", "--quiet", "--prefix", str(prefix)]
    env = dict(os.environ, ROBOT_SIMS_BUILD_WARMUP="1" if build_warmup else "0")
    subprocess.run([*pip, "--ignore-installed", "--no-deps", str(tree)], check=True, env=env)
    return prefix, site_packages(prefix)


def site_packages(prefix: Path) -> Path:
    return Path(sysconfig.get_path("purelib", vars={"base": str(prefix), "platbase": str(prefix)}))


def launch(prefix: Path, site: Path, world: str, args: list[str]) -> subprocess.Popen:
    env = dict(
        os.environ,
        PYTHONPATH=str(site),  # ahead of the venv's editable install
        AMENT_PREFIX_PATH=os.pathsep.join([str(prefix), os.environ.get("AMENT_PREFIX_PATH", "")]),
    )
    command = [sys.executable, str(prefix / "bin" / "robot_sims"), world, "--ros-args", *args]
    return subprocess.Popen(
        command, cwd=prefix, env=env, stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True, bufsize=1
    )


def read_log(process: subprocess.Popen, start: Start, ready: threading.Event, t0: float) -> None:
    assert process.stdout is not None
    for line in process.stdout:
        start.log.append(line.rstrip())
        if COMPILING_NOTICE in line:
            start.compiling = True
        if "ready:" in line and not ready.is_set():
            start.ready_s = time.monotonic() - t0
            start.ready_cpu_s = cpu_seconds(process.pid)
            ready.set()
    ready.set()


def cpu_seconds(pid: int) -> float:
    """CPU time (user + system) the process and the helpers it waited for have used so far (Linux /proc)."""
    fields = Path(f"/proc/{pid}/stat").read_text().rsplit(")", 1)[1].split()
    return sum(int(v) for v in fields[11:15]) / os.sysconf("SC_CLK_TCK")


def longest_gap(times: list[float], since: float, until: float) -> float:
    """Longest time without a message between ``since`` and ``until`` (the whole window if none came)."""
    window = [since, *(t for t in times if since <= t <= until), until]
    return max(b - a for a, b in itertools.pairwise(window))


def spin_for(executor, seconds: float, until=lambda: False) -> None:
    deadline = time.monotonic() + seconds
    while time.monotonic() < deadline and not until():
        executor.spin_once(timeout_sec=0.005)


def one_start(node, executor, prefix: Path, site: Path, world: str) -> Start:
    args, topic, msg_type = WORLDS[world]
    start = Start()
    clock: list[float] = []
    clock_sub = node.create_subscription(Clock, "/clock", lambda _m: clock.append(time.monotonic()), CLOCK_QOS)
    ready = threading.Event()
    t0 = time.monotonic()
    process = launch(prefix, site, world, args)
    threading.Thread(target=read_log, args=(process, start, ready, t0), daemon=True).start()
    try:
        spin_for(executor, READY_TIMEOUT_S, ready.is_set)
        if process.poll() is not None or start.ready_s != start.ready_s:
            raise RuntimeError(f"{world} did not get ready:\n" + "\n".join(start.log[-20:]))
        spin_for(executor, 2.0)
        joined = time.monotonic()
        readings: list[float] = []
        sub = node.create_subscription(
            msg_type, topic, lambda _m: readings.append(time.monotonic()), qos_profile_sensor_data
        )
        spin_for(executor, 3.0)
        spin_for(executor, 30.0, lambda: bool(readings))
        start.first_reading_s = readings[0] - joined if readings else float("nan")
        start.gap_before_s = longest_gap(clock, joined - 2.0, joined)
        start.gap_after_s = longest_gap(clock, joined, joined + 3.0)
        node.destroy_subscription(sub)
    finally:
        process.send_signal(signal.SIGINT)
        try:
            process.wait(timeout=60)
        except subprocess.TimeoutExpired:
            process.kill()
            process.wait()
        node.destroy_subscription(clock_sub)
    return start


def report(world: str, label: str, start: Start) -> None:
    print(
        f"  {world:15s} {label:6s} ready {start.ready_s:6.1f} s ({start.ready_cpu_s:5.1f} s CPU), {load()}"
        f"  compiling logged: {'yes' if start.compiling else 'no'}"
        f"   first reading {start.first_reading_s:5.2f} s after subscribing"
        f"   clock gap {start.gap_after_s:5.3f} s (before joining {start.gap_before_s:5.3f} s)"
    )


def shipped_cache(site: Path) -> int:
    """How many kernels' numba cache indexes the install put beside its sources."""
    return sum(1 for _ in site.rglob("__pycache__/*.nbi"))


def put_back(prefix: Path, pristine: Path) -> None:
    """The prefix as the install left it (the numba cache a start added removed)."""
    shutil.rmtree(prefix)
    shutil.copytree(pristine, prefix, symlinks=True)


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument(
        "--keep", type=Path, help="install into this folder and keep it (default: a temporary one); reuse its install"
    )
    parser.add_argument("--worlds", nargs="+", choices=list(WORLDS), default=list(WORLDS), help="default: all")
    parser.add_argument("--repeat", type=int, default=1, help="first starts per world (default 1)")
    parser.add_argument("--no-build-warmup", action="store_true", help="install without the build's numba warm-up")
    opts = parser.parse_args()
    work = opts.keep or Path(tempfile.mkdtemp(prefix="first_start_"))
    rclpy.init()
    node = rclpy.create_node("first_start_bench")
    executor = make_executor()
    executor.add_node(node)
    try:
        pristine = work / "pristine"
        if pristine.is_dir():  # --keep of an earlier run: its install, as it left it
            prefix, site = work / "prefix", site_packages(work / "prefix")
            print(f"the install in {work} of an earlier run, {load()}")
        else:
            warmup = "without" if opts.no_build_warmup else "with"
            print(f"pip install of a copy of this checkout into {work}, {warmup} the build's warm-up, {load()}")
            t = time.monotonic()
            prefix, site = install_copy(work, build_warmup=not opts.no_build_warmup)
            print(f"  installed in {time.monotonic() - t:.0f} s, {load()}")
            shutil.copytree(prefix, pristine, symlinks=True)
        shipped = shipped_cache(site_packages(pristine))  # as installed, whatever a start added since
        print(f"  numba cache shipped beside the installed sources: {shipped} kernels")
        for world in opts.worlds:
            for run in range(opts.repeat):
                put_back(prefix, pristine)
                for label in ("first", "second"):
                    print(f"{world}, {label} start after the install (run {run + 1}), {load()}")
                    report(world, label, one_start(node, executor, prefix, site, world))
    finally:
        executor.shutdown()
        node.destroy_node()
        rclpy.shutdown()
        if opts.keep is None:
            shutil.rmtree(work, ignore_errors=True)
    return 0


if __name__ == "__main__":
    sys.exit(main())
