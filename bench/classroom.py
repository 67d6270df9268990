"""Benchmark a classroom on this machine: N students, each with a studio, a Create world at real
time with the robot moving, and the Simulator page open in a browser (Debian's headless Chromium).

    ROS_AUTOMATIC_DISCOVERY_RANGE=LOCALHOST .venv/bin/python bench/classroom.py [--students 2]
        [--seconds 20] [--baseline TREE]

As a classroom runs: one studio and one world per student, each student in a ROS domain of their
own; the robot turns on the spot with every layer drawn (the view changes every frame). First a
window with no page open (the ROS side of the studio alone), then one with every page open.
Measured per student:

- studio CPU, % of one core (/proc utime+stime over the window), with the page open and without:
  the difference is what an open page costs, goal <= 3 % of a core;
- the same as CPU-seconds per simulated second (the world runs at real time, so on an idle
  machine the two agree; on a shared machine this one is less sensitive to the load);
- the world's CPU, and the memory (PSS) of studio + world;
- page updates: the browser's gaps between two updates of the view (a MutationObserver), and the
  delay from a scan's arrival in this process to the browser's DOM holding it, p95;
- every world's real-time factor over the window (/clock against the wall clock), goal >= 0.99;
- the load average, and Chromium's CPU (the students' own machines in a real class: not counted).

``--baseline TREE`` runs the same classroom first with the studio of another checkout (e.g. a
``git worktree`` of the commit before a change) and prints the two side by side with ratios.
The projection: students an 8-core machine holds at <= 0.25 core per student (studio + world +
the Jupyter server's 1.6 % measured with the hub), and how many the 2 cores here hold.
"""

from __future__ import annotations

import argparse
import itertools
import os
import statistics
import subprocess
import sys
import time
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

ROOT = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(ROOT))
from _studio_support import CHROMEDRIVER, CHROMIUM, cpu_seconds, free_port, new_driver, use_local_ros  # noqa: E402

use_local_ros()

from sim_tools.cli import executable_command  # noqa: E402

GOAL_PAGE_CPU = 3.0  # % of a core per open page
GOAL_RTF = 0.99
GOAL_CORE_PER_STUDENT = 0.25  # 30 students on 8 cores
JUPYTER_SERVER_CPU = 1.6  # % of a core per active student's Jupyter server, measured with the hub (issue 27)

OBSERVER_JS = """
window.__updates = []; window.__drawn = [];
const view = document.querySelector('.studio-view');
let last = null;
new MutationObserver(() => {
  const now = Date.now() / 1000;
  window.__updates.push(now);
  const p = view.querySelector('polyline.lidar');
  const stamp = p && p.dataset.stamp;
  if (stamp && stamp !== last) { last = stamp; window.__drawn.push([stamp, now]); }
}).observe(view, {childList: true, subtree: true, attributes: true});
"""


@dataclass
class Student:
    """One student's world, studio, ROS listener and browser."""

    domain: int
    world: subprocess.Popen
    studio: subprocess.Popen
    port: int
    ros: Listener
    driver: Any = None


@dataclass
class Window:
    """What one measuring window saw of every student."""

    wall_s: float = 0.0
    load: tuple[float, float, float] = (0.0, 0.0, 0.0)
    studio_cpu: list[float] = field(default_factory=list)  # % of a core
    studio_cpu_per_sim: list[float] = field(default_factory=list)  # CPU-s per sim-s
    world_cpu: list[float] = field(default_factory=list)
    rtf: list[float] = field(default_factory=list)
    pss_mib: list[float] = field(default_factory=list)
    browser_cpu: float = 0.0
    gaps_ms: list[float] = field(default_factory=list)
    delays_ms: list[float] = field(default_factory=list)
    updates_per_s: list[float] = field(default_factory=list)


class Listener:
    """This process's node in one student's domain: the world's clock, when each scan arrived, and
    the turn command (spun by :func:`wait_until`)."""

    def __init__(self, domain: int) -> None:
        import rclpy
        from geometry_msgs.msg import Twist
        from rclpy.context import Context
        from rclpy.node import Node
        from rosgraph_msgs.msg import Clock
        from sensor_msgs.msg import LaserScan

        from sim_runtime.msgs import time_from_msg
        from sim_runtime.qos import ANY_PUBLISHER_QOS, CLOCK_QOS, COMMAND_PUBLISHER_QOS
        from sim_runtime.run import make_executor

        self.context = Context()
        rclpy.init(context=self.context, domain_id=domain)
        self.node = Node("classroom_bench", context=self.context)
        self.executor = make_executor(self.context)
        self.executor.add_node(self.node)
        self.arrivals: dict[str, float] = {}
        self.clock = (0.0, 0.0)  # (wall, sim) of the latest /clock
        self.node.create_subscription(
            LaserScan,
            "/scan",
            lambda m: self.arrivals.setdefault(f"{time_from_msg(m.header.stamp):.9f}", time.time()),
            ANY_PUBLISHER_QOS,
        )
        self.node.create_subscription(
            Clock, "/clock", lambda m: setattr(self, "clock", (time.monotonic(), time_from_msg(m.clock))), CLOCK_QOS
        )
        self.cmd = self.node.create_publisher(Twist, "/cmd_vel", COMMAND_PUBLISHER_QOS)
        LISTENERS.append(self)
        self.turn = Twist()
        self.turn.angular.z = 1.0  # every layer keeps changing

    def close(self) -> None:
        import rclpy

        LISTENERS.remove(self)
        self.executor.shutdown()
        self.node.destroy_node()
        rclpy.shutdown(context=self.context)


def say(text: str) -> None:
    """Progress, on stderr (a slow machine takes minutes to bring a classroom up)."""
    print(f"[classroom {time.strftime('%H:%M:%S')}] {text}", file=sys.stderr, flush=True)


LISTENERS: list[Listener] = []  # every student's, spun in turn by this process's only thread


def wait_until(condition, timeout: float) -> bool:
    """Spin every listener until ``condition()`` or ``timeout`` seconds."""
    deadline = time.monotonic() + timeout
    while not condition():
        if time.monotonic() > deadline:
            return False
        for listener in LISTENERS:
            listener.executor.spin_once(timeout_sec=0.002)
    return True


def spin_for(seconds: float) -> None:
    end = time.monotonic() + seconds
    wait_until(lambda: time.monotonic() >= end, seconds + 1.0)


def start_student(domain: int, tree: Path) -> Student:
    """A ``create_world`` and a studio (from ``tree``'s sources) in ``domain``."""
    env = {k: v for k, v in os.environ.items() if k != "PYTEST_CURRENT_TEST"}
    env["ROS_DOMAIN_ID"] = str(domain)
    env["PYTHONPATH"] = str(tree) + os.pathsep + env.get("PYTHONPATH", "")
    world = subprocess.Popen(executable_command("create_world"), env=env, stdout=subprocess.DEVNULL, cwd=tree)
    port = free_port()
    studio = subprocess.Popen(
        [sys.executable, "-m", "studio", "--port", str(port), "--workspace", str(tree)],
        env=env,
        stdout=subprocess.DEVNULL,
        cwd=tree,
    )
    return Student(domain, world, studio, port, Listener(domain))


def browser_cpu(drivers: list) -> float:
    """CPU seconds of every Chromium process the drivers started."""
    import psutil

    total = 0.0
    for d in drivers:
        try:
            for p in psutil.Process(d.service.process.pid).children(recursive=True):
                t = p.cpu_times()
                total += t.user + t.system
        except psutil.Error:
            pass
    return total


def pss_mib(pid: int) -> float:
    import psutil

    try:
        return psutil.Process(pid).memory_full_info().pss / 2**20
    except psutil.Error:
        return float("nan")


def measure_window(students: list[Student], seconds: float, with_pages: bool) -> Window:
    """Every student's CPU, rtf and memory over ``seconds`` (and their pages' updates)."""
    drivers = [s.driver for s in students if s.driver is not None]
    if with_pages:
        for s in students:
            s.driver.execute_script(OBSERVER_JS)
            s.ros.arrivals.clear()
    c0 = [(cpu_seconds(s.studio.pid), cpu_seconds(s.world.pid)) for s in students]
    k0 = [s.ros.clock for s in students]
    b0, t0 = browser_cpu(drivers), time.monotonic()
    spin_for(seconds)
    c1 = [(cpu_seconds(s.studio.pid), cpu_seconds(s.world.pid)) for s in students]
    k1 = [s.ros.clock for s in students]
    w = Window(wall_s=time.monotonic() - t0, load=os.getloadavg())
    w.browser_cpu = 100.0 * (browser_cpu(drivers) - b0) / w.wall_s / max(len(drivers), 1)
    for s, (sa, wa), (sb, wb), (kw0, ks0), (kw1, ks1) in zip(students, c0, c1, k0, k1, strict=True):
        sim = ks1 - ks0
        w.studio_cpu.append(100.0 * (sb - sa) / w.wall_s)
        w.studio_cpu_per_sim.append(100.0 * (sb - sa) / sim if sim > 0 else float("nan"))
        w.world_cpu.append(100.0 * (wb - wa) / w.wall_s)
        w.rtf.append(sim / (kw1 - kw0) if kw1 > kw0 else float("nan"))
        w.pss_mib.append(pss_mib(s.studio.pid) + pss_mib(s.world.pid))
        if with_pages:
            updates = s.driver.execute_script("return window.__updates")
            drawn = s.driver.execute_script("return window.__drawn")
            w.gaps_ms += [1000.0 * (b - a) for a, b in itertools.pairwise(updates)]
            w.updates_per_s.append(len(updates) / w.wall_s)
            arrivals = dict(s.ros.arrivals)
            w.delays_ms += [1000.0 * (t - arrivals[st]) for st, t in drawn if st in arrivals]
    return w


def run_classroom(tree: Path, n: int, seconds: float, first_domain: int) -> tuple[Window, Window]:
    """N students on ``tree``'s studio: (the window without pages, the one with every page open)."""
    students: list[Student] = []
    try:
        say(f"{tree}: starting {n} worlds and studios")
        for i in range(n):
            students.append(start_student(first_domain + i, tree))
        for s in students:
            assert wait_until(lambda s=s: len(s.ros.arrivals) > 5, 90.0), f"no scans in domain {s.domain}"
            s.ros.cmd.publish(s.ros.turn)
        say("every world publishes; the robots turn")
        spin_for(3.0)  # the studios have found their worlds
        idle = measure_window(students, seconds / 2, with_pages=False)
        say("measured without pages; opening the pages")
        lidar = "return !!document.querySelector('.studio-view polyline.lidar')"
        for s in students:
            s.driver = new_driver()
            s.driver.get(f"http://127.0.0.1:{s.port}/")
        for s in students:
            assert wait_until(lambda s=s: s.driver.execute_script(lidar), 90.0), f"no view in domain {s.domain}"
        say("every page draws; measuring")
        spin_for(2.0)  # past the page's first drawing
        paged = measure_window(students, seconds, with_pages=True)
    finally:
        for s in students:
            if s.driver is not None:
                s.driver.quit()
            for child in (s.studio, s.world):
                child.terminate()
            for child in (s.studio, s.world):
                child.wait(timeout=30)
            s.ros.close()
    return idle, paged


def p95(values: list[float]) -> float:
    return sorted(values)[int(0.95 * (len(values) - 1))] if values else float("nan")


def mean(values: list[float]) -> float:
    return statistics.fmean(values) if values else float("nan")


def figures(idle: Window, paged: Window) -> dict[str, float]:
    page = [a - b for a, b in zip(paged.studio_cpu, idle.studio_cpu, strict=True)]
    page_sim = [a - b for a, b in zip(paged.studio_cpu_per_sim, idle.studio_cpu_per_sim, strict=True)]
    per_student = mean(paged.studio_cpu) + mean(paged.world_cpu) + JUPYTER_SERVER_CPU
    return {
        "studio CPU, page open (% core)": mean(paged.studio_cpu),
        "studio CPU, no page (% core)": mean(idle.studio_cpu),
        "open page's cost (% core)": mean(page),
        "open page's cost (CPU-ms / sim-s)": 10.0 * mean(page_sim),
        "studio, page open (CPU-ms / sim-s)": 10.0 * mean(paged.studio_cpu_per_sim),
        "world CPU (% core)": mean(paged.world_cpu),
        "per student all incl. (% core)": per_student,
        "students on 8 cores (CPU)": 800.0 / per_student,
        "students on 2 cores (CPU)": 200.0 / per_student,
        "memory studio+world (MiB PSS)": mean(paged.pss_mib),
        "page updates per s": mean(paged.updates_per_s),
        "update gap p95 (ms)": p95(paged.gaps_ms),
        "scan arrival->DOM p95 (ms)": p95(paged.delays_ms),
        "scan arrival->DOM median (ms)": statistics.median(paged.delays_ms) if paged.delays_ms else float("nan"),
        "min world rtf, page open": min(paged.rtf),
        "Chromium CPU per page (% core)": paged.browser_cpu,
    }


def report(n: int, seconds: float, runs: dict[str, tuple[Window, Window]]) -> None:
    print(f"classroom: {n} students (a studio + a world each), {seconds:.0f} s with pages, {os.cpu_count()} CPUs")
    for name, (idle, paged) in runs.items():
        print(f"  {name}: load average during it {', '.join(f'{v:.2f}' for v in paged.load)}")
        print(f"  {name}: rtf per world {', '.join(f'{v:.3f}' for v in idle.rtf + paged.rtf)}")
    table = {name: figures(*windows) for name, windows in runs.items()}
    names = list(table)
    print(f"{'measure':38s}" + "".join(f"{name:>12s}" for name in names) + ("   ratio" if len(names) == 2 else ""))
    for key in table[names[-1]]:
        values = [table[name][key] for name in names]
        ratio = f"  {values[1] / values[0]:6.2f}" if len(values) == 2 and values[0] else ""
        print(f"{key:38s}" + "".join(f"{v:12.2f}" for v in values) + ratio)
    last = table[names[-1]]
    ok = last["open page's cost (% core)"] <= GOAL_PAGE_CPU and last["min world rtf, page open"] >= GOAL_RTF
    print(
        f"goals: page <= {GOAL_PAGE_CPU:g} % core, every rtf >= {GOAL_RTF}, "
        f"<= {100 * GOAL_CORE_PER_STUDENT:g} % core per student: "
        + ("met" if ok and last["per student all incl. (% core)"] <= 100 * GOAL_CORE_PER_STUDENT else "MISSED")
        + " (the machine may be shared: see the load average)"
    )


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--students", type=int, default=2)
    parser.add_argument("--seconds", type=float, default=20.0)
    parser.add_argument("--baseline", type=Path, help="another checkout whose studio to measure first")
    args = parser.parse_args()
    if not (Path(CHROMIUM).exists() and Path(CHROMEDRIVER).exists()):
        print("bench/classroom.py skipped: needs Debian's chromium and chromium-driver (apt-get install -y ...)")
        return 0
    first_domain = int(os.environ["ROS_DOMAIN_ID"])
    runs = {}
    if args.baseline is not None:
        runs["baseline"] = run_classroom(args.baseline.resolve(), args.students, args.seconds, first_domain)
    runs["this tree"] = run_classroom(ROOT, args.students, args.seconds, first_domain)
    report(args.students, args.seconds, runs)
    return 0


if __name__ == "__main__":
    sys.exit(main())
